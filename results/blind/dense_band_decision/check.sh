#!/usr/bin/env bash
# The rule's check (RULE.md): a candidate (default cbd: runs/cbd/policy) on the stored searches of
# fourteen decision seeds, into OUT (default this folder).   bash results/blind/dense_band_decision/check.sh [NAME [OUT]]
set -euo pipefail
name=${1:-cbd}
out=${2:-results/blind/dense_band_decision}
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
