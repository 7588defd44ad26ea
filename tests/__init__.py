"""The test suite, laid out like the packages: ``core/`` and ``envs/`` test ``mdr_drive_env``,
``agents/`` tests ``mdr_drive_agents``; fixtures live in ``data/``."""

from pathlib import Path

#: The test fixtures (small configs, a golden run, cached reference runs).
DATA = Path(__file__).parent / "data"
#: The repository's root.
ROOT = Path(__file__).parents[1]
