#!/usr/bin/env bash
# The rule's step 2 (RULE.md): a candidate (default cbbf: runs/cbbf/policy) on the stored searches of
# fourteen decision seeds, as dense_band_decision/check.sh, written here.
#   bash results/blind/fast_codebook_decision/check.sh [NAME]
set -euo pipefail
bash results/blind/dense_band_decision/check.sh "${1:-cbbf}" results/blind/fast_codebook_decision
