"""Every entry point the README names prints its usage for --help and starts nothing."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

BIN = Path(sys.executable).parent


@pytest.mark.parametrize(("program", "says"), [("mode_manager", "mode_manager [--ros-args"),
                                               ("console", "console --ros-args"), ("g1ctl", "usage: g1ctl"),
                                               ("g1_demo", "usage: g1_demo"), ("sim_bridge", "usage: sim_bridge")])
def test_help_prints_usage_and_starts_nothing(program, says):
    done = subprocess.run([str(BIN / program), "--help"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert says in done.stdout
    assert "[INFO]" not in done.stdout + done.stderr, "a node started"  # every node logs its start at INFO
