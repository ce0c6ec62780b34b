# uavwind -- every command of the project. `make help` lists them.
# A fresh clone needs only Python 3.11 and make: the venv is built from environment.txt.

PYTHON  ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
PROFILE ?= paper
JOBS    ?= -1

export PYTHONPATH := $(CURDIR)
export PYTHONHASHSEED := 0
# papermill loses every figure under a non-interactive backend: never inherit one
unexport MPLBACKEND

.DEFAULT_GOAL := help
.PHONY: help venv test bench clean

help:  ## list the targets
	@grep -hE '^[a-zA-Z_-]+:.*## ' $(MAKEFILE_LIST) | sed -E 's/:.*## /\t/' | expand -t 16

$(STAMP): environment.txt
	$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), "uavwind pins need Python 3.11, got " + sys.version'
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --disable-pip-version-check --quiet -r environment.txt
	touch $@

venv: $(STAMP)  ## build .venv from environment.txt (only when missing or outdated)

test: $(STAMP)  ## run the test suite
	$(BIN)/python -m pytest -q

bench: $(STAMP)  ## print speed and memory figures (no pass/fail); FULL=1 adds the paper profile
	$(BIN)/python benchmarks/bench.py

clean:  ## remove caches and build products (never finished results)
	rm -rf .pytest_cache .benchmarks
	find . -name __pycache__ -not -path './$(VENV)/*' -prune -exec rm -rf {} +
