"""A MuJoCo G1 that speaks the robot's own Unitree SDK2 DDS protocol."""
