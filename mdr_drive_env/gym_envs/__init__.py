"""Gymnasium environments over the drive simulator (they know nothing of RL libraries)."""

from .mdr_drive import MDRDriveEnv
from .spaces import ActionMap, ObservationLayout

__all__ = ["ActionMap", "MDRDriveEnv", "ObservationLayout"]
