"""The constants more than one area uses, each defined once.

Physical: standard gravity. Vehicle: the DelFly II's motor-to-flapping gear ratio (docs/background.md section 1);
a rig file may name another (``[motor] gear_ratio``), which every run records and processing uses.
"""

STANDARD_GRAVITY_M_S2 = 9.80665
"""Standard acceleration of gravity (3rd CGPM, 1901), m/s^2: gravity in the models and 1 kgf, 1 gram-force."""
DELFLY_GEAR_RATIO = 21.33
"""DelFly II motor revolutions per flap: flapping frequency = motor rpm / 60 / 21.33 (the study)."""
TAIL_POSITION_RANGE_MM = (20.0, 300.0)
"""Tail positions x_h accepted anywhere (mm): the study flew 57-126 mm; beyond this range the vehicle model and
the trends mean nothing."""
