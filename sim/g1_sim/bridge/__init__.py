"""The simulated G1's Unitree SDK2 DDS face: RPC services, topics, faults on demand, pacing, ROS 2 node."""
