"""Safe control-mode manager for the Unitree G1."""
