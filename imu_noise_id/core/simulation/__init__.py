"""Simulated sensors with known errors, for the demo, the tests and the benchmarks.

* :mod:`.static` — a static 6-axis IMU from per-axis component models;
* :mod:`.robot` — a ground robot's IMU and wheel odometry with a motion profile (weaving, or stop and go): truth
  for the CMKF, the node and the demo.
"""
