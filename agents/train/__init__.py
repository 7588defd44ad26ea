"""Training programs: the told-load recipe (``recipe``: teacher, then student), the sensor
policy's (``sensor``), the friction-aware teacher's (``friction_teacher``), and plain
Stable-Baselines3 training from scratch (``sb3``, several seeds as one sweep: ``seeds``)."""
