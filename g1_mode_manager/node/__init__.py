"""The ROS 2 plumbing of the mode manager: parameters, services, topics, executors."""
