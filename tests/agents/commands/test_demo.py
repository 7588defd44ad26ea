"""The demo (mdr-drive demo, make demo)."""

import pytest

pytest.importorskip("stable_baselines3")


def test_the_demo_drives_the_shipped_sensor_policy_through_a_load_step(tmp_path, capsys):
    from mdr_drive_agents.commands.demo import load_steps
    from mdr_drive_agents.policy import PRETRAINED, SENSOR_PRETRAINED, load_policy

    load_steps(load_policy(SENSOR_PRETRAINED), load_policy(PRETRAINED), tmp_path)
    assert (tmp_path / "load_step.png").stat().st_size > 10_000
    assert capsys.readouterr().out.count("sensor policy") == 2  # one line per load step
