# repro: regenerate the figures of the driven-granular-fluid papers.
CARGO ?= cargo
PROFILE ?= small

.PHONY: build test bench ci all-figures

build:
	$(CARGO) build --release --locked

# The README's test command: unit and integration tests (release: the physics tests
# run millions of events).
test:
	$(CARGO) test --release --locked
	$(CARGO) run --release --locked --quiet -- figure $(FIGURES) --profile ci
	$(CARGO) run --release --locked --quiet -- regress --profile ci

# Every figure of issue 5 at $(PROFILE) (default small); the shared eps = 0.9
# ensemble is simulated once for all of them.
FIGURES = fig2 fig3 fig4 fig15 fig19
all-figures:
	$(CARGO) run --release --locked --quiet -- figure $(FIGURES) --profile $(PROFILE)

bench:
	$(CARGO) bench --locked

ci: test
