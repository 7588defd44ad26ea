"""The teacher: the best open-loop drives found on a grid of (k, load), as a field one can query
anywhere (``DriveField``), its settings and stages (``FieldConfig``), and fields at several friction
ratios (``FrictionField``)."""

from .config import PAPER_FRICTION, FieldConfig
from .field import DriveField
from .friction import FrictionField

__all__ = ["PAPER_FRICTION", "DriveField", "FieldConfig", "FrictionField"]
