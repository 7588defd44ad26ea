"""Training and evaluation of waveform policies on MDRDrive-v0 (Stable-Baselines3)."""

import mdr_drive_env  # noqa: F401  (first: it pins numpy's BLAS kernels before numpy loads, mdr_drive_env.blas)
