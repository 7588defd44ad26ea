"""The mdr-drive CLI: JSON output, help with units, errors, and a quick paper reproduction."""

import json
import os
import re
import subprocess
import sys

import numpy as np
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

    png = tmp_path / "new" / "run.png"  # the folder is created
    assert main(["simulate", "--k", "0.3", "--cargo-mass", "0.05", "--periods", "2", "--json", "--plot", str(png),
                 "--numerics", "default"]) == 0
    out = json.loads(capsys.readouterr().out)
    ref = DriveSimulator(DriveParams.paper(k=0.3, cargo_mass=0.05), "default").run(Waveform.paper(), 2)
    assert out["period_mean_velocity"] == [r.mean_velocity for r in ref]
    assert png.stat().st_size > 10_000


def test_numerics_fast_is_the_fast_solver_bit_for_bit_with_the_env_and_the_api(capsys):
    """One preset name, one solver: CLI, env (trapezoid action) and Python API agree exactly."""
    import gymnasium as gym

    import mdr_drive_env  # noqa: F401
    from mdr_drive_env.core import NUMERICS_PRESETS, DriveParams, DriveSimulator, Waveform

    assert main(["simulate", "--numerics", "fast", "--k", "0.25", "--cargo-mass", "0.07", "--periods", "5",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["numerics"]["method"] == "nodes" and out["numerics_preset"] == "fast"
    api = [r.mean_velocity for r in DriveSimulator(DriveParams.paper(k=0.25, cargo_mass=0.07)).run(Waveform.paper(), 5)]
    env = gym.make("MDRDrive-v0", k=0.25, cargo_mass=0.07)
    env.reset(seed=0)
    trap = env.unwrapped.trapezoid_action()
    via_env = [env.step(trap)[4]["mean_velocity"] for _ in range(5)]
    assert out["period_mean_velocity"] == api == via_env
    assert env.unwrapped.numerics == NUMERICS_PRESETS["fast"] == DriveSimulator(DriveParams.paper()).numerics
    assert build_parser().parse_args(["simulate"]).numerics == "fast"  # the default everywhere but reproduce
    assert build_parser().parse_args(["reproduce"]).numerics == "paper"


@pytest.mark.parametrize("preset", ["fast", "default", "paper"])
def test_every_preset_name_gives_that_preset(preset):
    from mdr_drive_env.cli import numerics_from_args
    from mdr_drive_env.core import NUMERICS_PRESETS

    args = build_parser().parse_args(["simulate", "--numerics", preset])
    assert numerics_from_args(args) == NUMERICS_PRESETS[preset]
    args = build_parser().parse_args(["simulate", "--numerics", preset, "--dt", "2e-6"])
    changed = numerics_from_args(args)
    assert changed.time_step == 2e-6 and changed.method == NUMERICS_PRESETS[preset].method


def test_dx_with_the_node_solver_is_an_error_that_says_so(capsys):
    assert main(["simulate", "--numerics", "fast", "--dx", "1e-8"]) == 2
    err = capsys.readouterr().err
    assert "--dx" in err and "node solver" in err and len(err.strip().splitlines()) == 1
    assert main(["simulate", "--numerics", "default", "--dx", "2e-7", "--periods", "1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["numerics"]["spring_spacing"] == 2e-7


@pytest.mark.parametrize("argv,needle", [
    (["simulate", "--k", "1.5"], "--k: Material.grading_exponent=1.5"),
    (["simulate", "--poisson-ratio", "0.7"], "--poisson-ratio: Material.poisson_ratio=0.7"),
    (["simulate", "--mu", "-0.1"], "--mu: Contact.friction_coefficient=-0.1"),
    (["simulate", "--load-force", "-1"], "--load-force: Drive.load_force=-1.0"),
    (["simulate", "--load-force", "1", "--cargo-mass", "0.1"], "--load-force and --cargo-mass"),
    (["simulate", "--x-fall-time", "0"], "--x-fall-time: AxisWaveform.fall_time=0.0"),
    (["simulate", "--z-amplitude=-1e-6"], "--z-amplitude: AxisWaveform.amplitude=-1e-06"),
    (["simulate", "--dt", "-1"], "--dt: Numerics.time_step=-1.0"),
    (["simulate", "--periods", "0"], "argument --periods: 0 is outside the allowed range"),
    (["simulate", "--periods", "2000000"], "argument --periods: 2000000 is outside the allowed range"),
    (["simulate", "--k", "abc"], "argument --k: invalid float value"),
    (["simulate", "--variant", "other"], "argument --variant: invalid choice"),
    (["reproduce", "--workers", "0"], "argument --workers"),
])
def test_bad_values_are_one_line_errors_naming_the_option(argv, needle, capsys):
    try:
        code = main(argv)
    except SystemExit as e:  # argparse's own checks
        code = e.code
    err = capsys.readouterr().err
    assert code == 2 and needle in err, err
    assert len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize("argv", [
    ["simulate", "--plot", "{file}/run.png"],
    ["simulate", "--plot", "{tmp}/run.txt"],
    ["simulate", "--plot", "{tmp}"],
    ["reproduce", "--out", "{file}"],
    ["bench", "--out", "{file}/sub"],
    ["evaluate", "--policy", "{tmp}/missing", "--k", "0.1", "--cargo-mass", "0.1"],
    ["evaluate", "--policy", "{tmp}", "--k", "0.1", "--cargo-mass", "0.1"],
    ["demo", "--out", "{file}"],
    ["train", "--config", "{tmp}/missing.yaml"],
    ["train", "--warm-start", "cma:{tmp}/missing.npz"],  # no longer a choice: one line too
    ["train", "--resume", "{tmp}"],
    ["train", "--out", "{file}"],
    ["benchmark", "--policies", "{tmp}/missing"],
])
def test_bad_paths_fail_at_once_in_one_line_without_a_traceback(argv, tmp_path):
    """Checked when the command line is read, before any work: exit 2, one line naming the option."""
    if argv[0] in ("evaluate", "demo", "train", "benchmark"):
        pytest.importorskip("stable_baselines3")
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    argv = [x.format(tmp=tmp_path, file=a_file) for x in argv]
    proc = subprocess.run([sys.executable, "-m", "mdr_drive_env.cli", *argv], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert lines[0].startswith(f"mdr-drive {argv[0]}: error: argument {argv[1]}"), lines[0]


def test_numpy_scalars_are_accepted_wherever_a_float_is():
    import gymnasium as gym

    import mdr_drive_env  # noqa: F401
    from mdr_drive_env.core import AxisWaveform, DriveParams, DriveSimulator, Numerics, Waveform

    p = DriveParams.paper(k=np.float32(0.2), cargo_mass=np.float64(0.1))
    assert type(p.k) is float and type(p.drive.cargo_mass) is float
    wf = Waveform(x=AxisWaveform(np.float32(30e-6), np.float64(1.9e-3), 1e-4), z_phase=np.float32(0.0))
    num = Numerics(time_step=np.float64(5e-6), method="nodes", nodes=np.int64(48), max_x_step=3e-7, max_z_step=1e-7,
                   node_power=1.5)
    assert type(num.nodes) is int
    assert DriveSimulator(p, num).run(wf, 1)[0].mean_velocity > 0
    env = gym.make("MDRDrive-v0", k=np.float32(0.2), cargo_mass=np.float64(0.1), friction_coefficient=np.float32(0.3))
    env.reset(seed=0)


def test_run_needs_at_least_one_period():
    from mdr_drive_env.core import DriveParams, DriveSimulator, Waveform

    sim = DriveSimulator(DriveParams.paper())
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ValueError, match="n_periods"):
            sim.run(Waveform.paper(), bad)


def test_ctrl_c_keeps_the_periods_computed_so_far(capsys, monkeypatch):
    from mdr_drive_env.core import DriveSimulator

    real_step, calls = DriveSimulator.step, []

    def step(self, *a, **kw):
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt
        return real_step(self, *a, **kw)

    monkeypatch.setattr(DriveSimulator, "step", step)
    assert main(["simulate", "--periods", "100", "--json"]) == 130
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert out["interrupted"] and out["periods_run"] == 3 and len(out["period_mean_velocity"]) == 3
    assert "interrupted after 3 of 100 periods" in captured.err and len(captured.err.strip().splitlines()) == 1


def _all_subparsers():
    return build_parser()._subparsers._group_actions[0].choices


def test_help_states_each_default_once_and_the_real_one():
    for name, sub in _all_subparsers().items():
        text = re.sub(r"\n {20,}", " ", sub.format_help())  # join wrapped help lines
        assert "(default: None)" not in text and "(default: False)" not in text, name
        for block in re.split(r"\n  -", text):  # one block per option
            assert block.count("default:") + block.count("default from") <= 1, (name, block)
    sim = " ".join(_all_subparsers()["simulate"].format_help().split())
    assert "(default: fast)" in sim and "(default: 6)" in sim and "(default: as-specified)" in sim
    assert "in [0, 1) (-) (default: 0.0)" in sim  # a default of 0.0 is a real default, not a switch's False


UNITS = ("(m)", "(s)", "(kg)", "(Pa)", "(N)", "(-)", "(m/s^2)")


def test_help_names_units_for_every_numeric_option():
    for name, sub in _all_subparsers().items():
        for action in sub._actions:
            numeric = action.type in (int, float) or getattr(action.type, "__name__", "") in ("integer", "number")
            if action.option_strings and numeric:
                assert any(u in (action.help or "") for u in UNITS), (name, action.dest, action.help)


def test_console_script_help_runs():
    out = subprocess.run([sys.executable, "-m", "mdr_drive_env.cli", "simulate", "--help"], capture_output=True,
                         text=True, check=True).stdout
    assert "--cargo-mass" in out and "(kg)" in out


AGENT_COMMANDS = ("train", "recipe", "train-sensor", "friction-teacher", "evaluate", "benchmark", "dense",
                  "adaptation", "identifiability", "model-card", "demo", "rl-baselines")


def test_the_agents_package_adds_its_subcommands_through_the_entry_point_group():
    pytest.importorskip("stable_baselines3")
    from mdr_drive_env.cli import COMMAND_GROUP, plugin_commands

    assert {ep.name for ep in plugin_commands()} == set(AGENT_COMMANDS)
    assert all(ep.group == COMMAND_GROUP and ep.value.startswith("mdr_drive_agents.commands.")
               for ep in plugin_commands())
    for command in AGENT_COMMANDS:  # each with its own --help
        text = _all_subparsers()[command].format_help()
        assert text.startswith(f"usage: mdr-drive {command}") and len(text.splitlines()) > 5


def test_the_physics_package_runs_without_the_agents_package(tmp_path):
    """With ``mdr_drive_agents`` not importable, ``mdr-drive`` still simulates, and an agents command
    says in one line what to install."""
    code = ("import sys; sys.modules['mdr_drive_agents'] = None; from mdr_drive_env.cli import main; "
            "print(main(['simulate', '--periods', '1', '--json']) == 0); sys.exit(main(['recipe']))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 2 and run.stdout.strip().splitlines()[-1] == "True"
    assert run.stderr.strip().startswith("mdr-drive recipe needs the train extra") and len(run.stderr.splitlines()) == 1


def test_the_install_adds_no_top_level_agents_module(tmp_path):
    """agents/ installs as mdr_drive_agents: a top-level ``agents`` would clash with openai-agents and TF-Agents."""
    code = "import importlib.util as u; print(u.find_spec('agents') is None, u.find_spec('mdr_drive_agents') is not None)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path).stdout
    assert out.split() == ["True", "True"]


def test_quick_reproduction_writes_figures_and_csvs_with_states(tmp_path):
    import csv

    from mdr_drive_env.reproduce import reproduce

    summary = reproduce(tmp_path, numerics="fast", periods=2, workers=1, quick=True, variant="as-published")
    assert summary["variant"] == "as-published" and summary["numerics"] == "fast"
    for name in ("fig3", "fig4", "fig5", "sensitivity"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000
        assert (tmp_path / f"{name}.csv").read_text().count("\n") > 2
    rows = list(csv.DictReader(open(tmp_path / "fig5.csv")))
    states = {r["settled_state"] for r in rows} | {r["paper_rule_state"] for r in rows}
    assert states <= {"settled", "settling", "runaway"} and "runaway" in states
    for r in rows:  # a runaway has no velocity in the CSV; everything else has one
        for rule in ("paper_rule", "settled"):
            assert (r[f"{rule}_velocity_m_s"] == "") == (r[f"{rule}_state"] == "runaway"), r
    heavy = [r for r in rows if float(r["k"]) == 0.6 and float(r["cargo_mass_kg"]) >= 0.5]
    assert heavy and all(r["settled_state"] == "runaway" for r in heavy)  # 4.9 N against 0.15 N of push


def test_reproduce_cli_names_its_variant(tmp_path, capsys):
    assert main(["reproduce", "--numerics", "fast", "--quick", "--periods", "2", "--workers", "1",
                 "--variant", "as-published", "--out", str(tmp_path)]) == 0
    assert json.loads((tmp_path / "summary.json").read_text())["variant"] == "as-published"


def test_run_command_turns_bad_values_and_ctrl_c_into_one_line_each(capsys):
    from mdr_drive_env.cli_args import run_command

    def bad():
        raise ValueError("k=2 is outside the allowed range [0, 1]")

    def interrupted():
        raise KeyboardInterrupt

    assert run_command("prog", lambda: None, "kept") == 0
    assert run_command("prog", bad, "kept") == 2
    assert capsys.readouterr().err == "prog: error: k=2 is outside the allowed range [0, 1]\n"
    assert run_command("prog", interrupted, "finished parts are kept") == 130
    assert capsys.readouterr().err == "prog: interrupted; finished parts are kept\n"


def test_simulate_streams_its_periods_and_refuses_a_trace_it_could_not_hold(capsys, tmp_path):
    assert main(["simulate", "--periods", "5", "--json", "--k", "0.1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["periods"]) == out["periods_run"] == 5 and "trace" not in out["periods"][0]
    assert main(["simulate", "--periods", "3", "--record-every", "1"]) == 2  # a trace without a plot keeps nothing
    assert "--record-every sets the plot's trace" in capsys.readouterr().err
    argv = ["simulate", "--periods", "10000", "--record-every", "1", "--numerics", "paper", "--plot",
            str(tmp_path / "p.png")]
    assert main(argv) == 2  # refused before any work: 10,000 periods of 20,000 steps
    err = capsys.readouterr().err
    assert "trace rows" in err and len(err.strip().splitlines()) == 1 and not (tmp_path / "p.png").exists()


def test_a_plot_that_cannot_be_written_names_itself_not_a_temporary_file(tmp_path, capsys):
    target = tmp_path / "ro" / "run.png"
    target.parent.mkdir()
    target.parent.chmod(0o500)
    if os.access(target.parent, os.W_OK):  # root writes anywhere: a path under a file instead
        target = tmp_path / "file" / "run.png"
        (tmp_path / "file").write_text("a file")
    try:
        code = main(["simulate", "--periods", "1", "--plot", str(target)])
    except SystemExit as e:  # argparse's own check catches the path under a file
        code = e.code
    err = capsys.readouterr().err
    assert code == 2 and str(target.parent) in err and ".run.png." not in err and len(err.strip().splitlines()) == 1


def test_a_reader_that_goes_away_is_no_error():
    """``mdr-drive ... --json | head``: the command ends quietly when the pipe closes."""
    r = subprocess.run(f"{sys.executable} -m mdr_drive_env.cli simulate --periods 200 --json | head -c 20",
                       shell=True, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and len(r.stdout) == 20 and "error" not in r.stderr and "Traceback" not in r.stderr
