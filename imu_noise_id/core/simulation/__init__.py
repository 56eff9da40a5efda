"""Simulated sensors with known errors, for the demo, the tests and the benchmarks: a static 6-axis IMU
(:mod:`.static`), a ground robot's IMU and wheel odometry (:mod:`.robot`) and AV bands of a fitted model
(:mod:`.bands`)."""
