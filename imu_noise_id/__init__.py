"""imu_noise_id: identify an IMU's stochastic errors offline (bags) and online (ROS 2 node).

Layers (imports point downwards only):

* :mod:`imu_noise_id.core` — the pure numerical core (numpy/scipy only): components, units, Allan-family
  variances, state-space models, Kalman filtering, estimators, diagnostics, simulation.
* :mod:`imu_noise_id.pipelines` — offline and online pipelines that chain core pieces.
* adapters — :mod:`imu_noise_id.bag` (rosbags I/O), :mod:`imu_noise_id.cli`, :mod:`imu_noise_id.report`,
  :mod:`imu_noise_id.ros` (rclpy: the node, play, monitor).
"""

__version__ = "0.1.0"
