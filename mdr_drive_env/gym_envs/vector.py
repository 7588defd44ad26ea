"""MDRDrive-v0 as a native Gymnasium vector env: N drives stepped by one compiled call per period."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ..core import kernel as K
from ..core.batch import BatchedDriveSimulator
from .mdr_drive import MDRDriveEnv
from .spaces import ActionMap, ObservationLayout, PrivilegedLayout, codebook_rows

_INFO_KEYS = ("displacement", "mean_velocity", "end_velocity", "peak_tangential_force", "peak_normal_force",
              "indenter_dissipation", "base_dissipation", "load_work")
_OUT_COLUMNS = (K.O_DISPLACEMENT, K.O_MEAN_VELOCITY, None, K.O_PEAK_FX, K.O_PEAK_FZ, K.O_DISS_INDENTER,
                K.O_DISS_BASE, K.O_WORK_LOAD)


class MDRDriveVectorEnv(VectorEnv):
    """``num_envs`` copies of :class:`MDRDriveEnv` stepped together by the batched fast solver.

    Takes the single env's keyword arguments (``numerics`` must be a ``method="nodes"`` preset,
    default ``"fast"``) plus ``num_envs`` and ``autoreset_mode`` (``NEXT_STEP``, Gymnasium's default:
    the step after an episode ends resets that sub-env and ignores its action; or ``SAME_STEP``:
    the sub-env resets at once and ``info["final_obs"]``, ``info["final_info"]`` hold the last
    observation and info), and ``num_threads``: the threads that step the drives (default: the
    cores available; results are the same bit for bit for every thread count). Sub-env i seeded with ``seed + i`` plays exactly the episode of
    ``gym.make("MDRDrive-v0", numerics=...)`` reset with ``seed + i``, bit for bit.

    Create with ``gym.make_vec("MDRDrive-v0", num_envs=N, vectorization_mode="vector_entry_point")``.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, num_envs: int = 8, autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
                 render_mode: str | None = None, num_threads: int | None = None, **kwargs: Any):
        if not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs={num_envs!r} is outside the allowed range [1, inf)")
        if render_mode is not None:
            raise ValueError(f"render_mode={render_mode!r}: the vector env does not render; use MDRDrive-v0")
        mode = AutoresetMode(autoreset_mode)
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(f"autoreset_mode={autoreset_mode!r} is not one of ['NextStep', 'SameStep']")
        kwargs.setdefault("numerics", "fast")
        self.template = MDRDriveEnv(**kwargs)  # validates every argument
        if self.template.sensor is not None or self.template.load_step_range is not None:
            raise ValueError("the batched vector env has the full observation and fixed loads only; for "
                             "observation='sensor' or load_step_period use gym.make_vec(..., vectorization_mode="
                             "'sync' or 'async')")
        if self.template.numerics.method != "nodes":
            raise ValueError(f"numerics={kwargs['numerics']!r}: the vector env needs the fast solver (method='nodes')")
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        self.num_envs = int(num_envs)
        self.single_action_space = self.template.action_space
        self.single_observation_space = self.template.observation_space
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.sim = BatchedDriveSimulator(self.num_envs, self.template.numerics, self.template.action_map.z_amplitude_max,
                                         num_threads=num_threads)
        n = self.num_envs
        self.k = np.zeros(n)
        self.cargo_mass = np.zeros(n)
        self.load = np.zeros(n)
        self.friction_ref = np.ones(n)
        self.friction = np.zeros((n, 2))  # mu, mu1 of each drive (the privileged observation's last entries)
        self.force_ref = np.ones(n)
        self.period_index = np.zeros(n, dtype=np.int64)
        self.prev_action = np.zeros((n, ActionMap.SIZE))
        self._rngs = [seeding.np_random(None)[0] for _ in range(n)]
        self._autoreset = np.zeros(n, dtype=bool)
        self._last_obs = np.zeros((n, self.single_observation_space.shape[0]), dtype=np.float32)

    def _reset_one(self, i: int, options: dict[str, Any] | None, per_env: frozenset = frozenset()) -> None:
        t = self.template
        # an option in ``per_env`` (a sequence of num_envs values) sets sub-env i to its i-th value
        own = {key: (v[i] if key in per_env else v) for key, v in (options or {}).items()}
        self.k[i], self.cargo_mass[i], params = t.sample_episode(self._rngs[i], own)
        self.sim.set_params(i, params)
        self.load[i] = params.drive.load
        self.force_ref[i] = t.reference_force(params)
        self.friction_ref[i] = params.contact.friction_coefficient * self.force_ref[i]
        self.friction[i] = params.contact.friction_coefficient, params.contact.base_friction_coefficient
        self.period_index[i] = 0
        self.prev_action[i] = 0.0

    def _observe(self, dynamics: np.ndarray) -> np.ndarray:
        fraction = self.period_index / self.template.max_periods
        if self.template.observation == "privileged":
            return PrivilegedLayout.build(dynamics, self.prev_action, self.k, self.load, self.friction_ref, fraction,
                                          self.friction)
        return ObservationLayout.build(dynamics, self.prev_action, self.k, self.load, self.friction_ref, fraction)

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None):
        """Reset every sub-env (or those in ``options["reset_mask"]``); ``seed`` int -> seed + i.

        ``options["k"]``, ``options["cargo_mass"]``, ``options["friction_coefficient"]`` and
        ``options["base_friction_coefficient"]`` set the next episode of every reset sub-env, or,
        given as sequences of ``num_envs`` values, of each sub-env its own.
        """
        options = dict(options or {})
        mask = np.asarray(options.pop("reset_mask", np.ones(self.num_envs, dtype=bool)), dtype=bool)
        seeds = [None if seed is None else seed + i for i in range(self.num_envs)] if not isinstance(seed, list) else seed
        if len(seeds) != self.num_envs:
            raise ValueError(f"seed list of length {len(seeds)} for {self.num_envs} envs")
        # told apart once, not per sub-env: np.ndim converts a list, so per sub-env it cost O(num_envs^2)
        per_env = frozenset(key for key, v in options.items() if np.ndim(v) == 1 and len(v) == self.num_envs)
        for i in np.flatnonzero(mask):
            if seeds[i] is not None:
                self._rngs[i] = seeding.np_random(seeds[i])[0]
            self._reset_one(i, options, per_env)
        self._autoreset[mask] = False
        obs = self._observe(np.zeros((self.num_envs, 5)))
        self._last_obs[mask] = obs[mask]
        return self._last_obs.copy(), {"k": self.k.copy(), "cargo_mass": self.cargo_mass.copy(),
                                       "load_force": self.load.copy()}

    def step(self, actions):
        t = self.template
        amap = t.action_map
        if t.action_codebook is not None:  # indices into the table: its rows are the Box actions played
            actions = codebook_rows(t.action_codebook, np.asarray(actions).reshape(self.num_envs))
        actions = np.asarray(actions, dtype=np.float64).reshape(self.num_envs, ActionMap.SIZE)
        waveforms = amap.to_params_batch(actions)  # raises on non-finite actions, before any state changes
        stepped = ~self._autoreset
        out = self.sim.step(waveforms, amap.period)
        self.period_index[stepped] += 1
        self.prev_action[stepped] = np.clip(actions[stepped], -1.0, 1.0)
        end_v = self.sim.state[:, K.S_V]
        dynamics = t.dynamics_of(out[:, K.O_DISPLACEMENT], out[:, K.O_MEAN_VELOCITY], end_v, out[:, K.O_PEAK_FX],
                                 out[:, K.O_PEAK_FZ], self.force_ref,
                                 self.friction_ref)  # each drive's own mu: friction may be drawn per episode
        effort = amap.effort(waveforms[:, 0], waveforms[:, 2])
        rewards = t.reward_of(out[:, K.O_DISPLACEMENT], effort)
        obs = self._observe(dynamics)
        truncated = stepped & (self.period_index >= t.max_periods)
        terminated = np.zeros(self.num_envs, dtype=bool)
        info: dict[str, Any] = {"k": self.k.copy(), "cargo_mass": self.cargo_mass.copy(), "load_force": self.load.copy(),
                                "effort": effort, "slider_position": self.sim.state[:, K.S_X].copy()}
        for key, col in zip(_INFO_KEYS, _OUT_COLUMNS):
            info[key] = end_v.copy() if col is None else out[:, col].copy()
        info = {**info, **{f"_{key}": stepped.copy() for key in info}}

        # sub-envs that were waiting for their autoreset: reset now, ignore what was just stepped
        for i in np.flatnonzero(~stepped):
            self._reset_one(i, None)
        if (~stepped).any():
            fresh = self._observe(np.zeros((self.num_envs, 5)))
            obs[~stepped] = fresh[~stepped]
            rewards[~stepped] = 0.0
        if self.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP and truncated.any():
            final_obs = np.full(self.num_envs, None, dtype=object)
            for i in np.flatnonzero(truncated):
                final_obs[i] = obs[i].copy()
                self._reset_one(i, None)
            fresh = self._observe(np.zeros((self.num_envs, 5)))
            obs[truncated] = fresh[truncated]
            info["final_obs"], info["_final_obs"] = final_obs, truncated.copy()
            info["final_info"] = {k: v.copy() for k, v in info.items() if not k.startswith(("final", "_final"))}
            info["_final_info"] = truncated.copy()
        else:
            self._autoreset = truncated | terminated
        self._last_obs = obs
        return obs, rewards.astype(np.float64), terminated, truncated, info


def make_sensor_vector_env(**kwargs) -> MDRDriveVectorEnv:
    """``MDRDriveSensor-v0``'s vector entry point: the batched env with the sensor defaults, which
    refuses them (the sensor observation runs with ``vectorization_mode="sync"`` or ``"async"``)."""
    from .mdr_drive import sensor_kwargs

    return MDRDriveVectorEnv(**sensor_kwargs(kwargs))
