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
from stable_baselines3.common.vec_env.base_vec_env import VecEnv


class BatchedVecEnv(VecEnv):
    """``MDRDrive-v0``'s batched vector env (one compiled call per period for all envs) as an SB3 VecEnv.

    Args:
        num_envs: number of drives.
        seed: base seed (sub-env i gets ``seed + i``).
        **env_kwargs: keyword arguments of ``MDRDrive-v0`` (``numerics`` must be the fast solver).
    """

    def __init__(self, num_envs: int, seed: int | None = None, **env_kwargs: Any):
        self.venv = gym.make_vec("MDRDrive-v0", num_envs=num_envs, vectorization_mode="vector_entry_point",
                                 autoreset_mode=AutoresetMode.SAME_STEP, **env_kwargs)
        super().__init__(num_envs, self.venv.single_observation_space, self.venv.single_action_space)
        self._seed = seed
        self._actions: np.ndarray | None = None

    def reset(self) -> np.ndarray:
        obs, _ = self.venv.reset(seed=self._seed)
        self._seed = None  # seed only the first reset, as SB3 does
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
