# Every target creates .venv when it is missing and installs the package with all extras.
# torch is pinned to the CPU build through constraints.txt.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
PYTEST_ARGS ?=

.PHONY: install test demo reproduce convergence bench train benchmark blind claims clean

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

## make train: the shipped policy's recipe: CMA-ES teacher, its refinement, residual PPO seeds 0-2, seed selection (about 30 minutes)
train: $(STAMP)
	$(PY) -m agents.teacher --points 160 --stall-points 192 --transition-points 64 --cycle-budget 2500 \
	    --out runs/teacher.npz
	$(PY) -m agents.lookup_refine runs/teacher.npz --probe-points 384 --rounds 3 --out runs/teacher_r1.npz
	$(PY) -m agents.lookup_refine runs/teacher_r1.npz --probe-points 384 --sweeps 64 --sweep-sampling chebyshev \
	    --rounds 2 --seed 200 --out runs/teacher_r2.npz
	for s in 0 1 2; do $(VENV)/bin/mdr-drive train --algo ppo --config agents/configs/ppo_residual.yaml --seed $$s \
	    --warm-start cma:runs/teacher_r2.npz --out runs/ppo_res_s$$s || exit 1; done
	$(PY) scripts/select_seed.py runs/ppo_res_s0 runs/ppo_res_s1 runs/ppo_res_s2 --out runs/selection.md

## make benchmark: learned (3 seeds) vs trapezoid vs CMA-ES (results/benchmark)
benchmark: $(STAMP)
	$(VENV)/bin/mdr-drive benchmark --policies runs/ppo_res_s0 runs/ppo_res_s1 runs/ppo_res_s2 --out results/benchmark

## make blind: the shipped policy on 24 random points of a fresh seed (results/blind/seed20261123; about 22 minutes)
blind: $(STAMP)
	$(VENV)/bin/mdr-drive benchmark --blind 24 --seed 20261123 --policies agents/pretrained/ppo_generalist \
	    --out results/blind/seed20261123

## make claims: each claim of the paper's text against the model variants (results/paper_claims)
claims: $(STAMP)
	$(PY) scripts/paper_claims.py --out results/paper_claims

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info
