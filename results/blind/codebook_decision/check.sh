#!/usr/bin/env bash
# The rule's check (RULE.md) for one candidate: its policy against the stored searches of F1s1's six
# spent record seeds. bash results/blind/codebook_decision/check.sh cb60   (policy: runs/cb60/policy)
set -euo pipefail
name=$1
for seed in 20261219 20261220 20261221 20261222 20261223 20261224; do
  mdr-drive benchmark --blind 120 --seed "$seed" --scan-draw \
    --reuse-search "results/blind/seed${seed}_drawn_scan/blind.json" \
    --policies "runs/${name}/policy" --out "results/blind/codebook_decision/${name}_seed${seed}"
done
