"""Reading and writing ROS 1 / rosbag2 (sqlite3, mcap) bags with rosbags, no ROS install needed."""
