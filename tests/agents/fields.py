"""Synthetic drive fields for the agents' tests."""

import numpy as np

from mdr_drive_agents.drive import PAPER_DRIVE
from mdr_drive_agents.teacher import DriveField


def synthetic_field(nk: int = 4, ns: int = 5) -> DriveField:
    """A drive field of ``nk`` k lines over [0, 0.6] and ``ns`` load fractions over [0, 1.2] with
    random drives (seed 0) and zero velocities."""
    rng = np.random.default_rng(0)
    drives = np.clip(rng.normal(0.5, 0.3, (nk, ns, 2, 5)), -1.0, 1.0)
    return DriveField(np.linspace(0.0, 0.6, nk), np.linspace(0.0, 1.2, ns), np.full(nk, 0.05), drives,
                      np.zeros((nk, ns)))


class StepTeacher:
    """A stand-in teacher whose drive jumps from A to B at k = 0.3 (one cycle phase of B swapped:
    the comparison must not count the phase as a jump), and a constant one."""

    ks, trapezoid_critical = np.array([0.0, 0.6]), np.array([0.1, 0.1])
    A = np.array([[0.9, 0.1, 1.0, -0.2, 0.5], [0.8, 0.3, 1.0, -0.1, 0.4]])
    B = np.array([[-0.6, -0.9, 1.0, -1.0, 0.9], [1.0, 0.9, 1.0, 0.0, 1.0]])
    drive = PAPER_DRIVE

    def __init__(self, jump=True):
        self.jump, self.calls = jump, 0

    def best(self, points, radius=1):
        self.calls += 1
        k = np.array([p[0] for p in points])
        b = np.where(np.arange(len(k)) % 2 == 0, 1, 0)  # every other B written in the swapped phase
        drives = np.where(((k >= 0.3) & self.jump)[:, None, None], np.where(b[:, None, None], self.B, self.B[::-1]), self.A)
        return drives, np.zeros(len(k))


def friction_field(mu1: float, ks=(0.0, 0.3), fill: float = 0.5) -> DriveField:
    """A synthetic 2 x 3 field searched (notionally) at mu = 0.3, mu1."""
    drives = np.full((len(ks), 3, 2, 5), fill)
    return DriveField(np.array(ks), np.linspace(0.0, 1.2, 3), np.full(len(ks), 0.05), drives, np.zeros((len(ks), 3)),
                      {"config": {"friction": [0.3, mu1]}})
