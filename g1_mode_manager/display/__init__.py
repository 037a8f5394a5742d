"""What the robot shows of the mode: ROS-free workers that signal it on the robot (head LED, spoken
announcements). Not relays: they forward no command stream and never touch the gate of the mode machine."""
