# uavwind -- every command of the project. `make help` lists them.
# A fresh clone needs only Python 3.11 and make: the venv is built from environment.txt.

PYTHON  ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
# numba's on-disk cache of the kernels is kept beside their sources (__pycache__), not in the
# venv: a fresh clone beside a built venv, or `make clean`, leaves it empty. So the warmup that
# fills it has its own stamp there, and runs again when the cache is gone
WARM    := uavwind/__pycache__/uavwind-warmup.done
PROFILE ?= paper
JOBS    ?= -1
BOOK_JOBS ?= $(shell nproc 2>/dev/null || echo 1)
# the suite's processes (pytest-xdist; 0: one process): a test module, the dask tests and the
# book's tests are each one unit of work (tests/conftest.py), the book's last
TEST_JOBS ?= $(shell nproc 2>/dev/null || echo 1)
RUN_FLAGS ?=# extra flags for `make results`, e.g. RUN_FLAGS="--times times.json"
SCHEDULER ?=# a dask.distributed scheduler address: `make book SCHEDULER=tcp://host:8786` fills the cache on that cluster
BOOK    ?= book
GEN     := $(BOOK)/generated
NB_DIR  ?= notebooks# the pages' sources (a test points it at a folder of its own)
# timeouts [s]: no build step may hang. A cell over CELL_TIMEOUT fails its page with the cell
# shown; a page over PAGE_TIMEOUT (kernel start, a hung kernel) is killed; the fill and the
# HTML build have their own. Pages read the cache; the fill is where the computing is.
CELL_TIMEOUT ?= 600
PAGE_TIMEOUT ?= 1200
FILL_TIMEOUT ?= $(if $(filter quick,$(PROFILE)),1800,10800)
BENCH_TIMEOUT ?= 14400  # [s] a whole `make bench` (FULL=1 builds the paper book; ONLY=builds four builds)
HTML_TIMEOUT ?= 1200
PIP_TIMEOUT  ?= 1800
WARMUP_TIMEOUT ?= 900
TEST_TIMEOUT ?= 1800  # [s] a whole `make test`
CHECK_TIMEOUT ?= 5400  # [s] a whole `make check` (CI allows 90 minutes)
TIMEOUT := timeout --kill-after=20
# pages read what the fill computed: a page that would compute a result fails, naming it
READ_ONLY := UAVWIND_PAGES_READ_ONLY=1
# pages run BOOK_JOBS at a time, so each page's soft-DTW kernels run serially (unless
# UAVWIND_SOFTDTW_PARALLEL is set): a numba thread waiting for a core another page holds
# spins (`ONLY=threads make bench`)
PAGE_THREADS := $(if $(filter-out 1,$(BOOK_JOBS)),UAVWIND_SOFTDTW_PARALLEL=$(or $(UAVWIND_SOFTDTW_PARALLEL),0))
# every notebook under notebooks/ is a page (tests/test_registry.py: each experiment of the
# registry has its notebook, and each notebook its line in book/_toc.yml)
NOTEBOOKS := $(basename $(notdir $(wildcard $(NB_DIR)/*.md)))
EXECUTED  := $(addprefix $(GEN)/,$(addsuffix .ipynb,$(NOTEBOOKS)))
LIBRARY   := $(wildcard uavwind/*.py uavwind/*/*.py uavwind/*/*/*.py uavwind/study/paper_values/*)
MATHJAX   := $(BOOK)/_vendor/mathjax/MathJax.js
PLOTLYJS  := $(BOOK)/_vendor/plotly/plotly.min.js
CSS       := $(BOOK)/_vendor/uavwind.css
HTML      := $(BOOK)/_build/html/index.html

export PYTHONPATH := $(CURDIR)
export PYTHONHASHSEED := 0
# the checkout's result cache (the library's own default is the user cache folder)
UAVWIND_RESULTS ?= $(CURDIR)/data/results
export UAVWIND_RESULTS
# papermill loses every figure under a non-interactive backend: never inherit one
unexport MPLBACKEND
# the venv is installed without compiling its 186 packages' bytecode (53 s of the 126 s
# install on 2 cores); each process then writes the bytecode of what it imports, once, so
# an inherited PYTHONDONTWRITEBYTECODE (set in many CI images) would make every page's
# kernel and worker compile its imports from source again
unexport PYTHONDONTWRITEBYTECODE

# the pins install in two halves side by side (--no-deps: no resolver, disjoint files):
# 36 s instead of 66 s for a fresh venv on 2 cores, the same files and `pip freeze`
PIP_INSTALL := $(BIN)/python -m pip install --disable-pip-version-check --quiet --no-deps --no-compile

.DEFAULT_GOAL := help
.PHONY: help venv test check bench book results lab clean clean-results FORCE

help:  ## list the targets
	@grep -hE '^[a-zA-Z_-]+:.*## ' $(MAKEFILE_LIST) | sed -E 's/:.*## /\t/' | expand -t 16

# the venv: the pins, then the package itself, editable (a script outside the checkout imports
# this checkout), then every numba kernel compiled once into numba's cache, the engine beside
# the multirotor and tslearn's reference kernels (python -m uavwind.warmup): later processes
# (pages, tests, a newcomer's first loop) load them instead of compiling
$(STAMP): environment.txt
	$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), "uavwind pins need Python 3.11, got " + sys.version'
	$(PYTHON) -m venv $(VENV)
	grep '==' environment.txt | awk 'NR % 2 == 1' > $(VENV)/pins.0
	grep '==' environment.txt | awk 'NR % 2 == 0' > $(VENV)/pins.1
	$(TIMEOUT) $(PIP_TIMEOUT) sh -c '$(PIP_INSTALL) -r $(VENV)/pins.0 & a=$$!; \
	  $(PIP_INSTALL) -r $(VENV)/pins.1 || { wait $$a; exit 1; }; wait $$a'
	$(BIN)/python -m pip check --disable-pip-version-check
	PIP_NO_INDEX=1 $(TIMEOUT) $(PIP_TIMEOUT) $(BIN)/python -m pip install --disable-pip-version-check --quiet --no-deps \
	  --no-build-isolation --no-compile -e .
	touch $@

$(WARM): $(STAMP)
	$(TIMEOUT) $(WARMUP_TIMEOUT) sh -c '$(BIN)/python -m uavwind.warmup engine & a=$$!; \
	  $(BIN)/python -m uavwind.warmup sim reference || { wait $$a; exit 1; }; wait $$a'
	@mkdir -p $(dir $@)
	touch $@

venv: $(WARM)  ## build .venv from environment.txt, the package editable, its kernels compiled (only when missing or outdated)

# two tiers (tests/conftest.py): `make test` runs every test but the slow ones (-m "not slow":
# the evidence at scale), within 5 minutes on 2 cores of the slower host kind, venv included;
# `make check` runs them all and builds the quick book beside them: what CI runs (.ci/run).
# --durations: where the suite's own time goes, printed with every run
PYTEST := $(BIN)/python -m pytest -q -n $(TEST_JOBS) --dist loadgroup --no-loadscope-reorder --durations=20
test: $(WARM)  ## run the tests but the slow ones (TEST_JOBS processes; `make check` runs them all)
	$(TIMEOUT) $(TEST_TIMEOUT) $(PYTEST) -m "not slow"

check: $(WARM)  ## run every test, the slow ones too, with the quick book built beside them (what CI runs)
	$(TIMEOUT) $(CHECK_TIMEOUT) $(PYTEST)

bench: $(WARM)  ## print speed and memory figures (no pass/fail); FULL=1 adds the paper book, ONLY=<section> one section (ONLY=builds: make test, the quick book and make check on fresh clones, twice)
	$(TIMEOUT) $(BENCH_TIMEOUT) $(BIN)/python benchmarks/bench.py

# every result the book shows, under the readings its pages show, and every analysis its pages read (Exp 13
# with $$UAVWIND_NEURALFLY), in one process and one pool of workers, longest task first;
# the notebooks then read them from the cache (and compute only what is missing)
results: $(WARM)  ## compute every registered entry (experiments under the readings their pages show, and the analyses) into UAVWIND_RESULTS (default data/results; PROFILE=paper|quick; cached, resumable)
	$(TIMEOUT) $(FILL_TIMEOUT) $(BIN)/python -m uavwind run all --reading all --profile $(PROFILE) --jobs $(JOBS) --no-tables $(if $(SCHEDULER),--scheduler $(SCHEDULER)) $(RUN_FLAGS)

# the results first (one pool over every experiment, its progress shown as it goes), then
# the notebooks BOOK_JOBS at a time (they read the cache, each output kept together), then
# the HTML. `-o results`: the notebooks' `| results` was just made, so it is not run again
# (a second run would only re-check the cache, and overwrite the fill's --times record)
book: $(WARM)  ## run the experiments (papermill) and build the book (PROFILE=paper|quick)
	@$(MAKE) --no-print-directory results
	@$(MAKE) --no-print-directory -o results -j$(BOOK_JOBS) --output-sync=target $(HTML)
	@echo "book: $(HTML)"

# the profile is a file, rewritten only when PROFILE changes, so notebooks rerun then
$(GEN)/.profile: FORCE
	@mkdir -p $(GEN)
	@echo "$(PROFILE)" | cmp -s - $@ || echo "$(PROFILE)" > $@

# a page that reads Neural-Fly's flights also reads what the cache cannot say: whether they are
# there ($$UAVWIND_NEURALFLY), and which files. The stamp is rewritten only when that changes,
# so the page reruns when the data arrive, go or change (Make tracks files, not variables)
DATA_PAGES := $(basename $(notdir $(shell grep -l -e UAVWIND_NEURALFLY -e neuralfly $(NB_DIR)/*.md 2>/dev/null)))
$(GEN)/.neuralfly: FORCE
	@mkdir -p $(GEN)
	@{ echo "folder: $${UAVWIND_NEURALFLY:-}"; \
	   if [ -n "$${UAVWIND_NEURALFLY:-}" ] && [ -d "$$UAVWIND_NEURALFLY" ]; then \
	     ls -lL --time-style=+%s "$$UAVWIND_NEURALFLY" 2>&1; fi; } > $@.new
	@if cmp -s $@.new $@; then rm -f $@.new; else mv $@.new $@; fi

$(addprefix $(GEN)/,$(addsuffix .ipynb,$(DATA_PAGES))): $(GEN)/.neuralfly

# a page's driver is run as a script, not `-m uavwind.report.pages`: it then imports none of the
# package (which its kernel imports): 1 CPU-s a page less (uavwind/report/pages.py)
$(GEN)/%.ipynb: $(NB_DIR)/%.md $(GEN)/.profile $(LIBRARY) $(STAMP) | results
	@mkdir -p $(GEN)/.src
	@echo "page $*"
	@$(READ_ONLY) $(PAGE_THREADS) $(TIMEOUT) $(PAGE_TIMEOUT) $(BIN)/python uavwind/report/pages.py $< $(GEN)/.src/$*.out.ipynb \
	    --profile $(PROFILE) --jobs $(JOBS) --execution-timeout $(CELL_TIMEOUT) --start-timeout 120 --cwd $(CURDIR) \
	  || { rc=$$?; echo "book: page $< failed (exit $$rc$$( [ $$rc -ge 124 ] && echo ': over PAGE_TIMEOUT=$(PAGE_TIMEOUT) s' ))" \
	       "-- the cell is named above; a cell over CELL_TIMEOUT=$(CELL_TIMEOUT) s is shown in full" >&2; exit 1; }
	mv $(GEN)/.src/$*.out.ipynb $@

$(MATHJAX): $(STAMP)
	rm -rf $(BOOK)/_vendor/mathjax
	mkdir -p $(BOOK)/_vendor
	cp -r $$($(BIN)/python -c 'import jupyter_server_mathjax, pathlib; print(pathlib.Path(jupyter_server_mathjax.__file__).parent / "static")') $(BOOK)/_vendor/mathjax

# plotly.js for the Explore page, from the pinned plotly package: no CDN
$(PLOTLYJS): $(STAMP)
	mkdir -p $(dir $@)
	cp $$($(BIN)/python -c 'import plotly, pathlib; print(pathlib.Path(plotly.__file__).parent / "package_data" / "plotly.min.js")') $@

# the book's own style sheet (wide tables scroll in the text column), beside the vendored files
$(CSS): $(BOOK)/uavwind.css
	mkdir -p $(dir $@)
	cp $< $@

# the landing page says which profile this build shows (a quick build: provisional verdicts)
$(GEN)/build_note.md: $(GEN)/.profile
	@if [ "$(PROFILE)" = paper ]; then \
	  echo "*This build shows the **paper** profile: the loop counts each page states.*" > $@; \
	else \
	  echo "**This build shows the *$(PROFILE)* profile, a few loops per setting: every verdict in it is provisional** (each page says its counts; \`make book\` builds the paper profile)." > $@; \
	fi

$(HTML): $(EXECUTED) $(GEN)/build_note.md $(MATHJAX) $(PLOTLYJS) $(CSS) $(wildcard $(BOOK)/*.md) $(BOOK)/references.bib \
         $(BOOK)/_config.yml $(BOOK)/_toc.yml
	$(TIMEOUT) $(HTML_TIMEOUT) $(BIN)/jupyter-book build $(BOOK) --warningiserror --keep-going --quiet
	touch $@

lab: $(WARM)  ## JupyterLab on the notebooks (open the .md files as notebooks)
	$(BIN)/jupyter lab notebooks/

clean:  ## remove caches and build products (never finished results)
	rm -rf .pytest_cache .benchmarks $(BOOK)/_build $(GEN) $(BOOK)/_vendor
	find . -name __pycache__ -not -path './$(VENV)/*' -prune -exec rm -rf {} +

clean-results:  ## delete the cached experiment results in UAVWIND_RESULTS (default data/results)
	rm -rf "$(UAVWIND_RESULTS)"

FORCE:
