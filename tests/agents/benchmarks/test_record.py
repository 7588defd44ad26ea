"""The blind record over report seeds (mdr_drive_agents.benchmarks.record) and the targets it counts
(mdr_drive_agents.benchmarks.targets)."""

import json

import pytest


def test_the_model_cards_blind_record_repeats_each_command_and_counts_the_seeds_that_meet_every_target(tmp_path):
    from mdr_drive_agents.benchmarks.blind import DRAWN_SCAN, EVEN_SCAN
    from mdr_drive_agents.benchmarks.record import blind_record

    clean = {"points_below_trapezoid": 0, "points_scored": 20, "fraction_of_best_mean": 1.1,
             "fraction_of_best_min": 0.9, "points_under_fraction_target": 0,
             "critical_load_over_best_cycle": [0.99, 1.0], "critical_load_over_best_cycle_min": 0.99,
             "k_values_at_critical_load_target": 2, "critical_load_over_trapezoid": [1.2, 1.5]}
    short = {**clean, "fraction_of_best_min": 0.84, "points_under_fraction_target": 1}
    low_crit = {**clean, "critical_load_over_best_cycle": [0.9696, 1.0], "critical_load_over_best_cycle_min": 0.9696}
    files = []
    for seed, scan, stats in ((97, DRAWN_SCAN, clean), (98, DRAWN_SCAN, short), (99, EVEN_SCAN, clean), (100, None, clean),
                              (101, None, low_crit)):
        res = {"n": 24, "seed": seed, "policies": ["P"], "statistics": {"P": stats}, **({"scan": scan} if scan else {})}
        files.append(tmp_path / f"{seed}.json")
        files[-1].write_text(json.dumps(res))
    text = blind_record(files, "P")
    assert "`mdr-drive benchmark --blind 24 --seed SEED --scan-draw --policies P` with SEED = 97, 98" in text
    assert "`mdr-drive benchmark --blind 24 --seed SEED --policies P` with SEED = 99, 100, 101" in text
    # a miss by less than the third decimal is printed with the digits that show it
    assert "| 101 | 0 | 1.100 | 0.900 (0 of 20) | 0.9696 (1 of 2) | 1.200-1.500 | critical load |" in text
    assert "| 98 | 0 | 1.100 | 0.840 (1 of 20) | 0.990 (2 of 2) | 1.200-1.500 | fraction of the best: minimum |" in text
    assert "| 97 | 0 | 1.100 | 0.900 (0 of 20) | 0.990 (2 of 2) | 1.200-1.500 | none |" in text
    assert ("All four targets met on 3 of 5 report seeds: a fresh seed passes with probability about\n"
            "0.60 (95 % Wilson interval 0.23-0.88).") in text


def test_the_pass_rates_wilson_interval_has_its_closed_forms_and_refuses_impossible_counts():
    from mdr_drive_agents.benchmarks.record import wilson_interval

    z2 = 1.96 ** 2
    assert wilson_interval(0, 10) == (0.0, pytest.approx(z2 / (10 + z2)))  # no pass: [0, z^2 / (n + z^2)]
    assert wilson_interval(10, 10) == (pytest.approx(10 / (10 + z2)), 1.0)
    low, high = wilson_interval(13, 18)
    assert low < 13 / 18 < high and high - low < wilson_interval(3, 4)[1] - wilson_interval(3, 4)[0]
    for passed, n in ((5, 4), (-1, 4), (0, 0)):
        with pytest.raises(ValueError, match=f"passed={passed} of n={n}"):
            wilson_interval(passed, n)


def test_missed_targets_names_each_target_a_policy_misses():
    from mdr_drive_agents.benchmarks.targets import missed_targets

    met = {"points_below_trapezoid": 0, "fraction_of_best_mean": 0.95, "fraction_of_best_min": 0.85,
           "critical_load_over_best_cycle_min": 0.97}
    assert missed_targets(met) == []
    assert missed_targets({**met, "fraction_of_best_mean": None, "critical_load_over_best_cycle_min": None}) == []
    assert missed_targets({"points_below_trapezoid": 1, "fraction_of_best_mean": 0.949, "fraction_of_best_min": 0.849,
                           "critical_load_over_best_cycle_min": 0.969}) == [
        "below the trapezoid", "fraction of the best: mean", "fraction of the best: minimum", "critical load"]
