"""The student: a plain SB3 PPO network (``network``) fitted to a teacher on the teacher's episodes
(``data``) by DAgger (``distill``, its first round kept for resuming: ``checkpoint``); the sensor
policy's network, which predicts what each drive of a table is worth (``drive_values``), and the
estimator of what the sensor hides (``estimator``)."""
