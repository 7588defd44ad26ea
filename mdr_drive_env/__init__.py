"""mdr-drive: MDR model of a stick-slip piezo micro-drive, and a Gymnasium environment over it.

Importing the package registers ``MDRDrive-v0``; ``gym.make("mdr_drive_env:MDRDrive-v0")``
imports it on demand (also in subprocesses).
"""

#: The version of the distribution (pyproject.toml reads it from here; ``mdr-drive --version``).
__version__ = "0.2.0"

#: The full-observation env's id (what the agents train and play on).
ENV_ID = "MDRDrive-v0"
ENV_IDS = (ENV_ID, "MDRDriveSensor-v0")

#: MDRDriveSensor-v0: what an encoder measures, with k, the load and both frictions hidden and drawn
#: per episode (the load up to 0.4 of mu F_ref: about 1.25 times the trapezoid's critical load,
#: which lies at 0.18-0.33 of it over k at mu = 0.3).
SENSOR_DEFAULTS = {"observation": "sensor", "k": (0.0, 0.6), "load_ratio": (0.0, 0.4),
                   "friction_coefficient": (0.2, 0.4), "base_friction_coefficient": (0.07, 0.13)}


def register_envs() -> None:
    """Register the package's environments with Gymnasium (idempotent)."""
    from gymnasium.envs.registration import register, registry

    if "MDRDriveSensor-v0" not in registry:
        # the defaults are applied by the entry points, so that a cargo_mass given replaces load_ratio
        register(id="MDRDriveSensor-v0", entry_point="mdr_drive_env.gym_envs.mdr_drive:make_sensor_env",
                 vector_entry_point="mdr_drive_env.gym_envs.vector:make_sensor_vector_env")  # says: sync/async
    if "MDRDrive-v0" not in registry:
        register(id="MDRDrive-v0", entry_point="mdr_drive_env.gym_envs.mdr_drive:make_env",
                 vector_entry_point="mdr_drive_env.gym_envs:MDRDriveVectorEnv")


register_envs()
