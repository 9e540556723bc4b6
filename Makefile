# repro: regenerate the figures of the driven-granular-fluid papers.
CARGO ?= cargo
PROFILE ?= small

.PHONY: build test bench ci

build:
	$(CARGO) build --release --locked

# The README's test command: unit and integration tests (release: the physics tests
# run millions of events).
test:
	$(CARGO) test --release --locked

bench:
	$(CARGO) bench --locked

ci: test
