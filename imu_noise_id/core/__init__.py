"""The pure numerical core: numpy/scipy only, no ROS, no files, no plotting."""
