"""Shared steps of the tests that interrupt a training command's student stage and resume it."""

from __future__ import annotations

from pathlib import Path

from mdr_drive_env.cli import main


def ctrl_c(*args, **kwargs):
    """Stands for the function a Ctrl-C interrupts."""
    raise KeyboardInterrupt


def interrupt_in_the_hole_round(argv: list[str], out: Path, monkeypatch, capsys) -> Path:
    """Run ``mdr-drive ARGV`` with Ctrl-C in its first hole round (after round 0), check that it
    exits with 130 in one line that says the first fit is kept, and that the checkpoint is written
    and no policy; return the checkpoint's path."""
    from mdr_drive_agents.student import distill

    with monkeypatch.context() as m:
        m.setattr(distill, "hole_round", ctrl_c)
        assert main(argv) == 130
    assert "first round, once labelled or fitted, are kept" in capsys.readouterr().err
    saved = out / ".tasks" / "student_round0.npz"
    assert saved.exists() and not (out / "policy").exists()
    return saved


def record_fits(monkeypatch) -> list[int]:
    """A list that each later ``distill.fit`` call appends its number of steps to."""
    from mdr_drive_agents.student import distill

    fits = []
    real_fit = distill.fit
    monkeypatch.setattr(distill, "fit", lambda *a, **k: fits.append(a[3]) or real_fit(*a, **k))
    return fits
