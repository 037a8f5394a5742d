"""The policy loop: a controller run at its own rate, its frames handed to the lowcmd relay's one writer."""
