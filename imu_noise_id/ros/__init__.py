"""The rclpy adapters (everything that imports rclpy or ROS message types): the node (:mod:`.node`), its table
layouts (:mod:`.messages`), ``imu-noise-id play`` (:mod:`.play`) and ``monitor`` (:mod:`.monitor`), and
launch-free helpers (:mod:`.launch`)."""
