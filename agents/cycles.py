"""Two-action cycles: a drive (2, 5) plays its first action, then its second, then its first again.

A drive is stored as its two actions; which one is written first (its phase) is arbitrary, so two
drives are compared, interpolated or fitted in the phase that brings them closest
(``align_phase``), and a policy imitating a drive plays the action that follows the one it played
last (``cycle_action``). A fixed drive has both actions equal. On a grid of drives, the phases that
agree best over the whole grid are ``grid_phases``'s.
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


def grid_phases(drives: np.ndarray) -> np.ndarray:
    """The phase of every drive on a grid (n_k, n_s, 2, 5) that agrees best with its grid neighbours:
    (n_k, n_s) bool, True where the drive is to be written swapped.

    Each pair of grid neighbours says whether one drive is closer to the other swapped or as written,
    and how surely: the difference of the two distances (summed absolute differences; 0 between
    fixed drives, large between a cycle and itself). The phases follow the surest pairs first, along
    a maximum spanning tree of the grid (Kruskal) from node (0, 0) as written, so a pair that cannot
    tell (two unlike drives) never overrides the pairs around it that can: one new drive on a k line
    does not flip the heavier nodes of that line when their k neighbours hold the same cycles."""
    drives = np.asarray(drives, dtype=np.float64)
    nk, ns = drives.shape[:2]
    index = np.arange(nk * ns).reshape(nk, ns)
    pairs = []
    for a, b, da, db in ((index[:-1], index[1:], drives[:-1], drives[1:]),  # along k
                         (index[:, :-1], index[:, 1:], drives[:, :-1], drives[:, 1:])):  # along the load
        as_written = np.abs(da - db).sum(axis=(-2, -1))
        swapped = np.abs(da - db[..., ::-1, :]).sum(axis=(-2, -1))
        pairs.append(np.stack([np.abs(as_written - swapped).ravel(), a.ravel(), b.ravel(),
                               (swapped < as_written).ravel()], axis=1))
    pairs = np.concatenate(pairs)
    pairs = pairs[np.lexsort((pairs[:, 2], pairs[:, 1], -pairs[:, 0]))]  # surest first, ties in grid order
    root = list(range(nk * ns))

    def find(n: int) -> int:
        while root[n] != n:
            root[n] = root[root[n]]
            n = root[n]
        return n

    tree: list[list[tuple[int, bool]]] = [[] for _ in range(nk * ns)]
    for _, a, b, flip in pairs:
        a, b = int(a), int(b)
        ra, rb = find(a), find(b)
        if ra != rb:
            root[ra] = rb
            tree[a].append((b, bool(flip)))
            tree[b].append((a, bool(flip)))
    swap = np.zeros(nk * ns, dtype=bool)
    seen, stack = {0}, [0]
    while stack:
        a = stack.pop()
        for b, flip in tree[a]:
            if b not in seen:
                seen.add(b)
                swap[b] = swap[a] ^ flip
                stack.append(b)
    return swap.reshape(nk, ns)


def cycle_action(drives: np.ndarray, previous_actions: np.ndarray) -> np.ndarray:
    """The action each drive (n, 2, 5) plays after ``previous_actions`` (n, 5): its second action
    after a period closer to its first, else its first (also after a zero action, an episode's
    start); a fixed drive (both actions equal) plays its action."""
    prev = np.asarray(previous_actions, dtype=np.float64)
    first, second = drives[:, 0], drives[:, 1]
    after_first = (np.abs(prev - first).sum(1) < np.abs(prev - second).sum(1)) & (np.abs(prev).sum(1) > 0)
    return np.where(after_first[:, None], second, first)


__all__ = ["align_phase", "cycle_action", "grid_phases", "swap_is_closer"]
