"""The body checks judged by the robot: each condition made true in the sim (a heated motor, a frozen state
stream, a spinning joint, the gantry let go, a key held on the remote) and the robot's reaction read from the
sim's record, with its latency. A walking robot pushed over is judged in test_recorder.py, on the walk and push
whose incident that file reads.

LOW_LEVEL runs with a controller streaming the standing pose at 500 Hz, the robot hung in the sim's
gantry as people hang a G1 for low-level work. "Damping frames" are rt/lowcmd frames with no stiffness
(kp 0) on the record; the condition's time is the sim's own (its `body` events every 10 ms of sim time,
or the injection's).
"""

from __future__ import annotations

import threading
import time
from collections import Counter, deque
from pathlib import Path
from typing import Any

import pytest
from g1_mode_manager_msgs.msg import JointCommand
from g1_mode_manager_msgs.msg import Mode as ModeMsg
from sensor_msgs.msg import JointState

from g1_mode_manager.core.body.checks import BY_NAME as CHECKS
from g1_mode_manager.node.settings import Settings
from g1_mode_manager.protocol.motors import JOINT_NAMES
from g1_sim.physics.model import DEFAULT_POSE
from harness.rate import run_at_rate
from support.incidents import ROBOT_CALLS, answered, json_of, messages, metadata, wait_for_incident
from support.mode_manager import wait_until
from support.sim_record import damped, is_damp, of_kind, requests, states
from support.timing import (
    BODY_SAMPLE_S,
    CONTROLLER_STALL_S,
    INCIDENT_AFTER_S,
    INCIDENT_WRITE_S,
    LOW_LEVEL_REACTION_S,
    RECORD_WAIT_S,
    REMOTE_REACTION_S,
    check_latency,
)

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

LEGS_KP, ARMS_KP, KD = 80.0, 40.0, 2.0
#: The test's controller (a thread of the pytest process) may stall on a loaded machine: the node's silence damping
#: would then interleave with the reaction's damping frames, which look the same on the record.
STEADY = f"lowcmd_timeout_s:={CONTROLLER_STALL_S}"


def _stand_command(pose: list[float] | None = None, **changes: tuple[float, float]) -> JointCommand:
    """``pose`` (default: the standing pose) for all 29 joints, held with the standing gains; ``changes``: joint ->
    (q, kp)."""
    q = [float(v) for v in (DEFAULT_POSE if pose is None else pose)]
    kp = [LEGS_KP if i < 15 else ARMS_KP for i in range(len(JOINT_NAMES))]
    for name, (target, stiffness) in changes.items():
        i = JOINT_NAMES.index(name)
        q[i], kp[i] = target, stiffness
    n = len(JOINT_NAMES)
    return JointCommand(name=list(JOINT_NAMES), q=q, dq=[0.0] * n, tau=[0.0] * n, kp=kp, kd=[KD] * n)


class Controller:
    """A user's joint controller: ``~/lowcmd`` at 500 Hz from a thread of its own."""

    def __init__(self, stack, rate_hz: float = 500.0) -> None:
        self._pub = stack.ros.node.create_publisher(JointCommand, stack.name("lowcmd"), 10)
        assert wait_until(lambda: self._pub.get_subscription_count() > 0, 10.0)
        self.msg = _stand_command()
        self._rate_hz = rate_hz
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        run_at_rate(self._rate_hz, lambda: self._pub.publish(self.msg), self._stop)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5.0)


def _low_level_with_controller(stack, controller: Controller, command: JointCommand | None = None) -> float:
    """LOW_LEVEL entered, the controller's frames (``command``, default: hold the joints where they are) reaching
    the robot; returns when they did. Where they are, not the standing pose: after a phase's damping the limbs hang
    on the gantry, and a stiff step back to the standing pose can spin a joint past the joint-speed limit."""
    controller.msg = command or _stand_command(_measured_pose(stack))
    reply = stack.set_mode("low_level")
    assert reply.success, reply.message
    t = time.monotonic()
    assert wait_until(lambda: len(_user_frames(stack, t)) > 50, 5.0), \
        ("the controller's frames never reached the robot", [(m.name, list(m.faults)) for m in stack.modes()[-2:]])
    return time.monotonic()


def _measured_pose(stack) -> list[float]:
    """The 29 joint positions in motor order, from the sim's next /joint_states message (its own measurement)."""
    if not hasattr(stack, "sim_joint_states"):
        # one subscription per stack, kept: destroying an entity while the client's executor waits on it kills that
        # executor, and every one kept is another 50 Hz callback until the client closes
        newest: deque[JointState] = deque(maxlen=1)
        stack.sim_joint_states = newest
        stack.ros.node.create_subscription(JointState, "/joint_states", lambda msg: newest.append(msg), 10)
    got = stack.sim_joint_states
    got.clear()
    assert wait_until(lambda: bool(got), 10.0), "no /joint_states from the sim"
    latest = got[-1]
    by_name = dict(zip(latest.name, latest.position, strict=True))
    return [float(by_name[name]) for name in JOINT_NAMES]


def _user_frames(stack, since: float) -> list[dict]:
    """The controller's frames the robot received (and applied) since ``since``."""
    return [e for e in stack.record.events(since) if e["k"] == "frame" and e["topic"] == "lowcmd" and e["kp_max"] > 0
            and e["ok"]]


def _user_frames_after_damping(stack, since: float) -> list[dict]:
    """The controller's frames the robot applied after the first damping frame it handled since ``since``. Judged
    by the record's order (arrival order per topic): a user frame the relay wrote before its damping frame can
    still reach the robot after the stop began, but not after that frame."""
    frames = [e for e in stack.record.events(since) if e["k"] == "frame" and e["topic"] == "lowcmd"]
    first = next((i for i, e in enumerate(frames) if e["kp_max"] == 0), len(frames))
    return [e for e in frames[first:] if e["kp_max"] > 0 and e["ok"]]


def _first_damping_frame(stack, since: float) -> float:
    """When the first damping frame since ``since`` reached the robot (waits for it). Received, not
    necessarily applied: a frame that arrives just before the e-stop path's SelectMode is judged by the sim
    after it (another thread) and counted "not_debug_mode"; the robot is then the service's to damp."""

    def frames() -> list[dict]:
        return [e for e in stack.record.events(since) if e["k"] == "frame" and e["topic"] == "lowcmd"
                and e["kp_max"] == 0]

    assert wait_until(lambda: bool(frames()), RECORD_WAIT_S), "no damping frame reached the robot"
    return frames()[0]["t"]


def _first_body(stack, since: float, field: str, above: float, timeout_s: float = RECORD_WAIT_S) -> float:
    """When the sim's body first showed ``field`` above ``above`` (waits for it)."""
    return _first_body_past(stack, since, {field: above}, timeout_s)


#: The record's body fields a falling robot shows first, and the node's LOW_LEVEL FAULT limits on them.
FALL_SIGNS = {"tilt": CHECKS["tilt"].threshold, "gyro": CHECKS["spin"].threshold,
              "dq": CHECKS["joint_speed"].threshold}


def _first_body_past(stack, since: float, limits: dict[str, float], timeout_s: float = RECORD_WAIT_S) -> float:
    """When the sim's body first showed any of ``limits``' fields above its limit (waits for it). For a fall,
    FALL_SIGNS: which one comes first depends on the pose the robot falls from."""

    def found() -> list[dict]:
        return [e for e in of_kind(stack.record.events(since), "body")
                if any(e[field] > limit for field, limit in limits.items())]

    assert wait_until(lambda: bool(found()), timeout_s), f"the sim never showed any of {limits}"
    return found()[0]["t"]


def _injected(stack, what: str, since: float) -> float:
    found = [e for e in of_kind(stack.record.events(since), "inject") if e["what"] == what and e["on"]]
    assert found, f"no {what} injection on the record"
    return found[0]["t"]


def _fault_seen(stack, *checks: str) -> ModeMsg:
    """The newest ~/mode FAULT with the robot seen damped; one of ``checks`` among its faults."""
    assert wait_until(lambda: stack.modes()[-1].mode == ModeMsg.FAULT and stack.modes()[-1].damp_confirmed, 10.0), \
        [(m.name, list(m.faults)) for m in stack.modes()[-3:]]
    fault = stack.modes()[-1]
    assert any(f.split(":")[0] in checks for f in fault.faults), list(fault.faults)
    return fault


def _damped_on_the_robot(stack, since: float) -> None:
    assert wait_until(lambda: any(damped(s) for s in states(stack.record.events(since))), 10.0)
    sport = stack.sim.get()["sport"]
    assert sport["fsm_id"] == 1 and sport["mode"] == "ai", sport


def _clear_to_idle(stack) -> None:
    stack.set_faults({})
    assert wait_until(lambda: stack.clear_fault().success, 10.0)
    assert stack.modes() and wait_until(lambda: stack.modes()[-1].mode == ModeMsg.IDLE, 5.0)


def _body_before(stack, t: float) -> float:
    """The record's last body sample before ``t``. The sim writes a sample before it publishes the frames of the
    steps after it (sim_loop), so every frame that showed a condition the record first shows at ``t`` left the sim
    after this sample, however long the sim's thread was preempted in between."""
    return max(e["t"] for e in of_kind(stack.record.events(t - 1.0), "body") if e["t"] < t)


def _damping_reaction(stack, name: str, t_condition: float, goal_s: float, since: float | None = None) -> float:
    """The first damping frame the robot received since its condition (``since``; by default less one body
    sample: the node reads rt/lowstate between the record's samples); its latency printed, and held to ``goal_s``
    when the run has the machine to itself. Then no user frame may reach the robot. Returns the frame's time."""
    since = t_condition - BODY_SAMPLE_S if since is None else since
    t_damping = _first_damping_frame(stack, since)
    check_latency(name, t_condition, t_damping, goal_s)
    late = _user_frames_after_damping(stack, since)
    assert late == [], f"{name}: a user frame reached the robot after the damping began: {late[:3]}"
    return t_damping


def test_low_level_checks_damp_a_streaming_controller(shared_stack_factory) -> None:
    stack = shared_stack_factory(node_params=("fault_clear_hold_s:=0.5", STEADY), bridge_args=("--gantry",))
    stack.modes()
    controller = Controller(stack)
    try:
        # a motor overheats: injected, so the condition's time is exact
        t0 = _low_level_with_controller(stack, controller)
        stack.set_faults({"motor_temperature": {"3": [70, 130]}})
        t_hot = _injected(stack, "motor_temperature", t0)
        _damping_reaction(stack, "winding overheat in LOW_LEVEL: damping frames", t_hot, LOW_LEVEL_REACTION_S)
        _fault_seen(stack, "winding_overheat", "winding_critical")
        _damped_on_the_robot(stack, t0)
        refused = stack.clear_fault()
        assert not refused.success and "still active" in refused.message, refused.message
        _clear_to_idle(stack)
        assert damped(states(stack.record.events(t0))[-1]), "clear_fault moved the robot"

        # the state stream freezes: the condition is 1 s without rt/lowstate
        t0 = _low_level_with_controller(stack, controller)
        stack.set_faults({"freeze_lowstate": True})
        t_frozen = _injected(stack, "freeze_lowstate", t0)
        # the node damps once the link looks lost (before the check's 1 s), and the FAULT's SelectMode may end
        # the damping frames before that second is over: the reaction is the first damping frame since the freeze
        _damping_reaction(stack, "state frozen in LOW_LEVEL: damping frames", t_frozen, 1.0 + LOW_LEVEL_REACTION_S)
        _fault_seen(stack, "state_lost")
        _damped_on_the_robot(stack, t0)
        _clear_to_idle(stack)

        # a joint spins: the controller steps a wrist far and hard
        t0 = _low_level_with_controller(stack, controller)
        controller.msg = _stand_command(_measured_pose(stack), left_wrist_roll_joint=(1.5, 500.0))
        t_fast = _first_body(stack, t0, "dq", 10.0)
        # measured by the sim, not injected: the frames that first showed it may precede the record's first sample
        # of it by more than a sample period on a starved sim, never the sample before
        _damping_reaction(stack, "joint speed in LOW_LEVEL: damping frames", t_fast, LOW_LEVEL_REACTION_S,
                          since=_body_before(stack, t_fast))
        _fault_seen(stack, "joint_speed", "spin")
        _damped_on_the_robot(stack, t0)
        _clear_to_idle(stack)

        # the gantry lets go: the robot, held stiff by its controller where the last phase's damping left it,
        # topples over
        t0 = _low_level_with_controller(stack, controller)
        stack.set_gantry(False)
        assert wait_until(lambda: any(m.mode == ModeMsg.FAULT for m in stack.modes()), 10.0)
        t_fall = _first_body_past(stack, t0, FALL_SIGNS)
        _damping_reaction(stack, "a fall in LOW_LEVEL: damping frames", t_fall, LOW_LEVEL_REACTION_S,
                          since=_body_before(stack, t_fall))
        _fault_seen(stack, "tilt", "spin", "joint_speed")
        _damped_on_the_robot(stack, t0)

        # an e-stop still overrides FAULT
        reply = stack.estop()
        assert reply.success, reply.message
        assert wait_until(lambda: stack.modes()[-1].mode == ModeMsg.EMERGENCY, 5.0)
    finally:
        controller.stop()


@pytest.mark.parametrize("mode", ["idle", "high_level", "low_level"])
def test_the_remote_combination_stops_the_robot(shared_stack_factory, tmp_path: Path, mode: str) -> None:
    """In LOW_LEVEL the stop's incident is read too (_the_remote_stops_incident): the one mode whose frames the
    node forwards, the others' steps being those of any e-stop."""
    incidents = tmp_path / "incidents"
    recorder = (f"recorder_dir:={incidents}", f"recorder_after_s:={INCIDENT_AFTER_S}") if mode == "low_level" else ()
    stack = shared_stack_factory(node_params=(STEADY, *recorder),
                                 bridge_args=("--gantry",) if mode == "low_level" else ())
    stack.modes()
    controller = Controller(stack) if mode == "low_level" else None
    try:
        if controller is not None:
            t_entry = time.monotonic()
            t0 = _low_level_with_controller(stack, controller)
            # the recorder keeps a frame per topic every 1 / recorder_frame_rate_hz: three such periods of the
            # controller's frames on the robot before the stop leave more than one of them in its incident
            period_s = 1.0 / Settings.recorder_frame_rate_hz

            def streamed_s() -> float:
                frames = _user_frames(stack, t_entry)
                return frames[-1]["t"] - frames[0]["t"] if frames else 0.0

            assert wait_until(lambda: streamed_s() >= 3 * period_s, RECORD_WAIT_S), "the controller's frames stopped"
        else:
            assert stack.set_mode(mode).success
            t0 = time.monotonic()
        stack.set_faults({"remote_keys": ["L2", "B"]})
        t_keys = _injected(stack, "remote_keys", t0)
        assert wait_until(lambda: any(m.mode == ModeMsg.EMERGENCY and m.damp_confirmed for m in stack.modes()), 10.0)
        node_damps = [e for e in requests(stack.record.events(t_keys)) if is_damp(e)]
        assert node_damps, "the node sent no Damp"
        if controller is not None:  # nothing else on the robot listens to the remote in LOW_LEVEL
            _damping_reaction(stack, "remote L2+B in LOW_LEVEL: damping frames", t_keys, REMOTE_REACTION_S)
        print(f"remote L2+B in {mode}: the node's first Damp {1000 * (node_damps[0]['t'] - t_keys):.1f} ms after")
        _damped_on_the_robot(stack, t0)
    finally:
        if controller is not None:
            controller.stop()
    if controller is not None:
        _the_remote_stops_incident(incidents, controller.msg)


def _the_remote_stops_incident(folder: Path, command: JointCommand) -> None:
    """L2+B in LOW_LEVEL, read from its incident file: the controller's frames as the node forwarded them on
    rt/lowcmd (kept at the recorder's frame rate), then the remote's e-stop (its DampNoReply first), EMERGENCY,
    the Damp and its answer with the robot's latency; after EMERGENCY no frame with stiffness (a damping frame
    of the stop may follow)."""
    path = wait_for_incident(folder, "emergency", INCIDENT_AFTER_S + INCIDENT_WRITE_S)
    info = metadata(path)
    assert info["cause"] == "EMERGENCY from LOW_LEVEL" and info["mode"] == "EMERGENCY", info
    got = messages(path)
    note = next((m for m, n in json_of(got, "/recorder/notes")
                 if n["level"] == "error" and n["text"].startswith("E-STOP from the robot's remote")), None)
    assert note is not None, json_of(got, "/recorder/notes")
    calls = json_of(got, ROBOT_CALLS)
    shot = [m for m, c in calls if c["verb"] == "DampNoReply" and c["phase"] == "no_reply" and c["code"] == 0
            and m.order < note.order]
    assert shot, "no DampNoReply in front of the remote's e-stop"
    emergency = next(m for m, s in json_of(got, "/recorder/status") if s["mode"] == "EMERGENCY")
    assert shot[-1].t <= note.t <= emergency.t and shot[-1].order < note.order < emergency.order

    frames = [m for m in got if m.topic in ("/recorder/frames/lowcmd", "/recorder/frames/user_lowcmd")]

    def the_controllers(frame: Any) -> bool:  # a JointCommand as mcap_ros2 decodes it
        return (list(frame.name) == list(command.name) and list(frame.kp) == list(command.kp)
                and list(frame.kd) == list(command.kd) and list(frame.q) == list(command.q))

    # up to EMERGENCY: the gate closes there, so a frame written between the remote's note and it is the user's too
    users = [m for m in frames if m.topic == "/recorder/frames/lowcmd" and m.order < emergency.order
             and the_controllers(m.data)]
    assert len(users) >= 2, f"the controller's frames before the stop: {[(m.topic, max(m.data.kp)) for m in frames]}"
    stiff = [(m.topic, m.t - emergency.t, max(m.data.kp)) for m in frames if m.order > emergency.order
             and max(m.data.kp) > 0.0]
    assert stiff == [], f"frames with stiffness after EMERGENCY: {stiff}"

    damp = next((m, c) for m, c in calls if c["verb"] == "Damp" and c["phase"] == "request"
                and m.order > emergency.order)
    _reply, answer = answered(got, damp)
    assert answer["code"] == 0 and answer["latency_ms"] > 0.0, answer
    print(f"incident {path.name}: {len(users)} of the controller's frames before the stop (the last "
          f"{1000 * (note.t - users[-1].t):.0f} ms before it), "
          f"{sum(1 for m in frames if m.order > emergency.order)} damping frames after; the Damp "
          f"{1000 * (damp[0].t - note.t):.1f} ms after the remote's e-stop, answered in {answer['latency_ms']:.1f} ms")


def test_the_deadman_passes_user_frames_only_while_its_key_is_held(shared_stack_factory) -> None:
    stack = shared_stack_factory(node_params=("lowcmd_deadman_key:=R2",), bridge_args=("--gantry",))
    controller = Controller(stack, rate_hz=200.0)
    try:
        assert stack.set_mode("low_level").success
        t0 = time.monotonic()
        time.sleep(0.5)
        assert _user_frames(stack, t0) == [] and _first_damping_frame(stack, t0)
        stack.set_faults({"remote_keys": ["R2"]})
        t_held = _injected(stack, "remote_keys", t0)
        passing = wait_until(lambda: len(_user_frames(stack, t_held)) > 20, 3.0)
        last = stack.modes()[-1] if stack.modes() else None
        assert passing, (f"{len(_user_frames(stack, t_held))} user frames in 3 s with R2 held; ~/mode "
                         f"{last and (last.mode, list(last.holds), list(last.faults), list(last.warnings))}; lowcmd "
                         f"frames since: {Counter(str(e['why']) for e in of_kind(stack.record.events(t_held), 'frame'))}")
        stack.set_faults({})
        t_released = max(e["t"] for e in of_kind(stack.record.events(t0), "inject") if e["what"] == "remote_keys")
        time.sleep(0.6)
        late = _user_frames(stack, t_released + 0.25)
        assert late == [], f"{len(late)} user frames after the key was released"
        assert _first_damping_frame(stack, t_released + 0.25)
    finally:
        controller.stop()
