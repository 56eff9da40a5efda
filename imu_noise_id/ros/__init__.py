"""The rclpy adapters (everything that imports rclpy or ROS message types).

* :mod:`.node` — ``imu_noise_id_node`` around :class:`imu_noise_id.pipelines.online.OnlineIdentifier`;
* :mod:`.messages` — the labelled layouts of its ``Float64MultiArray`` outputs;
* :mod:`.play` — publishing a bag with its timing (``imu-noise-id play``);
* :mod:`.monitor` — the live view of a running node (``imu-noise-id monitor``);
* :mod:`.launch` — launch-free helpers to run the node (no ``launch`` package on PyPI).
"""
