"""Keyboard teleop for g1ctl drive: keys change a velocity that is published at a fixed rate."""

from __future__ import annotations

import select
import sys
import termios
import time
import tty
from dataclasses import dataclass

HELP = """\
g1ctl drive: w/s forward/back, a/d left/right, q/e turn, space stop, x E-STOP, Ctrl-C quit.
Each key adds one step; velocity is published on /cmd_vel at 10 Hz (the node clamps it further)."""


@dataclass
class DriveState:
    vx: float = 0.0
    vy: float = 0.0
    wz: float = 0.0

    def apply(self, key: str, step: float = 0.1, turn_step: float = 0.2) -> str | None:
        """Update from one key; returns 'estop' or 'quit' for those keys, else None."""
        moves = {"w": (step, 0, 0), "s": (-step, 0, 0), "a": (0, step, 0), "d": (0, -step, 0),
                 "q": (0, 0, turn_step), "e": (0, 0, -turn_step)}
        if key in moves:
            dx, dy, dw = moves[key]
            self.vx, self.vy, self.wz = round(self.vx + dx, 3), round(self.vy + dy, 3), round(self.wz + dw, 3)
        elif key == " ":
            self.vx = self.vy = self.wz = 0.0
        elif key == "x":
            self.vx = self.vy = self.wz = 0.0
            return "estop"
        elif key == "\x03":
            return "quit"
        return None


def run_keyboard(client, rate_hz: float = 10.0) -> int:
    if not sys.stdin.isatty():
        print("g1ctl drive needs a terminal (stdin is not a TTY)", file=sys.stderr)
        return 2
    print(HELP)
    state = DriveState()
    fd = sys.stdin.fileno()
    saved = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd)
        next_pub = time.monotonic()
        while True:
            ready, _, _ = select.select([sys.stdin], [], [], max(0.0, next_pub - time.monotonic()))
            if ready:
                action = state.apply(sys.stdin.read(1))
                if action == "quit":
                    break
                if action == "estop":
                    client.drive(0.0)
                    result = client.estop()
                    print(f"\rE-STOP: success={result.success} {result.message}")
                print(f"\rvx {state.vx:+.2f}  vy {state.vy:+.2f}  wz {state.wz:+.2f}    ", end="", flush=True)
            if time.monotonic() >= next_pub:
                client.drive(state.vx, state.vy, state.wz)
                next_pub += 1.0 / rate_hz
    finally:
        client.drive(0.0)
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)
        print()
    return 0
