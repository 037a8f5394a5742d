"""Keyboard teleop for g1ctl drive: a key sets a velocity for a short hold time, like a real teleop's key repeat.

With no key pressed the tool stops publishing, so the node's watchdog stops the robot: the tool is a
dead-man switch, not a cruise control.
"""

from __future__ import annotations

import select
import sys
import termios
import time
import tty
from dataclasses import dataclass, field

#: A key's velocity lasts this long (s): longer than a terminal's initial key-repeat delay (~0.25-0.5 s),
#: so holding a key drives without gaps, and letting go stops publishing within this time.
HOLD_S = 0.6

HELP = f"""\
g1ctl drive: hold w/s forward/back, a/d left/right, q/e turn; space stop, x E-STOP, Ctrl-C quit.
A key drives for {HOLD_S} s (hold it to keep going); with no key the node's watchdog stops the robot."""

Command = tuple[float, float, float]


@dataclass
class DriveState:
    """The velocity of the last key and until when it holds (times from time.monotonic)."""

    speed: float = 0.3  # m/s
    turn_speed: float = 0.5  # rad/s
    hold_s: float = HOLD_S
    vx: float = 0.0
    vy: float = 0.0
    wz: float = 0.0
    _until: float = field(default=-1.0, repr=False)
    _zero_once: bool = field(default=False, repr=False)

    def apply(self, key: str, now: float) -> str | None:
        """Update from one key; returns 'estop' or 'quit' for those keys, else None."""
        moves = {"w": (self.speed, 0.0, 0.0), "s": (-self.speed, 0.0, 0.0), "a": (0.0, self.speed, 0.0),
                 "d": (0.0, -self.speed, 0.0), "q": (0.0, 0.0, self.turn_speed), "e": (0.0, 0.0, -self.turn_speed)}
        if key in moves:
            self.vx, self.vy, self.wz = moves[key]
            self._until = now + self.hold_s
        elif key in (" ", "x"):
            self.vx = self.vy = self.wz = 0.0
            self._until = -1.0
            self._zero_once = True
            return "estop" if key == "x" else None
        elif key == "\x03":
            return "quit"
        return None

    def command(self, now: float) -> Command | None:
        """What to publish now: the held velocity, a single zero after space, or None (publish nothing)."""
        if now < self._until:
            return (self.vx, self.vy, self.wz)
        self.vx = self.vy = self.wz = 0.0
        if self._zero_once:
            self._zero_once = False
            return (0.0, 0.0, 0.0)
        return None


def run_keyboard(client, rate_hz: float = 10.0) -> int:
    if not sys.stdin.isatty():
        print("g1ctl drive needs a terminal (stdin is not a TTY)", file=sys.stderr)
        return 2
    print(HELP, flush=True)
    state = DriveState()
    fd = sys.stdin.fileno()
    saved = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd)
        next_pub = time.monotonic()
        while True:
            ready, _, _ = select.select([sys.stdin], [], [], max(0.0, next_pub - time.monotonic()))
            if ready:
                action = state.apply(sys.stdin.read(1), time.monotonic())
                if action == "quit":
                    break
                if action == "estop":
                    client.drive(0.0)
                    result = client.estop()
                    print(f"\rE-STOP: success={result.success} {result.message}", flush=True)
            now = time.monotonic()
            if now >= next_pub:
                cmd = state.command(now)
                if cmd is not None:
                    client.drive(*cmd)
                print(f"\rvx {state.vx:+.2f}  vy {state.vy:+.2f}  wz {state.wz:+.2f}  "
                      f"{'driving' if cmd is not None else 'idle'}    ", end="", flush=True)
                next_pub = max(next_pub + 1.0 / rate_hz, now)
    finally:
        client.drive(0.0)
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)
        print()
    return 0
