import os
from mdr_drive_env.gym_envs.spaces import ActionMap
q = float(os.environ.get("TIME_QUANTUM", "1e-5"))
d = list(ActionMap.__init__.__defaults__)
names = ["period", "x_amplitude_max", "z_amplitude_max", "min_rise_fraction", "max_rise_fraction", "time_step", "time_quantum", "z_phase_origin"]
d[names.index("time_quantum")] = q
ActionMap.__init__.__defaults__ = tuple(d)
assert ActionMap().time_quantum == q
