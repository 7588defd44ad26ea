"""The table of whole drives a sensor policy picks from (mdr_drive_agents.teacher.drive_table)."""

import numpy as np
import pytest

from mdr_drive_agents.protocol import open_loop_velocity, trapezoid_action
from mdr_drive_agents.teacher.drive_table import (DriveTable, DriveTableConfig, SearchTask, coverage_utility,
                                                  search_drives, select)


def test_the_selection_starts_with_the_trapezoid_and_covers_the_points_greedily():
    values = np.array([[0.010, 0.020, 0.000, 0.019],
                       [0.010, 0.000, 0.020, 0.019],
                       [0.010, 0.005, 0.005, 0.018]])  # drive 3 is nearly best everywhere
    chosen, history = select(values, 3)
    assert chosen[:2] == [0, 3]
    assert np.all(np.diff(history) >= 0)
    assert select(values, 10)[0] == [0, 3, 1, 2]  # never more than the candidates
    assert coverage_utility(np.array([1.2, 1.0, 0.9, 0.5])).tolist() == pytest.approx([1.0, 1.0, 0.9, 0.5 - 0.8])


def test_a_table_plays_each_drive_as_two_rows_in_turn_and_saves_as_numbers(tmp_path):
    trap = trapezoid_action()
    push, clamp = np.full(5, 0.5), np.full(5, -0.5)
    drives = np.array([np.tile(trap, (2, 1)), [push, clamp], [clamp, push], np.tile(push, (2, 1))])
    table = DriveTable(drives, {"coverage": {"points_moving": 3}})
    np.testing.assert_array_equal(table.rows, [trap, trap, push, clamp, clamp, push, push, push])
    np.testing.assert_array_equal(table.partners, [trap, trap, clamp, push, push, clamp, push, push])
    table.save(tmp_path / "t.npz")
    again = DriveTable.load(tmp_path / "t.npz")
    np.testing.assert_array_equal(again.drives, drives)
    assert again.record == table.record
    (tmp_path / "bad.npz").write_bytes(b"not a table")
    with pytest.raises(ValueError, match="not a drive table"):
        DriveTable.load(tmp_path / "bad.npz")


def test_the_searches_at_a_point_report_the_velocities_their_drives_play():
    point = (0.3, 0.02, 0.3, 0.1)
    start = np.array([[0.9, 0.8, 0.9, 0.0, 0.9], [-0.8, -0.9, 0.9, -0.9, 0.8]])
    found = search_drives(SearchTask(point, 24, 32, 32, start))
    assert found["drives"].shape == (5, 2, 5)  # fixed, three cycle starts, the given start
    np.testing.assert_array_equal(found["drives"][0, 0], found["drives"][0, 1])
    np.testing.assert_allclose(open_loop_velocity([point] * 5, found["drives"]), found["velocities"])


@pytest.mark.parametrize("kwargs, name", [({"points": 0}, "points"), ({"size": 0}, "size"),
                                          ({"cycle_budget": 1}, "cycle_budget"), ({"fixed_budget": -1}, "fixed_budget"), ({"seed": -1}, "seed")])
def test_bad_table_settings_name_themselves(kwargs, name):
    with pytest.raises(ValueError, match=name):
        DriveTableConfig(**kwargs)


def test_a_budget_of_zero_skips_its_searches():
    point = (0.3, 0.02, 0.3, 0.1)
    start = np.array([[0.9, 0.8, 0.9, 0.0, 0.9], [-0.8, -0.9, 0.9, -0.9, 0.8]])
    found = search_drives(SearchTask(point, 0, 0, 32, start))
    assert found["drives"].shape == (1, 2, 5)  # the given start's search alone


def test_a_table_from_a_library_starts_each_search_from_its_fastest_drive_and_keeps_its_drives(tmp_path):
    from mdr_drive_env.sweep import Executor

    from mdr_drive_agents.teacher.drive_table import build

    still = np.array([[0.0, 0.5, 0.5, 0.0, 0.0]] * 2)  # no x stroke: it never moves the slider
    cycle = np.array([[0.9, 0.8, 0.9, 0.0, 0.9], [-0.8, -0.9, 0.9, -0.9, 0.8]])
    library = DriveTable(np.array([np.tile(trapezoid_action(), (2, 1)), still, cycle]), {})
    config = DriveTableConfig(points=2, fixed_budget=0, cycle_budget=0, polish_budget=8, keep_per_point=1,
                              selection_points=2, size=3)
    table = build(config, Executor(workers=1, progress=False), tmp_path, library)
    np.testing.assert_array_equal(table.drives[0], library.drives[0])  # the trapezoid first
    assert table.record["library"] == 3 and table.record["candidates"] <= 3 + 2
    from mdr_drive_agents.protocol import draw_hidden, hidden_point
    from mdr_drive_agents.teacher.drive_table import drive_values

    # the library is valued once, apart from the searched drives: a drive's values do not depend on its company
    sample = [hidden_point(d) for d in draw_hidden(2, config.seed) + draw_hidden(2, config.seed + 1)]
    together = drive_values(sample, np.concatenate([library.drives, table.drives]), Executor(workers=1, progress=False))
    apart = drive_values(sample, table.drives, Executor(workers=1, progress=False))
    np.testing.assert_array_equal(together[:, 3:], apart)
    with pytest.raises(ValueError, match="polish_from"):
        build(DriveTableConfig(points=1, polish_from="agents/pretrained/ppo_generalist"),
              Executor(workers=1, progress=False), tmp_path / "x", library)
