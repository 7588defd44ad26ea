"""mdr-drive: MDR model of a stick-slip piezo micro-drive, and a Gymnasium environment over it.

Importing the package registers ``MDRDrive-v0``; ``gym.make("mdr_drive_env:MDRDrive-v0")``
imports it on demand (also in subprocesses).
"""

__version__ = "0.1.0"

ENV_IDS = ("MDRDrive-v0",)


def register_envs() -> None:
    """Register the package's environments with Gymnasium (idempotent)."""
    from gymnasium.envs.registration import register, registry

    if "MDRDrive-v0" not in registry:
        register(id="MDRDrive-v0", entry_point="mdr_drive_env.gym_envs.mdr_drive:make_env",
                 vector_entry_point="mdr_drive_env.gym_envs:MDRDriveVectorEnv")


register_envs()
