"""The pure core: modes, transitions, the state machine and the safety logic. No ROS, no DDS."""
