# Every target depends on `setup`, so a fresh clone needs nothing but Python >= 3.11.
PY      ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
EXTRAS  ?= dev,cluster

.PHONY: setup demo test test-fast bench bench-smoke lint clean papers papers-full package-configs

setup: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	# the distribution was called `tuner` before it was renamed attitude-tuner: drop the old one and its
	# metadata, or both would register the same objective kinds
	$(BIN)/python -m pip uninstall --quiet --yes tuner 2>/dev/null || true
	rm -rf tuner.egg-info
	$(BIN)/python -m pip install --quiet -e ".[$(EXTRAS)]"
	touch $(STAMP)

demo: setup
	$(BIN)/tuner run configs/demo.yaml

# two pytest workers (pytest-xdist): the suite is mostly single-threaded, so this halves CI time on 2 cores
test: setup
	$(BIN)/python -m pytest -n 2

# everything but the tests marked slow (over about a second each on a warm cache): under 2 min warm on 2 cores
test-fast: setup
	NUMBA_CACHE_DIR=$(CURDIR)/.cache/numba $(BIN)/python -m pytest -n 2 -m "not slow"

bench: setup
	$(BIN)/python -m pip install --quiet -e ".[$(EXTRAS),bench]"   # the peers measured side by side
	$(BIN)/python -m benchmarks.run --full

bench-smoke: setup
	$(BIN)/python -m benchmarks.run --smoke

lint: setup
	$(BIN)/ruff check .

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache

# The seeds' claims from configs/papers/ at reduced budgets, five seeds each: one run writes docs/papers.json
# (every row's per-seed values) and docs/papers.md drawn from it (verdicts by the rules at its top; budgets sized
# for under 15 min on 2 cores; the page gives the measured wall and CPU time). papers-full: the papers' own
# budgets (hours). Regenerate from a clean tree, then commit both files: the header names the commit measured.
papers: setup
	NUMBA_CACHE_DIR=$(CURDIR)/.cache/numba $(BIN)/python -m benchmarks.papers

papers-full: setup
	NUMBA_CACHE_DIR=$(CURDIR)/.cache/numba $(BIN)/python -m benchmarks.papers --full

# The example jobs shipped in the package (tuner/data/configs/, `tuner demo`): copies of the configs/*.yaml
# that need no shared data (no `broad:` source). Run after editing one; tests/tuner/test_package.py checks it.
#: the README's own-CSV example: the job, its column map and its recording
OWN_CSV := own_csv.yaml imu_columns.yaml imu.csv

package-configs:
	for f in configs/*.yaml; do grep -q 'broad:' "$$f" || cp -L "$$f" tuner/data/configs/; done
	cp -L $(addprefix configs/examples/,$(OWN_CSV)) tuner/data/configs/examples/
