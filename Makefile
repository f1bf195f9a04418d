# Two entry points, each creating the virtual environment (.venv) when it is missing:
#   make run    executes the notebooks at a small preset into build/ (notebooks + HTML)
#   make test   runs the unit tests and the notebooks (nbval), and builds the documentation site
# Both set OPNET_STATIC_WIDGETS=1: no kernel drives the widgets there, so notebooks show pictures instead.
#   make docs   the documentation site into build/docs/ (warnings are errors, every reference must resolve;
#               Python >= 3.11, and every extra: the API pages import the modules)
#   make reproduce PRESET=default   Table 1 + ablation into build/reproduce-$(PRESET) (results.json/md, figures)
PYTHON ?= python3
VENV   ?= .venv
PRESET ?= quick
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
# torch is pinned where the environment is created: 2.13.0 is a CPU build on the project's
# machines; an unpinned torch would pull a multi-GB CUDA build. The package accepts any recent torch.
TORCH  ?= torch==2.13.0

.PHONY: run test docs reproduce clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet "$(TORCH)"
	$(PY) -m pip install --quiet -e ".[all,test,docs]"
	touch $(STAMP)

run: $(STAMP)
	mkdir -p build/notebooks build/html
	OPNET_PRESET=$(PRESET) OPNET_STATIC_WIDGETS=1 $(PY) -m jupyter nbconvert --to notebook --execute notebooks/[0-9]*.ipynb \
		--ExecutePreprocessor.store_widget_state=False --output-dir build/notebooks
	$(PY) -m jupyter nbconvert --to html build/notebooks/*.ipynb --output-dir build/html
	@echo "executed notebooks: build/notebooks/  HTML: build/html/"

test: $(STAMP)
	$(PY) -m ruff format --check .
	$(PY) -m ruff check .
	OPNET_PRESET=quick OPNET_STATIC_WIDGETS=1 $(PY) -m pytest

# The notebooks are rendered from their committed outputs (no execution): about 15 s on 2 cores.
docs: $(STAMP)
	rm -rf build/docs build/jupyter_execute
	$(PY) -m sphinx -W --keep-going -n -b html docs build/docs
	@echo "documentation: build/docs/index.html"

reproduce: $(STAMP)
	$(PY) -m opnet reproduce --preset $(PRESET) --out build/reproduce-$(PRESET)

clean:
	rm -rf build $(VENV)
