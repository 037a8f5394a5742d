"""The operator console: one web page and a WebSocket served by its own process and ROS 2 node (g1_console).

It reaches the mode manager only through the node's public ROS interfaces, as g1ctl does, so the mode manager
never depends on it and a crash of the console never touches the node. Pure parts (access, messages, the
dead-man, the driver lock, the robot view) are free of ROS and tested with a fake clock; ``bridge`` is the
ROS side, ``server`` the web side, ``main`` the process.
"""
