# simroad — two commands do all set-up: `make demo` and `make test`.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-$(shell cat pyproject.toml | cksum | cut -d' ' -f1)

.PHONY: all demo paper test test-fast lint bench figures clean help

# Python's bytecode cache on, whatever the shell says: with PYTHONDONTWRITEBYTECODE set
# (some containers set it) every test worker, sweep worker and CLI subprocess compiles
# simroad from source and pytest rewrites every test module again, on every run.
unexport PYTHONDONTWRITEBYTECODE

help:
	@echo "make demo     set up .venv and run the main job: a small ablation (writes runs/demo)"
	@echo "make paper    the paper's experiment in closed loop, paired seeds on evaluation worlds (648 episodes, the longest job; runs/paper)"
	@echo "make test     set up .venv with test extras; lint (ruff), types (mypy), then the whole test suite (about 4 minutes on 2 idle cores, warm caches)"
	@echo "make test-fast  lint, types and the tests not marked slow (the edit loop: about 1 minute on 2 idle cores, warm caches)"
	@echo "make lint     ruff check, ruff format --check and mypy only"
	@echo "make bench    run the benchmarks (medians and side-by-side ratios)"
	@echo "make figures  regenerate the pictures in docs/"

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,bench]'
	rm -f $(VENV)/.installed-*
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/simroad ablate --config experiments/demo.toml
	$(BIN)/simroad videos --out runs/demo/videos

# A lint, format or type error fails the build before any test runs.
lint: $(STAMP)
	$(BIN)/ruff check simroad tests benchmarks examples
	$(BIN)/ruff format --check simroad tests benchmarks examples
	$(BIN)/mypy

# worksteal: a worker that runs dry takes half of the other's queue, so no long test
# runs alone at the end. test-fast runs a third worker: its short tests spend part of
# their time waiting on subprocesses and files, which the third worker fills.
test: lint
	$(BIN)/python -m pytest -q -n 2 --dist worksteal

test-fast: lint
	$(BIN)/python -m pytest -q -n 3 --dist worksteal -m "not slow"

paper: $(STAMP)
	$(BIN)/simroad ablate --config experiments/paper.toml

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

figures: $(STAMP)
	$(BIN)/simroad figure camera --out docs/camera.png
	$(BIN)/simroad figure weather --out docs/weather.png
	$(BIN)/simroad figure friction --out docs/friction.png
	$(BIN)/simroad figure windscreen --out docs/windscreen.png
	$(BIN)/simroad evaluate-detector --seeds 1 --frames 2 --figure docs/qualitative.png

clean:
	rm -rf $(VENV) runs .pytest_cache .mypy_cache .ruff_cache
