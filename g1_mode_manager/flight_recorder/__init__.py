"""The flight recorder: the robot port's recording wrapper, the recorder's thread, incident files forked to MCAP."""
