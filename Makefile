# Every target creates .venv when it is missing and installs the package with all extras.
# torch is pinned to the CPU build through constraints.txt. `make help` lists the targets.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
MDR    := $(VENV)/bin/mdr-drive
STAMP  := $(VENV)/.installed-stamp
PYTEST_ARGS ?=
#: The shipped policy's record: blind benchmarks on these seeds (none was used to build or select it).
RECORD_SEEDS := 20261255 20261256 20261257 20261258 20261259 20261260 20261273 20261274 20261275 20261276 20261277 20261278
#: The plain-RL policy's record: the record seeds its baselines neither searched on (20261255) nor reported (20261256-57).
PLAIN_RECORD_SEEDS := 20261258 20261259 20261260 20261273 20261274 20261275 20261276 20261277 20261278

.PHONY: help install test demo reproduce claims convergence bench scaling train train-friction-teacher train-sensor benchmark \
        record reference dense \
        adaptation identifiability rl-baselines your-drive cards clean

## make help: this list
help:
	@grep -h '^## make' $(MAKEFILE_LIST) | sed 's/^## //'

$(STAMP): pyproject.toml constraints.txt
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q -c constraints.txt -e ".[train,ray,dev]"
	touch $(STAMP)

install: $(STAMP)

## make test: the whole test suite (about 3 minutes on 2 cores once installed; the install about 70 s more)
test: $(STAMP)
	$(PY) -m pytest -q -n 2 --dist loadgroup $(PYTEST_ARGS)

## make demo: the main job: the paper's drive, the shipped policy against the trapezoid, the sensor policy (results/demo)
demo: $(STAMP)
	$(MDR) demo --out results/demo

## make reproduce: the paper's Figs. 3-5 for both model variants (results/paper, results/paper_as_published; paper numerics: long)
reproduce: $(STAMP)
	$(MDR) reproduce --out results/paper
	$(MDR) reproduce --variant as-published --out results/paper_as_published

## make claims: each claim of the paper's text against the model variants (results/paper_claims*; the paper-numerics run is long)
claims: $(STAMP)
	$(PY) scripts/paper_claims.py --out results/paper_claims
	$(PY) scripts/paper_claims.py --models as-specified --h-normal-scales 1.3 1.35 1.4 1.6 1.8 2.2 2.3 2.5 3 4 \
	    --out results/paper_claims_h_normal_scan
	$(PY) scripts/paper_claims.py --numerics paper --models as-specified as-published --out results/paper_claims_paper_numerics

## make convergence: the dt/dx convergence table of the grid solver (results/convergence)
convergence: $(STAMP)
	$(PY) scripts/convergence.py --out results/convergence

## make bench: speed and accuracy of the solvers (results/bench)
bench: $(STAMP)
	$(MDR) bench --out results/bench

## make scaling: the sweeps' speed-up from 1 to N local workers, and to 2 workers of a local Ray instance, with their projections (results/scaling)
scaling: $(STAMP)
	$(PY) scripts/scaling.py --out results/scaling
	$(PY) scripts/scaling.py --ray-address local --workers 2 --out results/scaling/ray

## make train: the recipe's policy told k and the load on the paper's drive, teacher then student (runs/recipe; about 20 minutes alone on 2 cores, docs/results.md)
train: $(STAMP)
	$(MDR) recipe agents/configs/recipe.yaml --only told --out runs/recipe --force

## make train-friction-teacher: the sensor policies' teacher, told k, the load and mu1/mu (runs/friction_teacher; about 3.5 hours)
train-friction-teacher: $(STAMP)
	$(MDR) friction-teacher agents/configs/friction_teacher.yaml --out runs/friction_teacher --force

## make train-sensor: the sensor policies of the three tiers: a table of drives, then a network per tier that picks from it (runs/sensor*; about 4 hours)
train-sensor: $(STAMP)
	$(MDR) train-sensor agents/configs/sensor.yaml --out runs/sensor --force
	$(MDR) train-sensor agents/configs/sensor.yaml --sensor-tier encoder --reuse runs/sensor --out runs/sensor_encoder --force
	$(MDR) train-sensor agents/configs/sensor.yaml --sensor-tier self-sensing --reuse runs/sensor --out runs/sensor_self_sensing --force

## make benchmark: the shipped policy against the trapezoid and CMA-ES on the fixed grid (results/benchmark)
benchmark: $(STAMP)
	$(MDR) benchmark --policies agents/pretrained/ppo_generalist --out results/benchmark

## make record: the shipped policy's blind record, one blind benchmark per seed of RECORD_SEEDS (results/record; about 6-11 minutes a seed)
record: $(STAMP)
	for seed in $(RECORD_SEEDS); do \
	    $(MDR) benchmark --blind 120 --seed $$seed --scan-draw --policies agents/pretrained/ppo_generalist \
	        --out results/record/seed$$seed || exit $$?; done

#: The seed of the strong-reference benchmark (never used to build, choose or tune anything).
REFERENCE_SEED := 20261303

## make reference: the shipped policies against the strong reference search, which they do not beat on average (results/reference; about 20 minutes)
reference: $(STAMP)
	$(MDR) benchmark --blind 120 --seed $(REFERENCE_SEED) --scan-draw --reference strong \
	    --policies agents/pretrained/ppo_generalist agents/pretrained/ppo_plain --out results/reference/seed$(REFERENCE_SEED)

## make dense: where the shipped policy is below the trapezoid on a dense grid of its domain (results/dense)
dense: $(STAMP)
	$(MDR) dense --policy agents/pretrained/ppo_generalist --ks 173 --loads 277 --out results/dense --force

#: The shipped sensor policies (the first, position only, is the one whose estimates the report plots).
SENSOR_POLICIES := agents/pretrained/ppo_sensor agents/pretrained/ppo_sensor_encoder agents/pretrained/ppo_sensor_self_sensing
#: The seed of the sensor policies' report (never used to build or choose them).
ADAPTATION_SEED := 20261437

## make adaptation: the shipped sensor policies on blind hidden-parameter draws and load steps, then the dense check of each (results/adaptation)
adaptation: $(STAMP)
	$(MDR) adaptation --seed $(ADAPTATION_SEED) $(foreach p,$(SENSOR_POLICIES),--sensor-policy $(p)) --out results/adaptation
	for p in $(SENSOR_POLICIES); do \
	    $(MDR) dense --policy $$p --ks 21 --loads 21 --out results/adaptation/dense_$$(basename $$p) --force --no-progress \
	        || exit $$?; done

#: The seed of the identifiability study's draws (never used to build or choose anything).
IDENTIFIABILITY_SEED := 20261501

## make identifiability: what each sensor tier can tell of the hidden k, load and friction, by the drive played (results/identifiability; about 30 minutes)
identifiability: $(STAMP)
	$(MDR) identifiability --seed $(IDENTIFIABILITY_SEED) --out results/identifiability --force

#: The drive of docs/your_drive.md's worked example, and the seed of its blind benchmark (never used to choose anything).
EXAMPLE_DRIVE := agents/configs/drives/small_stage.yaml
EXAMPLE_DRIVE_SEED := 20261281
#: The seed of its benchmark against the strong reference (never used to choose anything).
EXAMPLE_STRONG_SEED := 20261305

## make your-drive: docs/your_drive.md's example: the recipe on another drive, then its blind benchmarks against the standard and the strong reference (results/your_drive; about 35 minutes)
your-drive: $(STAMP)
	$(MDR) recipe agents/configs/recipe.yaml --drive $(EXAMPLE_DRIVE) --out runs/your_drive --force
	$(MDR) benchmark --blind 120 --seed $(EXAMPLE_DRIVE_SEED) --scan-draw --policies runs/your_drive/policy \
	    --out results/your_drive/seed$(EXAMPLE_DRIVE_SEED)
	$(MDR) benchmark --blind 120 --seed $(EXAMPLE_STRONG_SEED) --scan-draw --reference strong --policies runs/your_drive/policy \
	    --out results/your_drive/strong_seed$(EXAMPLE_STRONG_SEED)

## make rl-baselines: plain PPO, SAC, TD3 and RecurrentPPO searched, 5 seeds each, then what helps PPO; ships the best (results/rl_baselines; about 1.5 hours on 2 cores)
rl-baselines: $(STAMP)
	$(MDR) rl-baselines agents/configs/rl_baselines.yaml --out results/rl_baselines --runs runs/rl_baselines \
	    --ship agents/pretrained --force
	$(MDR) rl-baselines agents/configs/rl_ablations.yaml --out results/rl_baselines/ablations \
	    --runs runs/rl_ablations --force
	plain=$$(ls -d agents/pretrained/*_plain) && for seed in $(PLAIN_RECORD_SEEDS); do \
	    $(MDR) benchmark --blind 120 --seed $$seed --scan-draw --policies $$plain \
	        --reuse-search results/record/seed$$seed/blind.json --out results/rl_baselines/record/seed$$seed || exit $$?; done
	$(MDR) rl-baselines agents/configs/rl_baselines.yaml --out results/rl_baselines --report --ship agents/pretrained \
	    --force --records $(foreach seed,$(PLAIN_RECORD_SEEDS),results/rl_baselines/record/seed$(seed)/blind.json)

## make cards: the shipped policies' model cards, from their files, the record and the adaptation report
cards: $(STAMP)
	$(MDR) model-card agents/pretrained/ppo_generalist agents/pretrained/ppo_generalist \
	    $(foreach seed,$(RECORD_SEEDS),results/record/seed$(seed)/blind.json) > /dev/null
	for p in $(SENSOR_POLICIES); do \
	    $(MDR) model-card $$p $$p results/adaptation/adaptation.json > /dev/null || exit $$?; done

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info
