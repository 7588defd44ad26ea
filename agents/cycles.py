"""Two-action cycles: a drive (2, 5) plays its first action, then its second, then its first again.

A drive is stored as its two actions; which one is written first (its phase) is arbitrary, so two
drives are compared, interpolated or fitted in the phase that brings them closest
(``align_phase``), and a policy imitating a drive plays the action that follows the one it played
last (``cycle_action``). A fixed drive has both actions equal.
"""

from __future__ import annotations

import numpy as np


def swap_is_closer(drives: np.ndarray, references: np.ndarray) -> np.ndarray:
    """Per pair, whether the swapped cycle of ``drives`` (n, 2, 5) is closer to ``references`` (n, 2, 5)
    than the cycle as written (summed absolute differences): (n,) bool."""
    return (np.abs(drives[:, ::-1] - references).sum(axis=(1, 2)) < np.abs(drives - references).sum(axis=(1, 2)))


def align_phase(drive: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """``drive`` (2, 5) or its swapped cycle, whichever is closer to ``reference`` (2, 5); or so pair
    by pair for ``drive`` and ``reference`` (n, 2, 5)."""
    if drive.ndim == 2:
        return drive[::-1] if swap_is_closer(drive[None], reference[None])[0] else drive
    return np.where(swap_is_closer(drive, reference)[:, None, None], drive[:, ::-1], drive)


def cycle_action(drives: np.ndarray, previous_actions: np.ndarray) -> np.ndarray:
    """The action each drive (n, 2, 5) plays after ``previous_actions`` (n, 5): its second action
    after a period closer to its first, else its first (also after a zero action, an episode's
    start); a fixed drive (both actions equal) plays its action."""
    prev = np.asarray(previous_actions, dtype=np.float64)
    first, second = drives[:, 0], drives[:, 1]
    after_first = (np.abs(prev - first).sum(1) < np.abs(prev - second).sum(1)) & (np.abs(prev).sum(1) > 0)
    return np.where(after_first[:, None], second, first)


__all__ = ["align_phase", "cycle_action", "swap_is_closer"]
