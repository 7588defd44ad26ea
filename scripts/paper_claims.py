"""Each claim of the paper's text about its Figs. 3-5, tested against model variants.

    python scripts/paper_claims.py --out results/paper_claims                 # fast numerics, ~1 min
    python scripts/paper_claims.py --numerics paper --models as-specified as-published \
        --out results/paper_claims_paper_numerics                             # the paper's numerics

The paper (Lyashenko, Borysiuk & Popov 2020) prints no data, only statements about its figures.
This script turns each statement into a test with a number that decides it, and runs it for the
model as specified, for the "as-published" variant (h_N doubled: the hypothesis about the paper's
own code, docs/paper_reproduction.md) and for other slips one could suspect (both h doubled, the
cargo's inertia, h_N x 1.5). <V> follows the paper's rule (the 6th period) as the paper's figures
do; the settled <V> is reported beside it. Writes ``claims.md`` (every claim with the numbers that
decide it), ``claims_summary.md`` (the yes/no grid) and ``claims.json``.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mdr_drive_env.cli_args import Parser, output_dir  # noqa: E402
from mdr_drive_env.core import DriveParams, DriveSimulator, Waveform, critical_load  # noqa: E402
from mdr_drive_env.core import kernel as K  # noqa: E402
from mdr_drive_env.files import write_text  # noqa: E402
from mdr_drive_env.reproduce import (  # noqa: E402
    FIG3_MASSES,
    FIG4_KS,
    FIG5_KS,
    FIG5_LEFT_KS,
    FIG5_LEFT_MASSES,
    FIG5_MASSES,
    fig5_case,
    scaled_h,
)


def _inertia(p: DriveParams) -> DriveParams:
    return dataclasses.replace(p, drive=dataclasses.replace(p.drive, cargo_inertia=True))


#: The models tested: name -> params(k, m).
MODELS = {
    "as-specified": lambda k, m: DriveParams.paper(k, m),
    "as-published": lambda k, m: DriveParams.paper(k, m, variant="as-published"),
    "h_N and h_T x2": lambda k, m: scaled_h(DriveParams.paper(k, m), 2.0, 2.0),
    "cargo inertia (M + m)": lambda k, m: _inertia(DriveParams.paper(k, m)),
    "h_N x1.5": lambda k, m: scaled_h(DriveParams.paper(k, m), 1.5, 1.0),
}
#: The slider moves "in one direction" in a period when its velocity never drops below this (m/s).
ONE_WAY_TOLERANCE = -1e-6
#: A change of <V> smaller than this (m/s) cannot be seen on the paper's figures (1 % of the
#: 15 mm/s stroke speed is 0.15 mm/s): claims about rising and falling curves ignore it.
VISIBLE = 1e-4


def _v(model, k, m, numerics) -> tuple[float, str, float, str]:
    paper_v, paper_state, settled_v, settled_state, _ = fig5_case((model(k, m), numerics))
    return paper_v, paper_state, settled_v, settled_state


def _mm(v: float, state: str) -> str:
    return "runaway" if state == "runaway" else f"{v * 1e3:.2f}"


def period6_trace(params: DriveParams, numerics: str) -> np.ndarray:
    sim = DriveSimulator(params, numerics)
    sim.run(Waveform.paper(), 5)
    return sim.step(Waveform.paper(), record_every=1).trace


def claims_of(model, numerics: str) -> list[dict]:
    """Every claim for one model: dicts with figure, claim, holds (bool) and the deciding numbers."""
    out = []

    def claim(fig: str, text: str, holds: bool, evidence: str) -> None:
        out.append({"figure": fig, "claim": text, "holds": bool(holds), "evidence": evidence})

    # Fig. 3 (k = 0)
    crit = critical_load(model(0.0, 0.0), numerics=numerics, rule="paper", tolerance=2e-3, upper_guess=0.5)
    claim("3", "the drive moves the cargo up to a critical mass inside 0-1 kg (k = 0)",
          0.0 < crit.cargo_mass < 1.0, f"critical mass {crit.bracket[0]:.3f}-{crit.bracket[1]:.3f} kg")
    modes = []
    for m in FIG3_MASSES:
        tr = period6_trace(model(0.0, m), numerics)
        v_mean = (tr[-1, K.T_SLIDER_X] - tr[0, K.T_SLIDER_X]) / (tr[-1, K.T_TIME] - tr[0, K.T_TIME])
        modes.append((m, v_mean, tr[:, K.T_SLIDER_V].min()))
    one_way = [m for m, v, vmin in modes if v > 0 and vmin >= ONE_WAY_TOLERANCE]
    stick_slip = [m for m, v, vmin in modes if v > 0 and vmin < ONE_WAY_TOLERANCE]
    claim("3", "two modes with <V> > 0: one-way motion (upper curves) and stick-slip with V changing sign",
          bool(one_way) and bool(stick_slip),
          f"one-way at m = {', '.join(f'{m:g}' for m in one_way) or 'none'} kg; "
          f"sign-changing at m = {', '.join(f'{m:g}' for m in stick_slip) or 'none'} kg (6th period)")

    # Fig. 4 (m = 0.1 kg)
    v4 = {k: _v(model, k, 0.1, numerics) for k in FIG4_KS}
    claim("4", "k = 0, 0.2 and 0.3 all drag the 0.1 kg cargo forward",
          all(v[1] != "runaway" and v[0] > 0 for v in v4.values()),
          "<V> = " + ", ".join(f"{_mm(v[0], v[1])}" for v in v4.values()) + " mm/s (6th period; settled: "
          + ", ".join(_mm(v[2], v[3]) for v in v4.values()) + ")")
    vs = [v4[k][0] if v4[k][1] != "runaway" else -np.inf for k in FIG4_KS]
    claim("4", "efficiency (<V>) falls as k grows (0 -> 0.2 -> 0.3)", vs[0] > vs[1] > vs[2],
          "see the row above")
    fx = [np.abs(period6_trace(model(k, 0.1), numerics)[:, K.T_FX]).max() for k in FIG4_KS]
    claim("4", "the tangential force falls as k grows", fx[0] > fx[1] > fx[2],
          "peak |F_x| = " + ", ".join(f"{f:.2f}" for f in fx) + " N")

    # Fig. 5
    right = {(k, m): _v(model, k, m, numerics) for m in FIG5_MASSES for k in FIG5_KS}
    left = {(k, m): _v(model, k, m, numerics) for k in FIG5_LEFT_KS for m in FIG5_LEFT_MASSES}
    pairs = bad = 0
    worst = -np.inf
    for k in FIG5_LEFT_KS:
        for m0, m1 in zip(FIG5_LEFT_MASSES[:-1], FIG5_LEFT_MASSES[1:]):
            a, b = left[(k, m0)], left[(k, m1)]
            if a[1] == "runaway" or a[0] <= 0:  # only where the drive still moves at the lighter load
                continue
            pairs += 1
            rise = -np.inf if b[1] == "runaway" else b[0] - a[0]
            worst = max(worst, rise)
            bad += rise > VISIBLE
    claim("5", "<V> falls with the cargo mass m (left panel, where the drive moves)", bad == 0,
          f"{pairs - bad} of {pairs} steps in m lower <V> by more than -0.1 mm/s; largest change "
          f"{worst * 1e3:+.3f} mm/s")

    def curve(m):
        return np.array([right[(k, m)][0] if right[(k, m)][1] != "runaway" else -np.inf for k in FIG5_KS])

    drop = [m for m in FIG5_MASSES if curve(m)[-1] < curve(m)[0]]
    claim("5", "<V> falls with k (right panel: <V> at k = 0.9 below <V> at k = 0)", len(drop) == len(FIG5_MASSES),
          f"{len(drop)} of {len(FIG5_MASSES)} masses")
    best = [m for m in FIG5_MASSES if curve(m)[0] >= curve(m).max() - VISIBLE]
    others = [f"{m:g} kg (k = {FIG5_KS[int(np.argmax(curve(m)))]:g}: {curve(m).max() * 1e3:.2f} against "
              f"{curve(m)[0] * 1e3:.2f})" for m in FIG5_MASSES if m not in best]
    claim("5", "k = 0 is best (\"best to use homogeneous materials\"): the highest <V> at every mass",
          len(best) == len(FIG5_MASSES),
          f"k = 0 is best at {len(best)} of {len(FIG5_MASSES)} masses; not at " + ("; ".join(others[:3]) or "-")
          + (" ..." if len(others) > 3 else ""))
    crit_k = [critical_load(model(k, 0.0), numerics=numerics, rule="paper", tolerance=2e-3, upper_guess=0.25).cargo_mass
              for k in FIG5_LEFT_KS]
    claim("5", "k = 0 is best: the heaviest cargo it can move (critical mass largest at k = 0)",
          crit_k[0] >= max(crit_k), "critical mass " + ", ".join(f"{c:.3f}" for c in crit_k) + " kg at k = "
          + ", ".join(f"{k:g}" for k in FIG5_LEFT_KS))
    rises = []
    for m in FIG5_MASSES:
        c = curve(m)
        if np.isfinite(c).sum() < 3:
            continue
        fin = c[np.isfinite(c)]
        rise = np.max(np.diff(fin)) if fin.size > 1 else 0.0
        if rise > VISIBLE and fin[-1] < fin.max():  # rises visibly somewhere, and falls again
            rises.append((m, rise))
    claim("5", "<V> against k is not monotonic", bool(rises),
          "; ".join(f"m = {m:g} kg rises by {r * 1e3:.2f} mm/s" for m, r in rises[:4]) or "monotonic everywhere")
    unloaded = [right[(k, 0.0)] for k in FIG5_KS]
    claim("Concl.", "the drive moves (<V> > 0) for every k in [0, 1) without load",
          all(v[1] != "runaway" and v[0] > 0 for v in unloaded),
          f"smallest unloaded <V> {min(v[0] for v in unloaded) * 1e3:.2f} mm/s (6th period)")
    return out


def markdown(results: dict[str, list[dict]], numerics: str, wall: float) -> str:
    names = list(results)
    first = results[names[0]]
    lines = [f"Claims of the paper's text against model variants ({numerics} numerics; `<V>`: the paper's "
             "6th-period rule). Yes/no: whether the claim holds; the numbers decide it.", "",
             "| Fig. | claim | " + " | ".join(names) + " |", "|---|---|" + "---|" * len(names)]
    for i, c in enumerate(first):
        cells = [("**yes**" if results[n][i]["holds"] else "no") + ": " + results[n][i]["evidence"] for n in names]
        lines.append(f"| {c['figure']} | {c['claim']} | " + " | ".join(cells) + " |")
    lines += ["", "Claims held: " + ", ".join(f"{n} {sum(c['holds'] for c in results[n])}/{len(first)}"
                                              for n in names), "", f"wall time {wall:.0f} s"]
    return "\n".join(lines) + "\n"


def summary_table(results: dict[str, list[dict]]) -> str:
    """The yes/no grid of ``markdown`` without the numbers (docs/paper_reproduction.md quotes it)."""
    names = list(results)
    first = results[names[0]]
    lines = ["| Fig. | claim | " + " | ".join(names) + " |", "|---|---|" + "---|" * len(names)]
    for i, c in enumerate(first):
        lines.append(f"| {c['figure']} | {c['claim']} | "
                     + " | ".join("**yes**" if results[n][i]["holds"] else "no" for n in names) + " |")
    lines.append("| | claims held | " + " | ".join(f"{sum(c['holds'] for c in results[n])}/{len(first)}"
                                                 for n in names) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = Parser(prog="paper_claims.py", description=__doc__)
    ap.add_argument("--numerics", default="fast", choices=("fast", "default", "paper"), help="numerics preset")
    ap.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS), metavar="MODEL",
                    help=f"models to test, of: {', '.join(MODELS)} (default: all)")
    ap.add_argument("--h-normal-scales", nargs="*", type=float, default=[], metavar="S",
                    help="also test the model with h_N times each S (h_T as is) (-)")
    ap.add_argument("--out", default="results/paper_claims", type=output_dir, help="output folder")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    models = {name: MODELS[name] for name in a.models}
    for scale in a.h_normal_scales:
        models[f"h_N x{scale:g}"] = lambda k, m, scale=scale: scaled_h(DriveParams.paper(k, m), scale, 1.0)
    results = {name: claims_of(model, a.numerics) for name, model in tqdm(models.items(), desc="models", unit="model")}
    text = markdown(results, a.numerics, time.perf_counter() - t0)
    write_text(Path(a.out) / "claims.md", text)
    write_text(Path(a.out) / "claims_summary.md", summary_table(results))
    write_text(Path(a.out) / "claims.json", json.dumps({"numerics": a.numerics, "results": results}, indent=1))
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
