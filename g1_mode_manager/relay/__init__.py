"""Command relays: ROS-free workers that forward command streams to the robot port when the mode allows."""
