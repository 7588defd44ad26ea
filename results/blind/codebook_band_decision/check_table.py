"""The rule's table (RULE.md): F1s1, `cbs` and CBB on fresh decision seeds 3232 and 9292 (the same
searches), and CBB on F1s1's six spent record seeds (stored searches), as the model card tabulates
them (``model_card.blind_record``; the targets judged by ``blind.missed_targets``), and the rule's miss
count (points under 0.85 + points below the trapezoid + scanned k under 0.97) per policy:

    python results/blind/codebook_band_decision/check_table.py
"""
import json
from pathlib import Path

from mdr_drive_agents.blind_record import blind_record

HERE = Path("results/blind/codebook_band_decision")
FRESH = (3232, 9292)
SPENT = range(20261219, 20261225)
SHIPPED = "agents/pretrained/ppo_generalist"


def misses(files, key) -> int:
    """The rule's misses of policy ``key`` over blind results ``files``."""
    total = 0
    for f in files:
        s = json.loads(Path(f).read_text())["statistics"][key]
        total += s["points_under_fraction_target"] + s["points_below_trapezoid"]
        total += sum(r < 0.97 for r in s["critical_load_over_best_cycle"])
    return total


def show(title: str, files, key: str) -> None:
    print(f"### {title} (misses: {misses(files, key)})\n")
    print(blind_record(files, key))
    print()


def main() -> None:
    fresh = [HERE / f"seed{s}" / "blind.json" for s in FRESH]
    spent_cbb = [Path("results/blind/codebook_decision") / f"cbb_seed{s}" / "blind.json" for s in SPENT]
    show("F1s1 on fresh decision seeds 3232, 9292", fresh, SHIPPED)
    show("cbs on fresh decision seeds 3232, 9292", fresh, "runs/cbs/policy")
    show("CBB on fresh decision seeds 3232, 9292", [HERE / f"cbb_seed{s}" / "blind.json" for s in FRESH], "runs/cbb/policy")
    show("CBB on F1s1's six spent record seeds (stored searches)", spent_cbb, "runs/cbb/policy")
    show("F1s1 on the same six (its record)", [f"results/blind/seed{s}_drawn_scan/blind.json" for s in SPENT], SHIPPED)


if __name__ == "__main__":
    main()
