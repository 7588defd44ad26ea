"""A teacher that picks its drives for a load known only to a few per cent (``LoadBand``): the
student that plays them reads the load from motion, so the drive it is told to play runs at a load
somewhat off the one it was picked for. ``DriveField.best`` and ``FrictionField.best`` take one;
``DistillConfig.teacher_load_band`` sets it for a student's labels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mdr_drive_env.core.params import check_range

from ..drive import PAPER_DRIVE, DriveDescription
from ..protocol import open_loop_velocity


def check_load_factors(name: str, scales) -> None:
    """A band's load factors: each in (0, 2) and none 1 (the point's own load always counts); a
    ``ValueError`` naming ``name`` otherwise."""
    for s in scales:
        check_range(name, s, 0.0, 2.0, low_open=True, high_open=True)
    if any(abs(float(s) - 1.0) < 1e-9 for s in scales):
        raise ValueError(f"{name}={list(scales)!r} must not hold 1 (the point's own load always counts)")


@dataclass(frozen=True)
class LoadBand:
    """A teacher that picks for an uncertain load: where the student that plays its drives reads the
    load from motion, to a few per cent, the drive it is told to play runs at a load somewhat off
    the one it was picked for, and the fastest drive at a point can sit just below a critical load
    of its own and lose much of its velocity a little heavier. Each candidate is then played at the
    point's load times each of ``scales`` (and 1) and scored by its worst ratio, over those loads,
    to the fastest candidate there (loads where the fastest moves less than ``floor`` times the
    drive's stroke speed do not count); the teacher plays the best-scored candidate among those
    within ``max_loss`` (relative) of the fastest at the point itself (minimax regret over the
    band).

    Attributes:
        scales: the load factors (-), each in (0, 2) and not 1, e.g. (0.92, 1.08) for a load read to
            about 8 %.
        max_loss: the most a picked drive may lose at the point against the fastest candidate there (-).
        floor: loads where the fastest candidate is slower than this times the stroke speed are not
            scored (-).
    """

    scales: tuple[float, ...]
    max_loss: float = 0.1
    floor: float = 0.1

    def __post_init__(self) -> None:
        if not self.scales:
            raise ValueError("load_band scales=() is empty: give load factors such as [0.92, 1.08]")
        check_load_factors("load_band scales", self.scales)
        check_range("load_band max_loss", self.max_loss, 0.0, 1.0, high_open=True)
        check_range("load_band floor", self.floor, 0.0, 1.0)

    @property
    def all_scales(self) -> np.ndarray:
        """1 (the point's own load), then ``scales``."""
        return np.array([1.0, *map(float, self.scales)])

    def scores(self, velocities: np.ndarray, stroke_speed: float) -> np.ndarray:
        """Each candidate's score from its velocities (len(all_scales), c) m/s at the band's loads:
        its worst ratio to the fastest candidate at the loads where that moves at least ``floor``
        times ``stroke_speed`` (1 where none does), or -inf if it loses more than ``max_loss`` at
        the point's own load (row 0)."""
        top = velocities.max(axis=1, keepdims=True)
        counted = top > self.floor * stroke_speed
        ratio = np.where(counted, velocities / np.where(counted, top, 1.0), 1.0)
        score = ratio.min(axis=0)
        own = velocities[0] >= top[0] - self.max_loss * abs(top[0])
        return np.where(own, score, -np.inf)

    def pick(self, points, cands: list, prefer_interpolation: float,
             drive: DriveDescription = PAPER_DRIVE) -> tuple[np.ndarray, np.ndarray]:
        """``pick_best`` with this band: per point the best-scored candidate (the first, an
        interpolation, unless another scores more than ``prefer_interpolation`` higher), all
        candidates at all the band's loads in one batched call; drives (n, 2, 5) and their
        velocities (n,) m/s at the points."""
        scales = self.all_scales
        at = [(p[0], p[1] * s, *p[2:]) for p, c in zip(points, cands) for s in scales for _ in c]
        v = open_loop_velocity(at, np.concatenate([np.concatenate([c] * len(scales)) for c in cands]), drive=drive)
        drives, velocities, start = [], [], 0
        for c in cands:
            vc = v[start:start + len(c) * len(scales)].reshape(len(scales), len(c))
            start += len(c) * len(scales)
            score = self.scores(vc, drive.stroke_speed)
            pick = int(np.argmax(score))
            if score[pick] <= score[0] + prefer_interpolation:
                pick = 0
            drives.append(c[pick])
            velocities.append(vc[0, pick])
        return np.array(drives), np.array(velocities)


__all__ = ["LoadBand", "check_load_factors"]
