"""Posterior-robust targets of the sensor policy's estimator (mdr_drive_agents.train.sensor_robust)."""

from __future__ import annotations

import numpy as np

from mdr_drive_agents.train.sensor import AdaptConfig


def test_each_episode_is_its_own_nearest_neighbour_and_the_scale_sets_the_distance():
    from mdr_drive_agents.train.sensor_robust import neighbours

    estimates = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 10.0], [3.0, 0.0]])
    groups = neighbours(estimates, np.array([1.0, 1.0]), 2)
    assert groups[:, 0].tolist() == [0, 1, 2, 3]
    assert groups[0, 1] == 1 and groups[2, 1] == 0  # (0, 10) is nearest (0, 0) on this scale
    assert neighbours(estimates, np.array([1.0, 100.0]), 2)[0, 1] == 2  # ... (0, 10) is next to (0, 0) on this


def test_the_target_is_the_candidate_best_on_average_over_the_neighbours_not_the_own_truth():
    from mdr_drive_agents.train.sensor_robust import choose_targets

    groups = np.array([[0, 1, 2], [1, 0, 2], [2, 0, 1]])
    teacher = np.array([0.010, 0.010, 0.010])  # told its own truth, each moves 10 mm/s
    v = {(a, b): 0.010 if a == b else 0.0 for a in range(3) for b in range(3)}
    v[1, 0] = v[1, 2] = 0.009  # told episode 1's truth, the teacher drives well at 0 and 2 too
    v[0, 1] = -0.02  # told 0's truth at 1's drive: slides back (the fraction is clipped at -2)
    chosen = choose_targets(groups, v, teacher)
    assert chosen.tolist() == [1, 1, 1]
    assert choose_targets(groups[:, :1], v, teacher).tolist() == [0, 1, 2]  # alone, an episode keeps its truth


def test_the_teacher_told_an_episodes_truth_drives_it_as_in_that_episode():
    """told_velocities rebuilds each drive from drive_parameters: told the truth, the teacher drives as it
    does in the sensor env the parameters were drawn in."""
    from mdr_drive_agents.policy import load_policy
    from mdr_drive_agents.protocol import steady_velocity_of
    from mdr_drive_agents.student.estimator import Estimator, SensorTeacher, hidden_entries, teacher_layout
    from mdr_drive_agents.train.sensor import collect, sensor_envs, sensor_structure_of
    from mdr_drive_agents.train.sensor_robust import ROBUST_PERIODS, drive_parameters, told_velocities

    config = AdaptConfig(history=2, periods=ROBUST_PERIODS, load_step_share=0.0, load_step_periods=(1, 1),
                         sensor_tier="trace", trace_samples=3)
    teacher = load_policy(config.teacher)
    hidden = hidden_entries(teacher_layout(teacher))
    composed = SensorTeacher(teacher, Estimator(1, (4,), seed=0, n_out=len(hidden)), sensor_structure_of(config))
    envs, first = sensor_envs(config, 3, seed=5)
    truths = np.array([e.unwrapped.privileged_observation(friction=True)[hidden] for e in envs])
    _, _, disp = collect(envs, first, lambda s, p: teacher.act(composed.full_observation(s, hidden=p[:, hidden])),
                         friction=True)
    told = told_velocities(composed, config, drive_parameters(envs), truths, friction=True, progress=False)
    np.testing.assert_allclose(told, steady_velocity_of(disp), rtol=1e-9, atol=1e-12)
    assert np.ptp(told) > 1e-3  # three different drives
