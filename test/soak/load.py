"""Play one lifetime's planned load against the node: two operators, one sending commands and one streaming, and a
third caller asking for ~/snapshot now and then, each in its own thread, every action at its planned instant (or at
once, if the one before ran late)."""

from __future__ import annotations

import threading
import time
from collections import Counter
from collections.abc import Callable
from typing import Any

from soak.schedule import Action, Lifetime

FAULT = 5  # Mode.FAULT
RATE_HZ = {"drive": 20.0, "arm": 50.0, "lowcmd": 100.0}
#: Faults the sim keeps while no link is lost (none: the soak judges the node, not a failing robot).
NO_FAULTS: dict[str, Any] = {}
#: ~/snapshot answers once its file is written, or after the node's own 10 s bound: room above that.
SNAPSHOT_TIMEOUT_S = 20.0


class Load:
    """The operators. ``outcomes`` counts each action's result, e.g. ``mode:ok``, ``loco:refused``, ``mode:timeout``."""

    def __init__(self, stack: Any, last_mode: Callable[[], int | None],
                 on_snapshot: Callable[[str], None] = lambda _path: None) -> None:
        self.stack = stack
        self._last_mode = last_mode
        self._on_snapshot = on_snapshot  # told each written snapshot's path, as ~/snapshot answers it
        self._pubs: dict[str, Any] = {}
        self.outcomes: Counter[str] = Counter()
        self._lock = threading.Lock()

    def publishers(self) -> None:
        """Made once per run: each publisher of the soak's client lives as long as the client (and a new node
        matches the same ones)."""
        from g1_mode_manager_msgs.msg import JointCommand
        from sensor_msgs.msg import JointState

        node = self.stack.ros.node
        self._pubs["drive"] = self.stack.cmd_vel_publisher()
        self._pubs["arm"] = node.create_publisher(JointState, self.stack.name("arm_cmd"), 10)
        self._pubs["lowcmd"] = node.create_publisher(JointCommand, self.stack.name("lowcmd"), 10)

    def start(self, plan: Lifetime, t0: float, stop: threading.Event) -> list[threading.Thread]:
        threads = [threading.Thread(target=self._operator, args=(actions, t0, stop), daemon=True, name=name)
                   for name, actions in (("commands", plan.commands), ("streams", plan.streams),
                                         ("snapshots", plan.snapshots))]
        for th in threads:
            th.start()
        return threads

    def _operator(self, actions: tuple[Action, ...], t0: float, stop: threading.Event) -> None:
        for a in actions:
            if stop.wait(max(0.0, t0 + a.at_s - time.monotonic())):
                return
            try:
                outcome = self._act(a, stop)
            except TimeoutError:
                outcome = "timeout"
            with self._lock:
                self.outcomes[f"{a.kind}:{outcome}"] += 1

    def _act(self, a: Action, stop: threading.Event) -> str:
        s = self.stack
        if a.kind == "mode":
            if self._last_mode() == FAULT:  # an operator clears a FAULT before asking for a mode
                s.clear_fault()
            return _ok(s.set_mode(a.arg, timeout_s=20.0).success)
        if a.kind == "loco":
            return _ok(s.loco(a.arg).success)
        if a.kind == "clear":
            return _ok(s.clear_fault().success)
        if a.kind == "snapshot":
            from std_srvs.srv import Trigger

            reply = s.ros.call(Trigger, s.name("snapshot"), Trigger.Request(), SNAPSHOT_TIMEOUT_S)
            if reply.success:
                self._on_snapshot(reply.message)
            return _ok(reply.success)
        if a.kind == "link_loss":
            s.set_faults({**NO_FAULTS, "pause_state": True})
            stop.wait(a.seconds)  # an e-stop meanwhile: the link comes back after it (the run clears the faults)
            s.set_faults(NO_FAULTS)
            return "ok"
        self._stream(a, stop)
        return "ok"

    def _stream(self, a: Action, stop: threading.Event) -> None:
        msg = _message(a)
        pub = self._pubs[a.kind]
        period = 1.0 / RATE_HZ[a.kind]
        end = time.monotonic() + a.seconds
        while time.monotonic() < end and not stop.is_set():
            pub.publish(msg)
            time.sleep(period)


def _ok(success: bool) -> str:
    return "ok" if success else "refused"


def _message(a: Action) -> Any:
    if a.kind == "drive":
        from geometry_msgs.msg import Twist

        msg = Twist()
        msg.linear.x, msg.linear.y, msg.angular.z = a.arg
        return msg
    if a.kind == "arm":
        from sensor_msgs.msg import JointState

        return JointState(name=["left_shoulder_roll_joint", "right_shoulder_roll_joint"], position=list(a.arg))
    from g1_mode_manager_msgs.msg import JointCommand

    return JointCommand(name=["left_elbow_joint"], q=[a.arg], dq=[0.0], tau=[0.0], kp=[40.0], kd=[2.0])
