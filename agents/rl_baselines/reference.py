"""A blind benchmark's points as a reference to score drives against: each point's (k, cargo mass),
and the steady velocities of the trapezoid and of the best drive the benchmark's search found there
(``mdr-drive benchmark --blind``'s ``blind.json``)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..benchmarks.score import normalized_scores
from ..benchmarks.targets import velocity_statistics
from ..protocol import TIME_QUANTUM


@dataclass(frozen=True)
class Reference:
    """The points of one blind benchmark and its references there.

    Attributes:
        name: how tables name it (``seed <S>``).
        points: ((k, cargo mass in kg), ...).
        trapezoid: the trapezoid's steady velocity at each point (m/s; NaN a runaway).
        best: the best drive's steady velocity at each point (m/s).
        time_quantum: the time quantum (s) its search's drives act at: drives scored against it act
            at the same.
    """

    name: str
    points: tuple[tuple[float, float], ...]
    trapezoid: np.ndarray
    best: np.ndarray
    time_quantum: float

    @classmethod
    def load(cls, path: str | Path) -> "Reference":
        """The reference in a ``blind.json``; ``ValueError`` naming the file if it is not one."""
        try:
            res = json.loads(Path(path).read_text())
            points = tuple((float(k), float(m)) for k, m in res["points"])
            trap = np.array([np.nan if v is None else v for v in res["trapezoid"]], dtype=float)
            best = np.array([np.nan if b["velocity"] is None else b["velocity"] for b in res["best"]], dtype=float)
            quantum = float(res.get("search", {}).get("time_quantum_s", TIME_QUANTUM))
            name = f"seed {res['seed']}"
        except OSError as e:
            raise ValueError(f"{path}: cannot be read ({e.strerror or e})") from None
        except (ValueError, KeyError, TypeError) as e:
            raise ValueError(f"{path} is not a blind benchmark's blind.json ({type(e).__name__}: {e})") from None
        if not len(points) == len(trap) == len(best):
            raise ValueError(f"{path}: its points, trapezoid and best velocities differ in number")
        return cls(name, points, trap, best, quantum)

    def scores(self, velocity) -> np.ndarray:
        """The normalised score of steady velocities ``velocity`` (m/s, one per point; NaN where
        unscored, ``benchmarks.score``)."""
        return normalized_scores(self.trapezoid, self.best, velocity)

    def statistics(self, velocity) -> dict:
        """The blind benchmark's velocity statistics of ``velocity`` (``targets.velocity_statistics``)."""
        return velocity_statistics(self.trapezoid, self.best, np.asarray(velocity, dtype=float))


def common_time_quantum(references) -> float:
    """The time quantum (s) of ``references``; ``ValueError`` if they differ."""
    quanta = {r.time_quantum for r in references}
    if len(quanta) != 1:
        raise ValueError(f"the blind records' searches ran at different time quanta {sorted(quanta)} s")
    return quanta.pop()


__all__ = ["Reference", "common_time_quantum"]
