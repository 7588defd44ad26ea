"""The ``mdr-drive`` subcommands of the agents package, found by ``mdr-drive`` through the entry-point
group ``mdr_drive.commands`` (pyproject.toml): each module holds ``HELP``, ``DESCRIPTION``,
``add_arguments(parser)`` and ``main(args) -> exit code``."""
