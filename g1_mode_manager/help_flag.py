"""``-h`` / ``--help`` for the entry points that take only ROS arguments (mode_manager, console): a user's first
try must print how to run them, never start a node on whatever domain the shell has."""

from __future__ import annotations

import sys
from collections.abc import Sequence


def wants_help(args: Sequence[str] | None = None) -> bool:
    """``-h`` or ``--help`` among the arguments before ``--ros-args`` (after it, ROS owns them)."""
    argv = list(sys.argv[1:] if args is None else args)
    own = argv[:argv.index("--ros-args")] if "--ros-args" in argv else argv
    return "-h" in own or "--help" in own
