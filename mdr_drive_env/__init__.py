"""mdr-drive: MDR model of a stick-slip piezo micro-drive, and a Gymnasium environment over it."""

__version__ = "0.1.0"
