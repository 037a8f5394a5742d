"""The operators of a chaos scenario: each client in its own thread, its actions at their planned times.

Every request and stream is registered in an ``InFlight`` from just before it is sent until it is answered
or ends, so the scenario knows what was in flight when its e-stop went out. A node killed mid-scenario
leaves requests unanswered: every call has a timeout short enough for the scenario to go on.

Who drives: the hand-overs and take-overs are logged with when they were sent and answered, and the planner's
streams with their first and last message (drivers.DriveLog), for the judge.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from g1_mode_manager_msgs.srv import LocoCommand, SetMode
from std_srvs.srv import Trigger

from chaos import policy
from chaos.coverage import InFlight
from chaos.drivers import TELEOP_VX, Call, DriveLog
from chaos.plan import SETUP, STREAMS, Plan
from harness.rate import run_at_rate
from support.planner import RATE_HZ as PLANNER_RATE_HZ

#: The longest any operator call waits for its answer, s (a transition with injected delays takes < 10 s).
CALL_TIMEOUT_S = 15.0
_COLUMN_OF = {"mode": "mode call", "loco": "loco command", **dict.fromkeys(STREAMS, "stream")}
#: How long the setup asks again (every 0.5 s) for a mode it was refused, s: within the aim's deadline.
SETUP_RETRY_S = 7.0
#: ... and for a hand-over refused for want of the robot's odometry (not there yet just after HIGH_LEVEL), every
#: HAND_OVER_RETRY_PERIOD_S, s; other refusals (a hold, another mode) stand.
HAND_OVER_RETRY_S = 1.0
HAND_OVER_RETRY_PERIOD_S = 0.1
#: The services of who drives, by action.
_DRIVE_SERVICES = {"hand_over": "hand_over_to_autonomy", "take_over": "take_over"}
_STREAM_RATE_HZ = {"drive": 50.0, "arm": 50.0, "lowcmd": 100.0}


class Operators:
    """Runs a plan's actions against ``stack``; ``row_reached`` starts a stream column, ``send_column`` sends a
    request column."""

    def __init__(self, stack: Any, p: Plan, in_flight: InFlight, stop: threading.Event, drives: DriveLog) -> None:
        self._stack = stack
        self._plan = p
        self._in_flight = in_flight
        self._stop = stop
        self._drives = drives
        self._planner_off = threading.Event()  # the planner falls silent for the rest of the scenario
        self.row_reached = threading.Event()
        self.setup_done = threading.Event()  # the setup's last step is done
        self.node_back = threading.Event()  # the node was restarted (or never killed)
        #: the noise is over and the node the setup talks to is settled: the e-stop's thread replaced one the noise
        #: left in EMERGENCY (scenario_run), so the setup never sends to a node being stopped
        self.node_checked = threading.Event()
        self.mode_calls: list[float] = []  # when each mode request began (list.append is atomic)
        self.engage_calls: list[float] = []  # when each policy engage was sent
        if p.kill_at is None:
            self.node_back.set()

    def run(self, t0: float, fault_claimed: Any) -> None:
        """All clients until their actions are done (or ``stop``); ``fault_claimed()``: the node shows FAULT or
        holds (the setup first clears them)."""
        clients = sorted({who for _, who, _, _ in self._plan.actions} | {SETUP})
        threads = [threading.Thread(target=self._client, args=(k, t0, fault_claimed), daemon=True) for k in clients]
        threads.append(threading.Thread(target=self._column, daemon=True))
        for th in threads:
            th.start()
        for th in threads:
            th.join(60.0)

    def _client(self, k: int, t0: float, fault_claimed: Any) -> None:
        if k == SETUP and not self._settle(t0, fault_claimed):
            return
        for at, who, kind, arg in self._plan.actions:
            if who != k:
                continue
            if self._stop.wait(max(0.0, t0 + at - time.monotonic())):
                return
            reply = self.act(kind, arg)
            # a setup's mode request refused (the noise's transition still in progress, or a FAULT the noise
            # caused after the settling) is asked again, or the aimed row is never reached; not when the node is
            # in that mode already
            until = time.monotonic() + SETUP_RETRY_S
            while (k == SETUP and kind == "mode" and reply is not None and not reply.success
                   and reply.mode_name.lower() != arg):
                if time.monotonic() > until or self._stop.wait(0.5):
                    break
                if fault_claimed():
                    self._clear(fault_claimed)
                reply = self.act(kind, arg)
            # a setup's policy verb refused (a transition of the noise still in progress, a shadow without fresh
            # targets yet) is asked again likewise
            while (k == SETUP and kind == "policy" and arg in policy.RETRIED and reply is not None
                   and not reply.success and "already" not in reply.message):
                if time.monotonic() > until or self._stop.wait(0.5):
                    break
                if fault_claimed():
                    self._clear(fault_claimed)
                reply = self.act(kind, arg)
            if k == SETUP and kind == "policy" and arg in policy.RETRIED and reply is not None and not reply.success:
                # why the aim may miss its cell
                print(f"chaos seed {self._plan.seed}: the setup's policy {arg} refused: {reply.message}", flush=True)
            until = time.monotonic() + HAND_OVER_RETRY_S
            while (k == SETUP and kind == "hand_over" and reply is not None and reply.success is False
                   and "odometry" in reply.message):
                if time.monotonic() > until or self._stop.wait(HAND_OVER_RETRY_PERIOD_S):
                    break
                reply = self.act(kind, arg)
        if k == SETUP:
            self.setup_done.set()

    def _settle(self, t0: float, fault_claimed: Any) -> bool:
        """Before the setup: wait for the restarted node, then undo the noise's body faults and clear them."""
        if self._stop.wait(max(0.0, t0 + self._plan.setup_at - time.monotonic())):
            return False
        while not (self.node_back.wait(0.1) and self.node_checked.wait(0.1)):
            if self._stop.is_set():
                return False
        if fault_claimed():
            self._clear(fault_claimed)
        return True

    def _clear(self, fault_claimed: Any) -> None:
        """Undo the noise's body faults in the sim and call clear_fault until the node leaves FAULT (4 s)."""
        self._stack.set_faults(self._plan.faults)
        deadline = time.monotonic() + 4.0
        while fault_claimed() and time.monotonic() < deadline and not self._stop.wait(0.5):
            self.act("clear", "")

    def _column(self) -> None:
        if self._plan.column_action is None or self._plan.column_action[0] not in STREAMS:
            return  # a request column is sent by the aim itself (send_column)
        while not self.row_reached.wait(0.1):
            if self._stop.is_set():
                return
        self.act(*self._plan.column_action)

    def send_column(self) -> bool:
        """Send the column's request (a mode call or a loco command) without waiting for its answer; False for
        a stream column (run by its own thread once ``row_reached``) or none.

        The node refuses a loco command outside HIGH_LEVEL within a few ms: a thread that sent it and another
        that saw it sent would rarely get an e-stop out before the answer. Sent from the aim's own thread, the
        e-stop follows the request at once, and the landing still observes whether it was answered by then.
        """
        action = self._plan.column_action
        if action is None or action[0] not in ("mode", "loco"):
            return False
        kind, arg = action
        stack = self._stack
        if kind == "mode":
            self.mode_calls.append(time.monotonic())
            srv, name, request = SetMode, stack.name("set_mode"), SetMode.Request(mode_name=arg)
        else:
            srv, name, request = LocoCommand, stack.name("loco_command"), LocoCommand.Request(command=arg)
        client = stack.ros.client(srv, name)
        if not client.wait_for_service(timeout_sec=5.0):
            return True  # a killed node's successor not up yet: the landing shows nothing in flight
        column = _COLUMN_OF[kind]
        self._in_flight.begin(column)
        client.call_async(request).add_done_callback(lambda _f: self._in_flight.end(column))
        return True

    def send_race(self, kind: str) -> None:
        """A hand-over or a take-over sent without waiting for its answer: the e-stop follows at once."""
        self._drive_call(kind, wait=False)

    def act(self, kind: str, arg: Any) -> Any:
        """Do one action; a mode request's or a policy verb's reply or a hand-over's or take-over's Call (None if
        unanswered), else None."""
        column = _COLUMN_OF.get(kind)
        if kind == "mode":
            self.mode_calls.append(time.monotonic())
        if (kind, arg) == ("policy", "engage"):
            self.engage_calls.append(time.monotonic())
        if column is not None:
            self._in_flight.begin(column)
        try:
            return self._act(kind, arg)
        except (TimeoutError, RuntimeError):  # a killed node leaves calls unanswered
            return None
        finally:
            if column is not None:
                self._in_flight.end(column)

    def _act(self, kind: str, arg: Any) -> Any:
        stack, ros = self._stack, self._stack.ros
        if kind == "mode":
            return ros.call(SetMode, stack.name("set_mode"), SetMode.Request(mode_name=arg), CALL_TIMEOUT_S, 5.0)
        elif kind == "loco":
            ros.call(LocoCommand, stack.name("loco_command"), LocoCommand.Request(command=arg), CALL_TIMEOUT_S, 5.0)
        elif kind == "body":
            stack.set_faults({**self._plan.faults, **arg["set"]})
            if arg["lasts"] is not None and not self._stop.wait(arg["lasts"]):
                stack.set_faults(self._plan.faults)
        elif kind == "policy":
            return policy.call(stack, arg, CALL_TIMEOUT_S)
        elif kind == "clear":
            ros.call(Trigger, stack.name("clear_fault"), Trigger.Request(), CALL_TIMEOUT_S, 5.0)
        elif kind in _DRIVE_SERVICES:
            return self._drive_call(kind, wait=True)
        elif kind == "planner":
            self._planner(float(arg))
        elif kind == "planner_off":
            self._planner_off.set()
        elif kind in STREAMS:
            _stream(stack, kind, float(arg or 0.5), self._stop)
        elif kind == "pause":  # the setup waits in the row it reached before its next step
            self._stop.wait(float(arg))
        return None


    def _drive_call(self, kind: str, *, wait: bool) -> Call | None:
        """Call ``~/hand_over_to_autonomy`` or ``~/take_over`` and log it; its Call, or None if the node was not
        there to send it to (killed)."""
        client = self._stack.ros.client(Trigger, self._stack.name(_DRIVE_SERVICES[kind]))
        if not client.wait_for_service(timeout_sec=5.0):
            return None
        call = Call(time.monotonic())
        (self._drives.hand_overs if kind == "hand_over" else self._drives.take_overs).append(call)
        done = threading.Event()

        def answered(future: Any) -> None:
            if future.exception() is None:
                call.success, call.message = future.result().success, future.result().message
                call.answered = time.monotonic()
            done.set()

        client.call_async(Trigger.Request()).add_done_callback(answered)
        if wait:
            done.wait(CALL_TIMEOUT_S)
        return call

    def _planner(self, seconds: float) -> None:
        """Publish the planner's command on the autonomy's topic at Nav2's rate for ``seconds`` (or until it falls
        silent, or the scenario stops), logging the stream's first and last message."""
        from geometry_msgs.msg import Twist

        msg = Twist()
        msg.linear.x, msg.linear.y, msg.angular.z = self._plan.planner_command
        pub = _publisher(self._stack, Twist, f"{self._stack.ns}/cmd_vel_nav")
        end = time.monotonic() + seconds
        span: list[float] = []

        def publish() -> bool:
            if time.monotonic() >= end or self._planner_off.is_set():
                return False
            pub.publish(msg)
            if not span:
                span.extend((time.monotonic(), time.monotonic()))
                self._drives.planner_streams.append(span)
            span[1] = time.monotonic()
            return True

        run_at_rate(PLANNER_RATE_HZ, publish, self._stop)


_PUBLISHERS: dict[tuple[int, str], Any] = {}


def _publisher(stack: Any, msg_type: Any, topic: str) -> Any:
    """The test's publisher on ``topic``, made once (a publisher destroyed while the client spins may kill it)."""
    key = (id(stack.ros.node), topic)
    if key not in _PUBLISHERS:
        _PUBLISHERS[key] = stack.ros.node.create_publisher(msg_type, topic, 10)
    return _PUBLISHERS[key]


def _stream(stack: Any, kind: str, seconds: float, stop: threading.Event) -> None:
    """Publish on /cmd_vel, ``~/arm_cmd`` or ``~/lowcmd`` for ``seconds`` (or until ``stop``)."""
    topic, msg = _message(stack, kind)
    pub = _publisher(stack, type(msg), topic)
    end = time.monotonic() + seconds
    period = 1.0 / _STREAM_RATE_HZ[kind]
    while time.monotonic() < end and not stop.is_set():
        pub.publish(msg)
        time.sleep(period)


def _message(stack: Any, kind: str) -> tuple[str, Any]:
    if kind == "drive":
        from geometry_msgs.msg import Twist

        msg = Twist()
        msg.linear.x = TELEOP_VX
        return f"{stack.ns}/cmd_vel", msg
    if kind == "arm":
        from sensor_msgs.msg import JointState

        return stack.name("arm_cmd"), JointState(name=["left_shoulder_roll_joint", "right_shoulder_roll_joint"],
                                                 position=[0.6, -0.6])
    from g1_mode_manager_msgs.msg import JointCommand

    return stack.name("lowcmd"), JointCommand(name=["left_elbow_joint"], q=[1.0], dq=[0.0], tau=[0.0], kp=[40.0],
                                              kd=[2.0])
