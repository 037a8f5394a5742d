"""MuJoCo side of the simulated G1: the model, the locomotion policy and the torque controllers."""
