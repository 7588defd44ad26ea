"""The mdr-drive CLI: JSON output, help with units, errors, and a quick paper reproduction."""

import json
import subprocess
import sys

import pytest

from mdr_drive_env.cli import build_parser, main


def test_simulate_json_has_per_period_velocities_and_params(capsys):
    assert main(["simulate", "--k", "0.2", "--cargo-mass", "0.1", "--periods", "3", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    v = out["period_mean_velocity"]
    assert len(v) == 3 and all(isinstance(x, float) for x in v)
    assert v == [p["displacement"] / 2e-3 for p in out["periods"]]
    assert out["params"]["slider"]["grading_exponent"] == 0.2
    assert out["params"]["drive"]["cargo_mass"] == 0.1
    assert out["load_force"] == pytest.approx(0.981)


def test_simulate_matches_library_and_writes_plot(tmp_path, capsys):
    from mdr_drive_env.core import DriveParams, DriveSimulator, Waveform

    png = tmp_path / "run.png"
    assert main(["simulate", "--k", "0.3", "--cargo-mass", "0.05", "--periods", "2", "--json", "--plot", str(png)]) == 0
    out = json.loads(capsys.readouterr().out)
    ref = DriveSimulator(DriveParams.paper(k=0.3, cargo_mass=0.05), "default").run(Waveform.paper(), 2)
    assert out["period_mean_velocity"] == [r.mean_velocity for r in ref]
    assert png.stat().st_size > 10_000


def test_bad_value_is_a_clean_error(capsys):
    assert main(["simulate", "--poisson-ratio", "0.7"]) == 2
    assert "Material.poisson_ratio=0.7" in capsys.readouterr().err


def test_help_names_units_for_every_physical_option():
    sub = build_parser()._subparsers._group_actions[0].choices["simulate"]
    units = ("(m)", "(s)", "(kg)", "(Pa)", "(N)", "(-)", "(m/s^2)")
    for action in sub._actions:
        if action.option_strings and action.dest not in ("help", "json", "plot", "numerics", "rigid_indenter",
                                                         "cargo_inertia"):
            assert any(u in (action.help or "") for u in units), action.dest


def test_console_script_help_runs():
    out = subprocess.run([sys.executable, "-m", "mdr_drive_env.cli", "simulate", "--help"], capture_output=True,
                         text=True, check=True).stdout
    assert "--cargo-mass" in out and "(kg)" in out


@pytest.mark.parametrize("command", ["train", "evaluate", "benchmark", "demo"])
def test_agents_modules_run_as_scripts(command):
    """``python -m agents.<command>`` is ``mdr-drive <command>`` (it used to import and do nothing)."""
    pytest.importorskip("stable_baselines3")
    out = subprocess.run([sys.executable, "-m", f"agents.{command}", "--help"], capture_output=True,
                         text=True, check=True).stdout
    assert out.startswith(f"usage: mdr-drive {command}")


def test_quick_reproduction_writes_figures_and_csvs(tmp_path):
    from mdr_drive_env.reproduce import reproduce

    reproduce(tmp_path, numerics="default", periods=2, workers=1, quick=True)
    for name in ("fig3", "fig4", "fig5", "sensitivity"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000
        assert (tmp_path / f"{name}.csv").read_text().count("\n") > 2
