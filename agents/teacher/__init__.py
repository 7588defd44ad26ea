"""The teacher: the best open-loop drives found on a grid of (k, load), as a field one can query
anywhere (``DriveField``), its settings and stages (``FieldConfig``), and fields at several friction
ratios (``FrictionField``), a pick that holds over a band of load (``LoadBand``), and a table of
whole drives found at hidden draws, which the sensor policies pick from (``drive_table``)."""

from .config import PAPER_FRICTION, FieldConfig
from .field import DriveField
from .friction import FrictionField
from .load_band import LoadBand

__all__ = ["PAPER_FRICTION", "DriveField", "FieldConfig", "FrictionField", "LoadBand"]
