"""The student: a plain SB3 PPO network (``network``) fitted to a teacher on the teacher's episodes
(``data``) by DAgger (``distill``, its first round kept for resuming: ``checkpoint``), and the sensor
policy's estimator of what the sensor hides (``estimator``)."""
