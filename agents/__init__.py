"""Learned drive waveforms for MDRDrive-v0 (Stable-Baselines3): the shipped policies, how they are
made (``teacher``, ``student``, ``train``) and judged (``protocol``, ``search``, ``benchmarks``).

    from mdr_drive_agents import load_policy

    policy = load_policy("agents/pretrained/ppo_generalist")
    env = policy.make_env(k=0.2, cargo_mass=0.1)
"""

from .blas import pin_blas_kernels

pin_blas_kernels()  # before numpy loads, where it can: the same CMA-ES drives on every x86-64 CPU (blas.py)

from mdr_drive_env import __version__  # noqa: E402  one distribution, one version

from .policy import PRETRAINED, SENSOR_PRETRAINED, Policy, load_policy  # noqa: E402

__all__ = ["PRETRAINED", "SENSOR_PRETRAINED", "Policy", "__version__", "load_policy"]
