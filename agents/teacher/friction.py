"""A teacher that knows friction: drive fields at several ratios ``rho = mu1 / mu``, queried at any
(k, load, mu, mu1).

The steady velocity of a drive depends little on mu itself at a given load over mu F_ref, but much
on the ratio ``rho = mu1 / mu`` (the base friction against the contact's): played at (k, load, 0.2,
0.1) and at (k, 1.5 load, 0.3, 0.15), one drive gives nearly the same velocity; at mu1 1.3 times
larger, often half of it. So the teacher is searched along rho only: one ``DriveField`` per rho,
each at mu = ``FIELD_MU``, and ``FrictionField.best`` plays the drives of the two fields whose rho
brackets a point's, each read at the same load over mu F_ref, and their mixture, and keeps the best.
Its recipe (the fields, then a student on the privileged observation) is
``mdr_drive_agents.train.friction_teacher``.
"""

from __future__ import annotations

import numpy as np

from mdr_drive_env.core.params import check_int

from ..cycles import align_phase
from .config import PAPER_FRICTION
from .field import DriveField, pick_best, with_friction
from .load_band import LoadBand

#: mu of every field: the fields differ in mu1 only (the load scales with mu).
FIELD_MU = PAPER_FRICTION[0]


class FrictionField:
    """Drive fields at increasing ``rho = mu1 / mu`` (each searched at mu = ``FIELD_MU``), queried at
    (k, load kg, mu, mu1) points."""

    def __init__(self, fields: list[DriveField]):
        if not fields:
            raise ValueError("a FrictionField needs at least one drive field")
        fields = sorted(fields, key=lambda f: f.friction[1] / f.friction[0])
        self.fields = fields
        self.rhos = np.array([f.friction[1] / f.friction[0] for f in fields])
        if len(set(np.round(self.rhos, 9))) != len(self.rhos):
            raise ValueError(f"two fields share a ratio mu1 / mu: {self.rhos.tolist()}")
        ks = fields[0].ks
        self.ks = ks
        self.trapezoid_critical = fields[0].trapezoid_critical  # at the paper's friction: loads' scale
        self.drive = fields[0].drive
        if any(f.drive.settings != self.drive.settings for f in fields[1:]):
            raise ValueError("the fields must be searched on the same drive")
        for f in fields[1:]:
            if f.ks.shape != ks.shape or not np.allclose(f.ks, ks):
                raise ValueError("the fields must share their k grid")

    def _bracket(self, rho: float) -> tuple[int, int, float]:
        """Indices of the fields below and above ``rho`` and the weight of the upper one (clipped to
        the fields' range)."""
        if len(self.rhos) == 1:
            return 0, 0, 0.0
        r = float(np.clip(rho, self.rhos[0], self.rhos[-1]))
        i = int(min(np.searchsorted(self.rhos, r, side="right") - 1, len(self.rhos) - 2))
        return i, i + 1, (r - self.rhos[i]) / (self.rhos[i + 1] - self.rhos[i])

    def candidates(self, point, radius: int = 1, interpolation: bool = True) -> np.ndarray:
        """(c, 2, 5) drives for (k, load kg, mu, mu1): the mixture of the two bracketing fields'
        interpolations (weighted by rho), then each field's :meth:`DriveField.candidates` at the same
        load over mu F_ref, all aligned to the lower field's interpolation. Without ``interpolation``:
        the two fields' grid drives only (each field's candidates but its interpolation), so every
        drive is one of the fields' own."""
        k, _, mu, mu1 = point
        lo, hi, w = self._bracket(mu1 / mu)
        skip = 0 if interpolation else 1
        below = self.fields[lo].candidates(k, self.fields[lo].field_load(point), radius)
        if hi == lo:
            return below[skip:]
        above = [align_phase(c, below[0]) for c in
                 self.fields[hi].candidates(k, self.fields[hi].field_load(point), radius)]
        if not interpolation:
            return np.array([*below[1:], *above[1:]])
        mixed = (1.0 - w) * below[0] + w * above[0]
        return np.array([mixed, *below, *above])

    def best(self, points, prefer_interpolation: float = 0.02, radius: int = 1,
             interpolation: bool = True, load_band: LoadBand | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The teacher's drive (n, 2, 5) and its velocity (n,) m/s at each (k, load kg, mu, mu1)
        point ((k, load) points: the paper's friction): the best of :meth:`candidates` played there,
        the mixture unless another is better by more than ``prefer_interpolation`` (relative).
        Without ``interpolation``: the best of the fields' own grid drives, what a student that
        picks among them (``grid_actions``) can be taught. With ``load_band``, the candidate that
        holds best over a band of load around each point (``LoadBand``)."""
        check_int("radius", radius, 1)
        points = with_friction(points, PAPER_FRICTION)
        cands = [self.candidates(p, radius, interpolation) for p in points]
        return pick_best(points, cands, prefer_interpolation if interpolation else 0.0, self.drive, load_band)

    @classmethod
    def load(cls, paths) -> "FrictionField":
        return cls([DriveField.load(p) for p in paths])


__all__ = ["FIELD_MU", "FrictionField"]
