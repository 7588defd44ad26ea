"""The ``mdr-drive`` subcommands of the agents package, found by ``mdr-drive`` through the entry-point
group ``mdr_drive.commands`` (pyproject.toml): each module holds ``HELP``, ``DESCRIPTION``,
``add_arguments(parser)`` and ``main(args) -> exit code``."""


def add_recipe_arguments(p, default_config, config_help: str, default_out: str) -> None:
    """The arguments every recipe command takes: its YAML config (optional, ``default_config``), ``--out``
    (default ``default_out``), ``--force`` and ``--no-progress``."""
    from mdr_drive_env.cli_args import input_file, output_dir

    p.add_argument("config", nargs="?", default=str(default_config), type=input_file, help=config_help)
    p.add_argument("--out", default=default_out, type=output_dir, help="output folder")
    p.add_argument("--force", action="store_true", help="overwrite a non-empty --out")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
