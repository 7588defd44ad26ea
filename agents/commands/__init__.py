"""The ``mdr-drive`` subcommands of the agents package, found by ``mdr-drive`` through the entry-point
group ``mdr_drive.commands`` (pyproject.toml): each module holds ``HELP``, ``DESCRIPTION``,
``add_arguments(parser)`` and ``main(args) -> exit code``."""


def add_recipe_arguments(p, default_config, config_help: str, default_out: str) -> None:
    """The arguments every recipe command takes: its YAML config (optional, ``default_config``), ``--out``
    (default ``default_out``), ``--force`` and ``--no-progress``."""
    from mdr_drive_env.cli_args import output_dir

    p.add_argument("config", nargs="?", default=str(default_config), type=package_file, help=config_help)
    p.add_argument("--out", default=default_out, type=output_dir, help="output folder")
    p.add_argument("--force", action="store_true", help="overwrite a non-empty --out")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")


def package_file(text: str) -> str:
    """argparse type: an existing file; ``agents/...`` names the package's own (its configs and example
    drives, ``policy.package_path``) from any working directory."""
    from mdr_drive_env.cli_args import input_file

    from ..policy import package_path

    return input_file(str(package_path(text)))


def drive_file(text: str):
    """argparse type: a drive description YAML (``mdr_drive_agents.drive.DriveDescription``; the
    package's example drives as ``agents/configs/drives/NAME.yaml`` from any working directory), with a
    one-line error for a missing file, an unknown key or a bad value."""
    import argparse

    from ..drive import DriveDescription

    path = package_file(text)
    try:
        return DriveDescription.load(path)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def add_drive_argument(p, what: str) -> None:
    """``--drive FILE``: the drive description ``what`` is done on (default: the paper's drive)."""
    p.add_argument("--drive", type=drive_file, default=None, metavar="FILE",
                   help=f"a drive description YAML (MDRDrive-v0 keywords in SI units: slider_mass kg, indenter_radius m, "
                        f"youngs_modulus Pa, poisson_ratio, friction_coefficient, base_friction_coefficient, period s, "
                        f"x_amplitude_max m, z_amplitude_max m; optionally k and load_ratio ranges; docs/your_drive.md) "
                        f"{what}; default the paper's drive")


def add_sensor_tier_argument(p, what: str) -> None:
    """``--sensor-tier``: the sensor tier ``what`` drives with, instead of the config's."""
    from mdr_drive_env.gym_envs.sensor import SENSOR_TIERS

    p.add_argument("--sensor-tier", choices=SENSOR_TIERS, default=None,
                   help=f"the sensor tier {what} drives with (default: the config's sensor_tier): encoder "
                        "(per-period summaries), trace (positions through each period), self-sensing (and the "
                        "piezo-sensed forces); docs/adaptation.md")


def replot(out, stem: str, markdown, plot) -> None:
    """``--replot``: ``OUT/<stem>.md`` and the plots (``plot(res)``) redrawn from ``OUT/<stem>.json``;
    nothing is recomputed."""
    import json
    from pathlib import Path

    from mdr_drive_env.files import write_text

    path = Path(out) / f"{stem}.json"
    if not path.is_file():
        raise ValueError(f"--replot needs {path}")
    res = json.loads(path.read_text())
    write_text(Path(out) / f"{stem}.md", markdown(res))
    plot(res)
