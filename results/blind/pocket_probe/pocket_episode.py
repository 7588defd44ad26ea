"""One closed-loop episode of a policy at (k, m): per period its velocity, action and observation."""
import sys
import numpy as np
import gymnasium as gym
sys.path.insert(0, ".")
import mdr_drive_env  # noqa
from mdr_drive_agents.evaluate import Policy
pol = Policy(sys.argv[1]); k = float(sys.argv[2]); m = float(sys.argv[3]); n = int(sys.argv[4]) if len(sys.argv) > 4 else 12
env = gym.make("MDRDrive-v0", k=k, cargo_mass=m, max_periods=30, **pol.play_kwargs)
obs, _ = env.reset(seed=0)
st = env.unwrapped.observation_structure
print({k_: (v.start, v.stop) for k_, v in st.items()})
np.set_printoptions(precision=3, suppress=True, linewidth=200)
for t in range(n):
    a = np.asarray(pol(obs[None]), dtype=np.float32).reshape(5)
    print(t, "obs", obs, "act", a)
    obs, r, term, trunc, info = env.step(a)
    print("   v mm/s", 1e3 * info["mean_velocity"])
