# Two commands do all the set-up on a fresh clone: `make demo` and `make test`.
# Each creates the virtual environment .venv and installs rmbench into it on first use.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
# pytest processes (pytest-xdist): one per core, a test file per process (its module fixtures built
# once); each keeps its BLAS and torch pools to its share
TEST_WORKERS ?= auto

.PHONY: demo test bench bench-summary docs install clean

install: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	# torch first, pinned: this machine's CPU build (a range admitting newer releases pulls CUDA)
	$(BIN)/python -m pip install --quiet torch==2.13.0
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/rmbench demo

test: $(STAMP)
	@if [ -f ../shared/tools/check_layers.py ]; then $(BIN)/python ../shared/tools/check_layers.py src/rmbench; fi
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder --durations=15 sim_tests

bench: $(STAMP)
	$(BIN)/python bench/modes.py | tee bench/results/modes.txt
	$(BIN)/python bench/invalidation.py | tee bench/results/invalidation.txt
	$(BIN)/python bench/campaign_speed.py | tee bench/results/campaign_speed.txt
	$(BIN)/python bench/user_wait.py | tee bench/results/user_wait.txt
	$(BIN)/python bench/identify_speed.py | tee bench/results/identify_speed.txt
	$(BIN)/python bench/control_loop.py | tee bench/results/control_loop.txt
	$(BIN)/python -m pip install --quiet -e '.[test,bench]'
	$(BIN)/python bench/modal_vs_sdypy.py | tee bench/results/modal_vs_sdypy.txt
	$(BIN)/python bench/modal_robustness.py | tee bench/results/modal_robustness.txt
	$(BIN)/python bench/gap_blind.py | tee bench/results/gap_blind.txt
	$(BIN)/python bench/gap_real.py | tee bench/results/gap_real.txt
	$(BIN)/python bench/calibrate_real.py | tee bench/results/calibrate_real.txt
	cd bench && ../$(BIN)/python calibrate.py --time-default | tee results/calibrate.txt
	cd bench && ../$(BIN)/python calibrate_design.py | tee results/calibrate_design.txt
	$(BIN)/python bench/gap_tracker.py | tee bench/results/gap_tracker.txt
	$(BIN)/python bench/predict.py | tee bench/results/predict.txt
	$(BIN)/python bench/path.py | tee bench/results/path.txt
	$(BIN)/python bench/rcsa.py | tee bench/results/rcsa.txt
	$(BIN)/python bench/lobes.py | tee bench/results/lobes.txt
	$(BIN)/python bench/any_robot.py | tee bench/results/any_robot.txt
	$(BIN)/python bench/report.py | tee bench/results/report.txt
	$(BIN)/python bench/summary.py

# bench/README.md: an index of the benches (how each runs, its results file), no figures (standard library only)
bench-summary: $(STAMP)
	$(BIN)/python bench/summary.py

# the API reference from the docstrings (docs/api, sphinx autodoc + napoleon), any warning an error;
# -E: every page read afresh, so an unchanged page's warnings are not hidden by the cache
docs: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[docs]'
	$(BIN)/python -m sphinx -E -W --keep-going -q -b html docs/api docs/_build/html
	@echo "API reference: docs/_build/html/index.html"

clean:
	rm -rf $(VENV) rmbench_demo
