"""The robot's own record: every request and frame the sim received, and every change of its state.

One JSON object per line, written as it happens, with ``t`` = CLOCK_MONOTONIC (shared by every process
of the machine, so a test can compare it with the moment it sent something). Kinds:

* ``req``: an RPC request on arrival: ``svc``, ``api``, ``p`` (JSON parameter), ``noreply``, ``id`` (its
  header's identity id, as the client wrote it: Unitree's Python SDK writes its ``time.monotonic_ns()`` when it
  built the request). ``t`` is when the sim's Cyclone delivered it (see arrivals.py), so lines are not always in
  ``t`` order.
* ``done``: the same request handled (after any injected delay): ``svc``, ``api``, ``p``, ``code``.
* ``frame``: an rt/lowcmd, rt/user_lowcmd or rt/arm_sdk frame: ``topic``, ``n`` (its arrival number on the topic,
  counted from 1 since the sim started), ``ok``, ``why`` (ignore reason or null), ``w`` (arm_sdk blend weight),
  ``kp_max`` (largest stiffness commanded), ``crc`` (its crc field: "ok", "none" = left 0, "wrong"; rt/lowcmd and
  rt/user_lowcmd need "ok", rt/arm_sdk takes all three); ``t`` is when the sim's Cyclone delivered it, ``src`` when
  its writer wrote it (its DDS source timestamp: the writer's CLOCK_REALTIME taken as CLOCK_MONOTONIC, exact on one
  machine), ``ap`` when the sim had applied (or ignored) it, from which step on it acts, ``past`` how far its
  furthest position target lies outside its joint's range (rad, 0 within; null for a non-finite one). Every frame
  that reached the sim is on the record, in arrival order per topic (frame_reader.py), unless a ``drop`` says
  otherwise.
* ``drop``: ``count`` frames of ``topic`` from arrival number ``n`` on reached the sim and were never looked at (its
  handler fell behind by more than frame_reader.MAX_BACKLOG): from there on the record is not complete, and a
  reader of it must not judge frames by it (harness/sim_record.py raises).
* ``state``: the robot's controller state changed: ``fsm`` (the controller's, even in debug mode),
  ``svc`` (the motion switcher's service, '' = released), ``fsm_mode``. A state is on the record before
  any rt/sportmodestate frame or RPC reply shows it; fsm 1000 is user control, and its ``state`` line is
  written before the first rt/user_lowcmd frame it lets through.
* ``reset``: the sim was reset to its boot state (a sim-only status call).
* ``odom``: every rt/lf/odommodestate sample (20 Hz of sim time while a high-level service is active): ``st``
  (sim time, the sample's stamp), the estimate as published (float32, rounded to 1e-6): ``x``, ``y`` (m),
  ``yaw`` (rad, rpy[2]), ``vx``, ``vy`` (m/s, odometry frame), ``wz`` (rad/s, yaw_speed); and the truth:
  ``true_x``, ``true_y``, ``true_yaw`` (the pelvis in the world frame, which is the odometry frame at the
  start). ``t`` is when the sample was written, before it was published.

The sim thread's own lines (``body``, ``odom``, a ``state`` it finds) are written when their step is computed: while
nobody is on a 500 Hz stream the sim steps in batches (sim_loop.IDLE_BATCH_STEPS), so such a line may be written up
to 10 ms before the wall clock reaches its step (a reaction timed from it is overstated, not flattered); a starved
sim writes it late, as it always could.

This is what end-to-end and chaos tests judge by: the robot's side, never the node's belief.
"""

from __future__ import annotations

import json
import threading
import time
from typing import IO, Any, Protocol


class StatefulRobot(Protocol):
    @property
    def lock(self) -> threading.RLock: ...
    @property
    def fsm_id(self) -> int: ...
    def check_mode(self) -> tuple[str, str]: ...
    def sport_state(self) -> tuple[int, int]: ...


class Recorder:
    """Appends events to a JSONL file; without a path it records nothing (and costs nothing)."""

    def __init__(self, path: str | None) -> None:
        self._lock = threading.Lock()
        self._file: IO[str] | None = open(path, "a", buffering=1) if path else None  # noqa: SIM115 (closed in close())
        self._state: tuple[int, str, int] | None = None

    @property
    def enabled(self) -> bool:
        return self._file is not None

    def event(self, kind: str, at: float | None = None, **fields: Any) -> None:
        """Record one event at ``at`` (a CLOCK_MONOTONIC receive time taken earlier) or now."""
        if self._file is None:
            return
        line = json.dumps({"k": kind, "t": time.monotonic() if at is None else at, **fields}, separators=(",", ":"))
        with self._lock:
            if self._file is not None:
                self._file.write(line + "\n")

    def state(self, fsm: int, service: str, fsm_mode: int) -> None:
        """Record the robot's state if it differs from the last one recorded."""
        if self._file is None:
            return
        key = (int(fsm), service, int(fsm_mode))
        with self._lock:
            if key == self._state:
                return
            self._state = key
        self.event("state", fsm=key[0], svc=key[1], fsm_mode=key[2])

    def reset(self) -> None:
        """Record a ``reset`` and forget the last state, so the boot state after it is always recorded (a test
        reading only the events after the reset must see the state they start from)."""
        with self._lock:
            self._state = None
        self.event("reset")

    def close(self) -> None:
        with self._lock:
            if self._file is not None:
                self._file.close()
                self._file = None


def record_state(record: Recorder, robot: StatefulRobot) -> tuple[int, int]:
    """Record the robot's state and return rt/sportmodestate's (fsm_id, fsm_mode), both read in one hold of
    its lock. The frame, RPC and loop threads all record: a state read before another thread recorded a newer
    one must not be written after it, and a frame published with what this returns shows a state that is
    already on the record (a client answered on that frame finds it there)."""
    with robot.lock:
        sport = robot.sport_state()
        record.state(robot.fsm_id, robot.check_mode()[1], sport[1])
        return sport
