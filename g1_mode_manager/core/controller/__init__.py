"""Controllers that run inside the node's own loop: they propose joint targets; the loop decides what leaves."""
