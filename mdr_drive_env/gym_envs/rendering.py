"""Matplotlib rendering of MDRDrive: the last period's x(t), z(t), X(t), its reward and mean velocity,
and a sketch of the drive with the load."""

from __future__ import annotations

import os

import numpy as np

from ..core import kernel as K


class Renderer:
    """Draws frames for ``rgb_array`` (returned as (H, W, 3) uint8) or shows them (``human``)."""

    def __init__(self, human: bool = False):
        import matplotlib

        if not human or not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            human = False  # headless: draw off-screen (documented), no window
            if matplotlib.get_backend().lower() != "agg":
                matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        self.plt = plt
        self.human = human
        self.fig, (self.ax_t, self.ax_s) = plt.subplots(1, 2, figsize=(9, 3.4), width_ratios=[2, 1])

    def draw(self, env) -> np.ndarray | None:
        ax, sk = self.ax_t, self.ax_s
        ax.clear()
        sk.clear()
        tr = env.last_trace
        if tr is not None and len(tr):
            t = (tr[:, K.T_TIME] - tr[0, K.T_TIME]) * 1e3
            ax.plot(t, tr[:, K.T_X] * 1e6, label="indenter x")
            ax.plot(t, tr[:, K.T_Z] * 1e6 * 5, label="indenter z (x5)")
            ax.plot(t, (tr[:, K.T_SLIDER_X] - tr[0, K.T_SLIDER_X]) * 1e6, label="slider X - X0", lw=2)
            ax.legend(fontsize=7, loc="upper left")
            title = (f"period {env.period_index}: reward {env.last_reward:.3f}, "
                     f"mean velocity {env.last_mean_velocity * 1e3:.2f} mm/s")
        else:
            ax.text(0.5, 0.5, "no period simulated yet", transform=ax.transAxes, ha="center", va="center",
                    fontsize=11, color="0.4")
            title = "after reset"
        ax.set(xlabel="t in last period (ms)", ylabel="µm",
               title=f"{title}\nk = {env.k:.2f}, m = {env.cargo_mass:.3f} kg, load F_m = {env.params.drive.load:.3g} N")
        ax.title.set_fontsize(9)
        ax.grid(alpha=0.3)
        # sketch in the lab frame: base, slider (ticks move with X), paraboloid indenter at (x, z)
        sim = env.sim
        X = sim.position * 1e6 if sim is not None else 0.0
        x_ind = float(tr[-1, K.T_X]) * 1e6 if tr is not None and len(tr) else 0.0
        depth = sim.indenter_depth * 1e6 if sim is not None else 0.0
        sk.axhline(0, color="k", lw=2)
        sk.add_patch(self.plt.Rectangle((-60, 0), 150, 20, color="tab:blue", alpha=0.5))
        for tick in np.arange(-60, 100, 20) + (X % 20):
            sk.plot([tick, tick], [2, 8], color="tab:blue", lw=1)
        r = np.linspace(-25, 25, 60)
        sk.plot(x_ind + r, 20 - 2 * depth + r**2 / 40, color="tab:red", lw=2)
        sk.text(-55, 23, "slider", fontsize=7)
        sk.annotate("", xy=(-58, 10), xytext=(-28, 10),
                    arrowprops=dict(arrowstyle="-|>", color="tab:green", lw=2))  # the load pulls towards -X
        sk.text(-57, 12.5, f"F_m {env.params.drive.load:.3g} N", fontsize=7, color="tab:green", ha="left")
        sk.text(x_ind - 10, 38, "indenter", fontsize=7, color="tab:red")
        sk.set(xlim=(-60, 90), ylim=(-5, 45), xticks=[], yticks=[],
               title=f"X = {X:.1f} µm, x = {x_ind:.1f} µm, d = {depth:.2f} µm")
        sk.title.set_fontsize(8)
        self.fig.tight_layout()
        self.fig.canvas.draw()
        if self.human:
            self.plt.pause(1.0 / 60)
            return None
        return np.asarray(self.fig.canvas.buffer_rgba())[..., :3].copy()

    def close(self) -> None:
        self.plt.close(self.fig)
