#!/usr/bin/env bash
# The rule's step 2 (RULE.md): a candidate (default cbbf: runs/cbbf/policy) on the stored searches of
# fourteen decision seeds.   bash results/blind/fast_codebook_decision/check.sh [NAME]
set -euo pipefail
name=${1:-cbbf}
out=results/blind/fast_codebook_decision
for seed in 3232 9292; do
  mdr-drive benchmark --blind 120 --seed "$seed" --scan-draw \
    --reuse-search "results/blind/codebook_band_decision/seed${seed}/blind.json" \
    --policies "runs/${name}/policy" --out "$out/${name}_seed${seed}"
done
for seed in 20261219 20261220 20261221 20261222 20261223 20261224 20261249 20261250 20261251 20261252 20261253 20261254; do
  mdr-drive benchmark --blind 120 --seed "$seed" --scan-draw \
    --reuse-search "results/blind/seed${seed}_drawn_scan/blind.json" \
    --policies "runs/${name}/policy" --out "$out/${name}_seed${seed}"
done
