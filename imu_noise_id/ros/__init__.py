"""The rclpy adapters (everything that imports rclpy or ROS message types): :mod:`.node`, :mod:`.messages`,
:mod:`.play`, :mod:`.monitor`, :mod:`.launch`."""
