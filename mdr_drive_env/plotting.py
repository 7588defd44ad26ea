"""Plots of a simulated run (matplotlib PNG, written atomically)."""

from __future__ import annotations

import textwrap

from .core import concat_traces
from .core import kernel as K
from .files import save_figure


def plot_run(results, path: str, title: str, mu: float = 0.3) -> None:
    """X(t), indenter x(t), z(t) and the contact forces of a run, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr = concat_traces(results)
    t = tr[:, K.T_TIME] * 1e3
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    a1.plot(t, tr[:, K.T_X] * 1e6, label="indenter x", lw=0.8)
    a1.plot(t, tr[:, K.T_Z] * 1e6 * 5, label="indenter z (x5)", lw=0.8)
    a1.plot(t, tr[:, K.T_SLIDER_X] * 1e6, label="slider X", lw=1.5)
    a1.set(ylabel="position (µm)")
    a1.set_title("\n".join(textwrap.fill(line, 95) for line in title.splitlines()), fontsize=9)
    a2.plot(t, tr[:, K.T_FX], label="F_x", lw=0.8)
    a2.plot(t, tr[:, K.T_FZ] * mu, label="mu F_z (Coulomb bound)", lw=0.8)
    a2.set(xlabel="t (ms)", ylabel="force (N)")
    for a in (a1, a2):
        a.legend(fontsize=8)
        a.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
