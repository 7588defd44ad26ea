# Every target creates .venv when it is missing and installs the package with all extras.
# torch is pinned to the CPU build through constraints.txt.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
PYTEST_ARGS ?=

.PHONY: install test demo reproduce convergence bench train train-sensor benchmark blind adaptation claims clean

$(STAMP): pyproject.toml constraints.txt
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q -c constraints.txt -e ".[train,ray,dev]"
	touch $(STAMP)

install: $(STAMP)

## make test: the whole test suite (a few minutes on 2 cores)
test: $(STAMP)
	$(PY) -m pytest -q -n 2 --dist loadgroup $(PYTEST_ARGS)

## make demo: the main job: the paper's drive, then the shipped policy against the trapezoid
demo: $(STAMP)
	$(VENV)/bin/mdr-drive demo --out results/demo

## make reproduce: the paper's Figs. 3-5 under results/paper (paper numerics: long)
reproduce: $(STAMP)
	$(VENV)/bin/mdr-drive reproduce --out results/paper

## make convergence: the dt/dx convergence table under results/convergence
convergence: $(STAMP)
	$(PY) scripts/convergence.py --out results/convergence

## make bench: speed and accuracy of the solvers (results/bench)
bench: $(STAMP)
	$(VENV)/bin/mdr-drive bench --out results/bench

## make train: the shipped policy's recipe: the drive-field teacher, then the DAgger-distilled PPO student (runs/recipe; 14-22 minutes alone on 2 cores by the host's speed, docs/results.md; continue an interrupted one with python -m mdr_drive_agents.recipe agents/configs/recipe.yaml --out runs/recipe --resume)
train: $(STAMP)
	$(PY) -m mdr_drive_agents.recipe agents/configs/recipe.yaml --out runs/recipe --force

## make train-sensor: the sensor policy (MDRDriveSensor-v0: k, load, friction hidden) from its full-observation teacher, agents/pretrained/ppo_sensor/teacher (runs/sensor)
train-sensor: $(STAMP)
	$(PY) -m mdr_drive_agents.adapt agents/configs/sensor.yaml --out runs/sensor --force

## make adaptation: the shipped sensor policy on blind hidden-parameter draws and load steps (results/adaptation/seed20261125)
adaptation: $(STAMP)
	$(PY) -m mdr_drive_agents.adaptation --seed 20261125 --out results/adaptation/seed20261125

## make benchmark: the shipped policy against the trapezoid and CMA-ES on the fixed grid (results/benchmark_shipped)
benchmark: $(STAMP)
	$(VENV)/bin/mdr-drive benchmark --policies agents/pretrained/ppo_generalist --out results/benchmark_shipped

## make blind: the shipped policy on 120 random points of the first report seed its model card quotes, the scan's k drawn with the seed (its record: results/blind/seed20261255_drawn_scan, 683 s alone on 2 cores)
blind: $(STAMP)
	$(VENV)/bin/mdr-drive benchmark --blind 120 --seed 20261255 --scan-draw --policies agents/pretrained/ppo_generalist \
	    --out results/blind/seed20261255_shipped

## make claims: each claim of the paper's text against the model variants (results/paper_claims)
claims: $(STAMP)
	$(PY) scripts/paper_claims.py --out results/paper_claims

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info
