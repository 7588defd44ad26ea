"""The sensor policy's network that predicts each drive's worth (mdr_drive_agents.student.drive_values)."""

import numpy as np
import pytest

pytest.importorskip("torch")

from mdr_drive_agents.protocol import BELOW_TOLERANCE  # noqa: E402
from mdr_drive_agents.student.drive_values import DriveValueNetwork, DriveValueTargets, pick_rows  # noqa: E402

#: Three drives: the trapezoid (fixed), a push/clamp cycle, a fixed drive; as a table, two rows each.
PUSH, CLAMP, FIXED, TRAP = np.full(5, 0.8), np.full(5, -0.8), np.full(5, 0.2), np.zeros(5)
DRIVES = np.array([[TRAP, TRAP], [PUSH, CLAMP], [FIXED, FIXED]])
ROWS, PARTNERS = DRIVES.reshape(-1, 5), DRIVES[:, ::-1].reshape(-1, 5)
#: Their velocities (m/s) at two hidden points: the cycle is best at the first, the fixed drive at the second.
VELOCITIES = np.array([[0.004, 0.010, 0.008], [0.001, -0.003, 0.012]])


def test_a_drive_is_worth_its_fraction_of_the_best_less_its_shortfall_and_a_fall_below_the_trapezoid():
    worth = DriveValueTargets(VELOCITIES, knee=0.85, shortfall_weight=1.0, below_weight=5.0).worth
    assert worth[0, 1] == pytest.approx(1.0)  # the best drive
    assert worth[0, 0] == pytest.approx(0.4 - (0.85 - 0.4))  # 0.4 of the best, 0.45 short of the knee
    assert worth[0, 2] == pytest.approx(0.8 - 0.05)
    below = (0.001 - BELOW_TOLERANCE + 0.003) / 0.012  # the cycle at the second point: backwards, below the trapezoid
    assert worth[1, 1] == pytest.approx(max(-0.25 - 1.1 - 5.0 * below, -1.0))
    assert worth.min() >= -1.0 and worth.max() <= 1.0
    slow = DriveValueTargets(VELOCITIES * 0.1).worth  # nothing moves 2 mm/s: fractions of 2 mm/s
    assert slow[0, 1] == pytest.approx(0.5 - 0.35)


def test_where_every_drive_slides_back_the_one_that_slides_back_least_is_worth_most():
    v = np.array([[-0.081, -0.060, -0.395]])  # a runaway load: the trapezoid, a drive that brakes, one that does not
    worth = DriveValueTargets(v, knee=0.85, shortfall_weight=1.0, below_weight=5.0).worth
    assert worth[0, 1] == pytest.approx(0.0)  # the least backward: 0, never the worth of a drive that moves
    assert worth[0, 0] == pytest.approx(0.060 / 0.081 - 1.0)
    assert worth[0, 2] == -1.0  # slides back far faster than the trapezoid
    assert worth[0, 1] > worth[0, 0] > worth[0, 2]


def test_the_pick_plays_a_cycles_actions_in_turn_and_switches_only_for_a_margin():
    worth = DriveValueTargets(VELOCITIES).worth
    played, previous = [], np.zeros((1, 5))
    for _ in range(4):
        row = pick_rows(worth[[0]], previous, PARTNERS, 0.002)[0]
        played.append(int(row))
        previous = ROWS[[row]]
    assert played in ([2, 3, 2, 3], [3, 2, 3, 2])  # push, clamp, push, clamp
    assert pick_rows(worth[[1]], ROWS[[2]], PARTNERS, 0.002)[0] in (4, 5)  # the fixed drive where it is best
    close = np.array([[0.5, 0.51, 0.0]], dtype=np.float32)  # another drive a little better: the cycle goes on
    assert pick_rows(close, ROWS[[2]], PARTNERS, 0.002)[0] == 3
    assert pick_rows(close, ROWS[[2]], PARTNERS, 0.0)[0] == 2  # no continuation: the better drive, either action


def test_a_switch_cost_keeps_the_drive_just_played_unless_another_is_worth_more_by_it():
    worth = np.array([[0.55, 0.5, 0.0]])  # the trapezoid a little better than the cycle, whose push was just played
    assert pick_rows(worth, ROWS[[2]], PARTNERS, 0.0)[0] == 0
    assert pick_rows(worth, ROWS[[2]], PARTNERS, 0.0, switch_cost=0.1)[0] == 3  # the cycle goes on: its clamp
    assert pick_rows(worth, ROWS[[2]], PARTNERS, 0.0, switch_cost=0.01)[0] == 0  # not worth 0.05 less
    assert pick_rows(worth, np.full((1, 5), 0.5), PARTNERS, 0.0, switch_cost=0.1)[0] == 0  # nothing to continue


def network(obs_dim, seed=0) -> DriveValueNetwork:
    return DriveValueNetwork(obs_dim, PARTNERS, slice(1, 6), 0.002, ("k", "friction_ratio"), (16, 16), seed=seed,
                             ignored=(obs_dim - 1,))


def test_the_network_learns_each_drives_worth_from_observations_and_ignores_the_episode_fraction():
    rng = np.random.default_rng(0)
    n = 512
    point = rng.integers(0, 2, n)
    x = rng.normal(size=(n, 8)).astype(np.float32)
    x[:, 0] = point  # the observation shows the point
    x[:, 1:6] = ROWS[rng.integers(0, 6, n)]  # the previous action
    x[:, 7] = rng.uniform(size=n)  # the elapsed fraction: ignored
    estimates = np.stack([point * 0.3, point * 0.2 + 0.1], axis=1).astype(np.float32)
    net = network(8)
    net.standardise_with(x, estimates)
    targets = DriveValueTargets(VELOCITIES)
    before = np.mean((net.predicted_worth(x) - targets.worth[point]) ** 2)
    net.fit(x, point, estimates, targets, 600, 64, 3e-3, seed=0, progress=False)
    assert np.mean((net.predicted_worth(x) - targets.worth[point]) ** 2) < 0.1 * before
    assert np.mean(net.act(x[point == 1]) >= 4) > 0.9  # the fixed drive where it is best
    assert np.mean(np.isin(net.act(x[point == 0]), [2, 3])) > 0.9  # the cycle where it is
    shifted = x.copy()
    shifted[:, 7] = 0.0
    np.testing.assert_array_equal(net.predicted_worth(shifted), net.predicted_worth(x))
    assert np.abs(net.estimates(x)[:, 0] - point * 0.3).mean() < 0.05


@pytest.mark.parametrize("switch_cost, arch", [(0.0, (8, 8)), (0.3, (8, 8)), (0.3, (8,)), (0.3, (8, 8, 8))])
def test_the_sb3_policy_and_the_estimator_compute_the_network_exactly(tmp_path, switch_cost, arch):
    import gymnasium as gym

    import mdr_drive_env  # noqa: F401
    from mdr_drive_agents.student.estimator import Estimator

    env = gym.make("MDRDriveSensor-v0", history=2)
    structure = env.unwrapped.observation_structure
    d = env.observation_space.shape[0]
    newest = slice(structure["actions"].start, structure["actions"].start + 5)
    net = DriveValueNetwork(d, PARTNERS, newest, 0.05, ("k", "friction_ratio"), arch, seed=1,
                            ignored=(structure["episode_fraction"].start,))
    rng = np.random.default_rng(4)
    x = rng.normal(size=(400, d)).astype(np.float32)
    x[:, newest] = ROWS[rng.integers(0, 6, 400)]  # previous actions from the table, as the env shows them
    x[:100, newest] = 0.0  # and none, in an episode's first period
    net.standardise_with(x, rng.normal(size=(400, 2)))
    net.switch_cost = switch_cost
    if switch_cost:  # the cost decides some picks here
        assert np.any(net.act(x) != pick_rows(net.predicted_worth(x), x[:, newest], PARTNERS, 0.05))
    student = net.policy({"history": 2}, ROWS)
    assert student.model.action_space.n == 6
    np.testing.assert_array_equal(student.codebook_index(student.act(x)) // 2, net.act(x) // 2)  # the same drive
    np.testing.assert_array_equal(student.act(x), ROWS[net.act(x)])  # the same action
    est = net.estimator()
    est.save(tmp_path / "e.npz")
    np.testing.assert_allclose(Estimator.load(tmp_path / "e.npz")(x), net.estimates(x), rtol=1e-5, atol=1e-5)
    again = DriveValueNetwork(d, PARTNERS, newest, 0.05, ("k", "friction_ratio"), arch, seed=2)
    again.load_state(net.state())
    np.testing.assert_array_equal(again.predicted_worth(x), net.predicted_worth(x))
