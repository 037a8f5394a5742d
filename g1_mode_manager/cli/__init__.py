"""g1ctl: use the mode manager without a ROS install (pip installs have no `ros2` command)."""
