"""Gymnasium environments over the drive simulator (they know nothing of RL libraries)."""

from .mdr_drive import MDRDriveEnv
from .spaces import ActionMap, ObservationLayout
from .vector import MDRDriveVectorEnv

__all__ = ["ActionMap", "MDRDriveEnv", "MDRDriveVectorEnv", "ObservationLayout"]
