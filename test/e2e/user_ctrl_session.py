"""What the user-control e2e files share: a user's controller, the way into user control, and the sim's record
read as they read it.

A user's controller here is a stiff hold of the measured pose at 500 Hz on ~/lowcmd (the sim's own tests show
such a hold keeps the 29-dof G1 standing); its gains differ from the node's hand-over frame, so the record tells
the user's frames (kp_max USER_KP) from the node's (kp_max HOLD_KP).
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Sequence

from g1_mode_manager_msgs.msg import JointCommand
from sensor_msgs.msg import JointState

from e2e.conftest import Stack
from g1_mode_manager.core.user_ctrl import UserCtrlConfig
from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol.fsm import USER_CTRL_FSM_ID
from g1_mode_manager.protocol.motors import JOINT_NAMES
from harness.rate import run_at_rate
from support.mode_manager import wait_until
from support.sim_record import of_kind, requests
from support.timing import BODY_SAMPLE_S, CONTROLLER_STALL_S, RECORD_WAIT_S

USER_KP, USER_KD = 250.0, 6.0
HOLD_KP = UserCtrlConfig().hold_kp
STANDING_Z_M = 0.6
USER_CTRL = "low_level_path:=user_ctrl"
#: For the tests that are not about silence: the test's controller, a thread of the pytest process, may stall on a
#: loaded machine longer than the default lowcmd_timeout_s, and the node would then rightly hand the robot back.
STEADY = f"lowcmd_timeout_s:={CONTROLLER_STALL_S}"
#: At rest for a pose to be held: every |dq| below a tenth of the node's own rest speed (UserCtrlConfig's 0.5 rad/s),
#: on every body sample of 0.2 s of sim time. The walk-run controller gets there ~1.3 s after its StopMove; its
#: balance keeps |dq| near 0.015 rad/s from then on.
AT_REST_RAD_S = 0.05
AT_REST_SAMPLES = round(0.2 / BODY_SAMPLE_S)
#: How far a robot must walk to show it walks: far beyond a standing robot's balance sway (centimetres).
WALKS_M = 0.5


class HoldController:
    """A user's controller: every joint held at the pose measured when it starts, published at ``rate_hz``."""

    def __init__(self, stack, rate_hz: float = 500.0) -> None:
        node = stack.ros.node
        self._pub = node.create_publisher(JointCommand, stack.name("lowcmd"), 10)
        self._latest: dict[str, float] = {}
        node.create_subscription(JointState, "/joint_states", self._on_joint_states, 10)
        assert wait_until(lambda: self._pub.get_subscription_count() > 0 and len(self._latest) == 29, 15.0)
        self._rate_hz = rate_hz
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.sent = 0

    def _on_joint_states(self, msg: JointState) -> None:
        self._latest = dict(zip(msg.name, msg.position, strict=False))

    def start(self) -> None:
        pose = [float(self._latest[n]) for n in JOINT_NAMES]
        msg = JointCommand(name=list(JOINT_NAMES), q=pose, dq=[0.0] * 29, tau=[0.0] * 29, kp=[USER_KP] * 29,
                           kd=[USER_KD] * 29)
        self._thread = threading.Thread(target=self._run, args=(msg,), daemon=True)
        self._thread.start()

    def _run(self, msg: JointCommand) -> None:
        def publish() -> bool:
            try:
                self._pub.publish(msg)
            except Exception:  # the test's client closed under a controller left running: it is dead
                return False
            self.sent += 1
            return True

        run_at_rate(self._rate_hz, publish, self._stop)

    def stop(self) -> float:
        """Stop publishing (a killed controller); returns when."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)
        return time.monotonic()


def wait_sim(stack, seconds: float) -> None:
    end = stack.sim.get()["sim_time"] + seconds
    assert wait_until(lambda: stack.sim.get()["sim_time"] >= end, seconds * 20 + 10, period_s=0.1)


def fsm_states(ev) -> list[tuple[int, int]]:
    """(index in the record, fsm) of each state line."""
    return [(i, e["fsm"]) for i, e in enumerate(ev) if e["k"] == "state"]


def frames_on(ev, topic: str) -> list[tuple[int, dict]]:
    return [(i, e) for i, e in enumerate(ev) if e["k"] == "frame" and e["topic"] == topic]


def internal_ctrl(ev) -> list[int]:
    return [json.loads(e["p"])["data"] for e in requests(ev, api.LOCO_SWITCH_TO_INTERNAL_CTRL)]


def lowest_pelvis(ev, since: float = float("-inf")) -> float:
    return min(e["z"] for e in of_kind(ev, "body") if e["t"] >= since)


def wait_at_rest(stack) -> None:
    """Until the record's body samples show the robot at rest (AT_REST_RAD_S on AT_REST_SAMPLES samples in a row)."""
    since = time.monotonic()
    body: list[dict] = []

    def at_rest() -> bool:
        body[:] = of_kind(stack.record.events(since), "body")[-AT_REST_SAMPLES:]
        return len(body) == AT_REST_SAMPLES and all(e["dq"] <= AT_REST_RAD_S for e in body)

    assert wait_until(at_rest, RECORD_WAIT_S, period_s=0.05), f"never at rest: {body[-1:]}"


def enter_walking(stack, *, rest: bool = True) -> None:
    """HIGH_LEVEL, the robot walked for 1 s of sim time; with ``rest``, then stopped and come to rest."""
    assert stack.set_mode("high_level").success
    assert stack.loco("start").success
    stack.drive_sim_time(0.4, 1.0)  # walking: past the walk's ramp (0.3 s), the robot steps (|dq| > 2 rad/s)
    if rest:
        # the watchdog's StopMove, then the walk-run controller comes to rest (fsm stays 500): a stiff hold of a
        # pose taken mid-step falls over, whoever holds it; waited for on the record rather than for a fixed 2.5 s
        wait_at_rest(stack)


def enter_user_ctrl(stack, controller: HoldController) -> float:
    controller.start()  # the controller runs first; its frames pass only once LOW_LEVEL is entered
    t0 = time.monotonic()
    r = stack.set_mode("low_level")
    print(f"set_mode low_level: {r.message} ({(time.monotonic() - t0) * 1000:.0f} ms)")
    assert r.success and "[low_level_path: user_ctrl]" in r.message, r.message
    return t0


def damped_on_the_record(stack, since: float) -> list[dict]:
    """The damping frames on rt/user_lowcmd since ``since``, once the record shows one and the robot's Damp (the
    sim's frame handler may lag its reader on a loaded machine: waited for on the record, not for a fixed time)."""

    def damping() -> list[dict]:
        return [e for _, e in frames_on(stack.record.events(), "user_lowcmd") if e["t"] >= since and e["kp_max"] == 0.0]

    assert wait_until(lambda: bool(damping()), RECORD_WAIT_S), "no damping frame on rt/user_lowcmd after the e-stop"
    assert wait_until(lambda: fsm_states(stack.record.events())[-1][1] == 1, RECORD_WAIT_S), "the record never showed Damp"
    return damping()


def no_user_frame_before_1000(ev, user_kp: float = USER_KP) -> None:
    """No user frame let through before fsm 1000 (by the record's order: a frame is judged when the sim handles it,
    and the state line comes before the first frame it lets through), and the hand-over frame arrived at the robot
    before the switch (by arrival time: a frame handler lagging on a loaded machine writes a frame that arrived
    before the switch after the state line)."""
    states = fsm_states(ev)
    first_1000 = next(i for i, fsm in states if fsm == USER_CTRL_FSM_ID)
    user = [(i, e) for i, e in frames_on(ev, "user_lowcmd") if abs(e["kp_max"] - user_kp) < 1e-3]
    assert user, "no user frame reached the robot"
    early = [e for i, e in user if i < first_1000]
    assert not early, f"{len(early)} user frames before fsm 1000 was on the record"
    switched = ev[first_1000]["t"]
    hand_over = [e for _, e in frames_on(ev, "user_lowcmd") if e["t"] < switched]
    assert hand_over and all(e["kp_max"] == HOLD_KP for e in hand_over), "no hand-over frame before the switch"


def held_in_user_ctrl(shared_stack_factory, *, faults: dict | None = None,
                      node_params: Sequence[str] = ()) -> tuple[Stack, HoldController]:
    """A node on the user_ctrl path, the robot walked, then in user control held by the test's controller for a
    second of sim time (``faults`` and ``node_params``: the sim's and the node's, on top of the path's)."""
    stack = shared_stack_factory(faults=faults, node_params=(USER_CTRL, STEADY, *node_params))
    stack.modes()  # every ~/mode from here on
    controller = HoldController(stack)
    enter_walking(stack)
    enter_user_ctrl(stack, controller)
    wait_sim(stack, 1.0)
    return stack, controller
