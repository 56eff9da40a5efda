"""The rclpy adapters: the node, its messages, and launch-free helpers to run it (no ``launch`` package on PyPI)."""
