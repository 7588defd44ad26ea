"""A blind benchmark's points as a reference to score any drive against: each point's (k, cargo
mass), and the steady velocities of the trapezoid and of the best drive the benchmark's search found
there (``mdr-drive benchmark --blind``'s ``blind.json``).

    from mdr_drive_agents import load_policy
    from mdr_drive_agents.benchmarks.reference import Reference

    reference = Reference.load("results/record/seed20261256/blind.json")
    found = reference.score_policy(load_policy("agents/pretrained/ppo_plain"))
    found["score"]            # IQM and mean normalised score with 95 % bootstrap intervals
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..drive import PAPER_DRIVE, DriveDescription
from ..protocol import TIME_QUANTUM, drive_of, policy_velocity
from .score import aggregate, normalized_scores
from .targets import MOVING_THRESHOLD, velocity_statistics


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
        learned: the steady velocities (m/s) of the policies the benchmark judged, by the folder it
            ran them from.
        drive: the drive it was run on (``blind.json``'s ``drive``; the paper's without one).
    """

    name: str
    points: tuple[tuple[float, float], ...]
    trapezoid: np.ndarray
    best: np.ndarray
    time_quantum: float
    learned: dict = field(default_factory=dict)
    drive: DriveDescription = PAPER_DRIVE

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
            learned = {policy: np.array([np.nan if v is None else v for v in velocity], dtype=float)
                       for policy, velocity in (res.get("learned") or {}).items()}
            drive = DriveDescription.from_record(res["drive"]) if res.get("drive") else PAPER_DRIVE
        except OSError as e:
            raise ValueError(f"{path}: cannot be read ({e.strerror or e})") from None
        except (ValueError, KeyError, TypeError) as e:
            raise ValueError(f"{path} is not a blind benchmark's blind.json ({type(e).__name__}: {e})") from None
        if not len(points) == len(trap) == len(best):
            raise ValueError(f"{path}: its points, trapezoid and best velocities differ in number")
        return cls(name, points, trap, best, quantum, learned, drive)

    def scores(self, velocity) -> np.ndarray:
        """The normalised score of steady velocities ``velocity`` (m/s, one per point; NaN where
        unscored, ``benchmarks.score``)."""
        return normalized_scores(self.trapezoid, self.best, velocity)

    def load_fractions(self) -> np.ndarray:
        """Each point's cargo mass over the trapezoid's critical load at its k (the blind benchmark
        draws them from 0 to 1.25)."""
        from ..protocol import trapezoid_critical_load

        ks = [k for k, _ in self.points]
        return np.array([m for _, m in self.points]) / trapezoid_critical_load(ks, self.drive)

    def fractions_of_best(self, velocity) -> np.ndarray:
        """The fraction of the best drive at each point where it moves at least ``MOVING_THRESHOLD``
        (a runaway counts as 0)."""
        moving = self.best >= MOVING_THRESHOLD
        return np.nan_to_num(np.asarray(velocity, dtype=float), nan=0.0)[moving] / self.best[moving]

    def statistics(self, velocity) -> dict:
        """The blind benchmark's velocity statistics of ``velocity`` (``targets.velocity_statistics``)."""
        return velocity_statistics(self.trapezoid, self.best, np.asarray(velocity, dtype=float))

    def score_policy(self, policy) -> dict:
        """A closed-loop ``policy``'s (``load_policy``'s, or any ``act(obs) -> Box actions``) steady
        velocity at every point (m/s; NaN a runaway), its normalised score there and the aggregates:
        ``score`` (IQM and mean, bootstrap over the points), the fraction of the best drive and the
        blind statistics. The policy must act at this reference's time quantum (as its search did)
        and have been built for its drive."""
        if drive_of(policy, self.drive).stage_settings != self.drive.stage_settings:
            raise ValueError(f"the policy was built for another drive than this reference's ({self.drive.name}): "
                             "score it against a blind benchmark run on its own")
        quantum = float(getattr(policy, "play_kwargs", {}).get("time_quantum", TIME_QUANTUM))
        if quantum != self.time_quantum:
            raise ValueError(f"the policy acts at a time quantum of {quantum:g} s, this reference's search at "
                             f"{self.time_quantum:g} s: score it against a blind benchmark run at its own")
        velocity = policy_velocity(policy, list(self.points), mark_runaway=True, drive=self.drive)
        scores = self.scores(velocity)
        return {"velocity": velocity, "scores": scores, "score": aggregate([scores]),
                "fraction_of_best": aggregate([self.fractions_of_best(velocity)]),
                "statistics": self.statistics(velocity)}


def common_time_quantum(references) -> float:
    """The time quantum (s) of ``references``; ``ValueError`` if they differ."""
    quanta = {r.time_quantum for r in references}
    if len(quanta) != 1:
        raise ValueError(f"the blind records' searches ran at different time quanta {sorted(quanta)} s")
    return quanta.pop()


__all__ = ["Reference", "common_time_quantum"]
