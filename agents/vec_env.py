"""SB3 adapter for the batched Gymnasium vector env (MDRDriveVectorEnv).

SB3's VecEnv resets a finished sub-env in the same step and puts its last observation in
``infos[i]["terminal_observation"]``; Gymnasium's SAME_STEP autoreset mode does the same with
``info["final_obs"]``, so the adapter only reshapes the infos.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvWrapper

from .policy import cycle_space

#: Reward baselines ``BatchedVecEnv`` subtracts: none, or the trapezoid's steady reward at each
#: episode's drive.
REWARD_BASELINES = ("none", "trapezoid")
#: Periods the trapezoid plays for its baseline, and the last ones averaged (the evaluation protocol's).
BASELINE_PERIODS, BASELINE_AVERAGE = 30, 10


class BatchedVecEnv(VecEnv):
    """``MDRDrive-v0``'s batched vector env (one compiled call per period for all envs) as an SB3 VecEnv.

    **Reward relative to the trapezoid** (``reward_baseline="trapezoid"``, a training aid): each
    period's reward minus the reward per period the paper's trapezoid earns once settled on the same
    drive (the episode's k, load and friction; the mean of periods 21-30 of the env's own
    ``trapezoid_action``, computed in one batched call when episodes start). A constant per episode:
    it leaves the best policy of every episode the same, and removes from the returns the part that
    depends only on the drive, which the critic would otherwise have to learn. ``infos[i]
    ["reward_baseline"]`` holds it; evaluation sees the env's own reward.

    Args:
        num_envs: number of drives.
        seed: base seed (sub-env i gets ``seed + i``).
        reward_baseline: one of ``REWARD_BASELINES``.
        **env_kwargs: keyword arguments of ``MDRDrive-v0`` (``numerics`` must be the fast solver).
    """

    def __init__(self, num_envs: int, seed: int | None = None, reward_baseline: str = "none", **env_kwargs: Any):
        if reward_baseline not in REWARD_BASELINES:
            raise ValueError(f"reward_baseline={reward_baseline!r} is not one of {list(REWARD_BASELINES)}")
        self.venv = gym.make_vec("MDRDrive-v0", num_envs=num_envs, vectorization_mode="vector_entry_point",
                                 autoreset_mode=AutoresetMode.SAME_STEP, **env_kwargs)
        super().__init__(num_envs, self.venv.single_observation_space, self.venv.single_action_space)
        self._seed = seed
        self._actions: np.ndarray | None = None
        self.baseline = np.zeros(num_envs)
        self._baseline_env = None
        if reward_baseline == "trapezoid":
            self._baseline_env = gym.make_vec("MDRDrive-v0", num_envs=num_envs, vectorization_mode="vector_entry_point",
                                              **{**env_kwargs, "max_periods": BASELINE_PERIODS,
                                                 "load_step_period": None})

    def _update_baseline(self, starting: np.ndarray) -> None:
        """The trapezoid's steady reward per period on the drives of the episodes ``starting`` (mask)."""
        if self._baseline_env is None or not starting.any():
            return
        v = self.venv.unwrapped
        self._baseline_env.reset(options={"k": v.k.copy(), "cargo_mass": v.cargo_mass.copy(),
                                          "friction_coefficient": v.friction[:, 0].copy(),
                                          "base_friction_coefficient": v.friction[:, 1].copy()})
        action = np.repeat(self._baseline_env.unwrapped.template.trapezoid_action()[None], self.num_envs, axis=0)
        rewards = [self._baseline_env.step(action)[1] for _ in range(BASELINE_PERIODS)]
        self.baseline[starting] = np.mean(rewards[-BASELINE_AVERAGE:], axis=0)[starting]

    @property
    def load_ratio_range(self) -> tuple[float, float] | None:
        """The range new episodes draw their load ratio from (None: a cargo mass range instead)."""
        return self.venv.unwrapped.template.load_ratio_range

    def set_load_ratio_range(self, low: float, high: float) -> None:
        """Draw the load ratio of the episodes that start from now in [low, high] (a curriculum)."""
        if self.load_ratio_range is None:
            raise ValueError("a load curriculum needs a load_ratio range (the env draws a cargo mass instead)")
        if not 0.0 <= low <= high <= 10.0:
            raise ValueError(f"load ratio range ({low}, {high}) is outside the allowed range [0, 10]")
        self.venv.unwrapped.template.load_ratio_range = (float(low), float(high))

    def reset(self) -> np.ndarray:
        obs, _ = self.venv.reset(seed=self._seed)
        self._seed = None  # seed only the first reset, as SB3 does
        self._update_baseline(np.ones(self.num_envs, dtype=bool))
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        obs, rewards, terminated, truncated, info = self.venv.step(self._actions)
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for key, value in info.items():
            if key.startswith("_") or key in ("final_obs", "final_info"):
                continue
            for i in range(self.num_envs):
                infos[i][key] = value[i]
        for i in np.flatnonzero(dones):
            infos[i]["terminal_observation"] = info["final_obs"][i]
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        if self._baseline_env is not None:
            rewards = rewards - self.baseline
            for i in range(self.num_envs):
                infos[i]["reward_baseline"] = float(self.baseline[i])
            self._update_baseline(dones)  # the episodes that start now
        return obs, rewards.astype(np.float32), dones, infos

    def seed(self, seed: int | None = None):
        self._seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        return [getattr(self.venv.template, attr_name) for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        raise NotImplementedError("the batched env shares one configuration; create a new one instead")

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list[Any]:
        return [getattr(self.venv.template, method_name)(*method_args, **method_kwargs)
                for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]



class CycleActions(VecEnvWrapper):
    """A VecEnv whose action sets a two-period cycle: ``Box(10)``, the first 5 entries the waveform of
    the coming period, the last 5 that of the period after; one step plays both (their rewards
    summed, the observation after the second, the first period's infos in ``info["first_period"]``).
    A stationary policy can then choose the push/clamp cycles that carry heavy loads as one action.
    The wrapped env's episodes must last an even number of periods (``max_periods``)."""

    def __init__(self, venv):
        periods = venv.get_attr("max_periods")[0]
        if periods % 2:
            raise ValueError(f"action_cycle=2 needs episodes of an even number of periods, not max_periods={periods}")
        super().__init__(venv, action_space=cycle_space(venv.action_space))

    def reset(self):
        return self.venv.reset()

    def step_async(self, actions):
        self._pair = np.asarray(actions).reshape(self.num_envs, 2, -1)

    def step_wait(self):
        self.venv.step_async(self._pair[:, 0])
        _, first, done, first_infos = self.venv.step_wait()
        if done.any():  # cannot happen with an even episode length
            raise RuntimeError("an episode ended between the two periods of a cycle")
        self.venv.step_async(self._pair[:, 1])
        obs, second, done, infos = self.venv.step_wait()
        for info, earlier in zip(infos, first_infos):
            info["first_period"] = earlier
        return obs, first + second, done, infos

