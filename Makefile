# repro: regenerate the figures of the driven-granular-fluid papers.
#   make all-figures            every figure (profile: small)
#   make figure FIG=fig19       one figure; PROFILE=ci|small|paper, JOBS=N
#   make test / test-slurm / bench / ci / report / sensitivity
#   make example                fig3 by numpy and matplotlib script stages (pipelines/examples/)
CARGO ?= cargo
PROFILE ?= small
JOBS ?=
REPRO ?= $(CARGO) run --release --locked --quiet --
JOBS_FLAG = $(if $(JOBS),--jobs $(JOBS),)

.PHONY: venv example convergence build test test-slurm bench ci ci-figures all-figures figure status gc report sensitivity coverage-small

build:
	$(CARGO) build --release --locked

# The README's test command: unit and integration tests (release: the physics tests
# run millions of events).
# Then the ci profile of the CI-checked figures (`ci: true` in their YAML),
# their regression check against tests/golden/ci.json (docs/figures.md), and
# their report, the HTML one checked in headless Chromium (docs/report.md).
# The tutorial's test (tests/tutorial.rs) and `make example` need the Python
# of `make venv`: it installs while the binary compiles (2-3 min each on a fresh
# clone), and either failing stops the target.
# The ci figures build (niced) while the tests compile and run: they take the
# cores that the compile's serial stretches and the tests' waits (Slurm, one
# test binary at a time) leave idle; results do not depend on the load. Both
# print their progress here; the figures' log is also .repro/log/LAST-RUN.log.
REPRO_BIN ?= target/release/repro
test:
	$(MAKE) venv & venv=$$!; $(CARGO) build --release --locked && wait $$venv
	nice -n 10 $(REPRO_BIN) figure --ci --profile ci $(JOBS_FLAG) & figs=$$!; \
	  REPRO_REQUIRE_VENV=1 $(CARGO) test --release --locked; tests=$$?; \
	  wait $$figs; figures=$$?; \
	  if [ $$tests != 0 ]; then echo "make test: the tests failed" >&2; exit 1; fi; \
	  if [ $$figures != 0 ]; then echo "make test: the ci figures failed" >&2; exit 1; fi
	$(MAKE) example
	$(REPRO) regress --profile ci
	$(REPRO) report --profile ci --html
	$(CARGO) test --release --locked --test report_html -- --ignored

# The Slurm executor against a local single-node Slurm (started if needed; root),
# with the two-minute chain of jobs past a partition's time limit that `make
# test` leaves out.
test-slurm:
	scripts/slurm-local.sh start
	REPRO_REQUIRE_SLURM=1 $(CARGO) test --release --locked --test slurm -- --include-ignored

# The Python of the script stages (pipelines/examples/requirements.txt) in a
# virtual environment under the ignored .repro/ (pip reaches PyPI).
VENV = .repro/venv
venv: $(VENV)/.installed
$(VENV)/.installed: pipelines/examples/requirements.txt
	python3 -m venv $(VENV)
	$(VENV)/bin/pip install --quiet -r pipelines/examples/requirements.txt
	touch $@

# Fig. 3's Q(t) computed by a numpy script stage, drawn by a matplotlib one and
# checked against the built-in kind (its `check` stage fails beyond rounding),
# at the ci profile: the trajectories are those `make test` built (one store).
example: venv
	PATH="$(CURDIR)/$(VENV)/bin:$$PATH" $(REPRO) figure fig3-numpy --root pipelines/examples --store .repro/store --profile ci $(JOBS_FLAG)

bench:
	$(CARGO) bench --locked

# Would CI notice eps 0.90 -> 0.88 or the radius ratio 1.43 -> 1.40, and does it
# stay quiet without a change? Three fresh master seeds each (docs/accuracy.md);
# about an hour on 2 cores, so not part of `make test`.
sensitivity:
	REPRO="$(REPRO)" JOBS="$(JOBS)" scripts/sensitivity.sh

# Do the default profile's quoted errors cover their spread? The eps = 0.9
# sweep's headline figures and intruder-fig5 at four fresh master seeds
# (docs/coverage-small.md); `repro plan fig2 fig4 fig15 fig19 intruder-fig5`
# plans 1.62 core-hours a seed, so about 6.5 in all: not part of `make test`.
coverage-small:
	$(REPRO) coverage --profile small --seeds 101,102,103,104 --docs $(JOBS_FLAG) fig2 fig4 fig15 fig19 intruder-fig5

all-figures:
	$(REPRO) figure --all --profile $(PROFILE) $(JOBS_FLAG)
	$(REPRO) report --profile $(PROFILE) --html

# The sweeps in N of the numbers that disagree at small (docs/figures.md,
# "Convergence in N"): 2.74 core-hours of simulation planned at small (`repro
# plan convergence-tau ... convergence-eps --profile small`), too slow for CI;
# their ci versions (a few small N) are built and gated by `make test`.
convergence:
	$(REPRO) figure convergence-tau convergence-exponents convergence-chi4-box convergence-cutoff convergence-intruder convergence-collapse convergence-eps --profile $(PROFILE) $(JOBS_FLAG)

# The gallery and key-number table of the built figures: results/REPORT.md and
# results/report/index.html (docs/report-PROFILE.md too with DOCS=1).
report:
	$(REPRO) report --profile $(PROFILE) --html $(if $(DOCS),--docs,)

figure:
	@test -n "$(FIG)" || { echo "usage: make figure FIG=fig19 [PROFILE=ci|small|paper] [JOBS=N]"; exit 2; }
	$(REPRO) figure $(FIG) --profile $(PROFILE) $(JOBS_FLAG)

status:
	@test -n "$(FIG)" || { echo "usage: make status FIG=fig19 [PROFILE=...]"; exit 2; }
	$(REPRO) why $(FIG) --profile $(PROFILE)

gc:
	$(REPRO) gc

# Small-N versions of every figure, as CI checks them.
ci-figures:
	@if ls pipelines/*.yaml >/dev/null 2>&1; then $(REPRO) figure --all --profile ci $(JOBS_FLAG); else echo "no pipelines/*.yaml yet"; fi

ci: test ci-figures
