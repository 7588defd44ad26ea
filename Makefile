# Every target creates .venv when it is missing and installs the package with all extras.
# torch is pinned to the CPU build through constraints.txt.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
PYTEST_ARGS ?=

.PHONY: install test demo reproduce convergence bench clean

$(STAMP): pyproject.toml constraints.txt
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q -c constraints.txt -e ".[train,dev]"
	touch $(STAMP)

install: $(STAMP)

## make test: the whole test suite (a few minutes on 2 cores)
test: $(STAMP)
	$(PY) -m pytest -q -n 2 $(PYTEST_ARGS)

## make demo: the main job (simulate the paper's drive, print and plot it)
demo: $(STAMP)
	$(VENV)/bin/mdr-drive demo --out results/demo

## make reproduce: the paper's Figs. 3-5 under results/paper (paper numerics: long)
reproduce: $(STAMP)
	$(VENV)/bin/mdr-drive reproduce --out results/paper

## make convergence: the dt/dx convergence table under results/convergence
convergence: $(STAMP)
	$(PY) scripts/convergence.py --out results/convergence

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info
