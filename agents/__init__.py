"""Training and evaluation of waveform policies on MDRDrive-v0 (Stable-Baselines3)."""
