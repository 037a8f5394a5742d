"""One chaos scenario: random robot faults, random operator traffic, an e-stop at a random instant.

Everything random comes from the scenario's seed, so a failure is replayed with `make chaos SEED=<seed> N=1`.
The judge reads only the robot's side: the sim's record (requests and frames with receive times, state
changes) and the sim's final state. The node's replies are used only to know what it *claimed* and when.
"""

from __future__ import annotations

import random
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from g1_mode_manager.protocol import api_ids
from support.sim_record import Event, damped, fsm_of, is_damp, requests, states, velocity_of

#: Per-api delays the sim may inject (the robot's slow calls), s; node call timeouts exceed the maximum.
DELAYED_APIS = (api_ids.MS_CHECK_MODE, api_ids.MS_SELECT_MODE, api_ids.MS_RELEASE_MODE, api_ids.LOCO_SET_FSM_ID)
MAX_DELAY_S = 3.0
MODES = ("idle", "high_level", "low_level")
LOCO = ("stand_up", "start", "zero_torque", "squat", "balance_stand")
#: Operator actions, with their weights: mode requests, loco commands, /cmd_vel, arm and joint streams.
KINDS = ("mode", "mode", "loco", "drive", "arm", "lowcmd")
#: The node's stream limits (defaults of config/mode_manager.yaml), for the judge.
ARM_STEP = 1.0 / (2.0 * 50.0)  # arm_ramp_time_s 2 s at 50 Hz: the most the weight may change per frame
MOVE_STEP = (1.5 * 0.05, 1.0 * 0.05, 3.0 * 0.05)  # max_ax, max_ay, max_awz times one 20 Hz tick
GRACE_S = 0.06  # a frame in flight, plus one rt/sportmodestate period, after a change of state


@dataclass
class Plan:
    seed: int
    faults: dict[str, Any]
    actions: list[tuple[float, int, str, str]]  # (at s, client, "mode" | "loco" | "drive", argument)
    estop_at: float
    estop_via: str  # "service", "topic_reliable", "topic_best_effort"
    damp_fails: int


def plan(seed: int) -> Plan:
    rng = random.Random(seed)
    delays = {}
    for api in DELAYED_APIS:
        if rng.random() < 0.6:
            high = rng.uniform(0.1, MAX_DELAY_S)
            delays[str(api)] = [0.0, round(high, 3)]
    damp_fails = rng.choice([0, 0, 0, 1, 2])
    faults: dict[str, Any] = {"delay_s": delays, "seed": seed, "damp_fails": damp_fails}
    actions = []
    t = 0.0
    for _ in range(rng.randint(2, 6)):
        t += rng.uniform(0.05, 0.6)
        kind = rng.choice(KINDS)
        arg = rng.choice(MODES) if kind == "mode" else rng.choice(LOCO) if kind == "loco" else ""
        actions.append((t, rng.randint(0, 1), kind, arg))
    estop_at = rng.uniform(0.1, t + 0.8)
    via = rng.choice(["service", "service", "topic_reliable", "topic_best_effort"])
    return Plan(seed, faults, actions, estop_at, via, damp_fails)


@dataclass
class Claims:
    """What the node said, with the test process's monotonic receive time."""

    t_estop: float = 0.0
    estop_success: bool | None = None
    t_answer: float = 0.0
    modes: list[tuple[float, Any]] = field(default_factory=list)  # (t, Mode msg)
    lock: threading.Lock = field(default_factory=threading.Lock)


def judge(events: list[Event], claims: Claims, end_state: dict[str, Any]) -> list[str]:
    """Violations of the safety invariants, from the robot's record; [] if none."""
    bad: list[str] = []
    history = states(events)

    def state_at(t: float) -> Event | None:
        before = [s for s in history if s["t"] <= t]
        return before[-1] if before else None

    if claims.estop_success:
        at = state_at(claims.t_answer)
        if at is None or not damped(at):
            bad.append(f"e-stop answered success but the robot was {at}")
        later = [s for s in history if s["t"] > claims.t_answer and not damped(s)]
        if later:
            bad.append(f"robot left damping after the e-stop's success: {later[:3]}")
    sport = end_state["sport"]
    if not (sport["fsm_id"] == 1 and sport["mode"]):
        bad.append(f"robot not damped at the end (faults cleared): {sport}")

    after = [e for e in events if e["t"] >= claims.t_estop]
    damps = [e for e in requests(after) if is_damp(e)]
    if not damps:
        bad.append("no Damp reached the robot after the e-stop")
    else:
        cut = damps[1]["t"] if len(damps) > 1 else damps[0]["t"]
        for e in after:
            if e["t"] <= cut:
                continue
            if e["k"] == "req" and any(velocity_of(e) or []):
                bad.append(f"Move after the e-stop: {e}")
            elif e["k"] == "req" and fsm_of(e) not in (None, 1):
                bad.append(f"SetFsmId {fsm_of(e)} after the e-stop")
            elif e["k"] == "frame" and e["topic"] == "arm_sdk" and e["w"] > 0:
                bad.append(f"arm_sdk weight {e['w']} after the e-stop")
            elif e["k"] == "frame" and e["topic"] == "lowcmd" and e["kp_max"] > 0:
                bad.append(f"user lowcmd (kp {e['kp_max']}) after the e-stop")
    with claims.lock:
        modes = list(claims.modes)
    for t, msg in modes:
        if msg.damp_confirmed:
            at = state_at(t)
            if at is None or not damped(at):
                bad.append(f"~/mode claimed damped at {t:.3f} while the robot was {at}")
                break
    bad += _judge_streams(events, history, modes)
    return bad


def _judge_streams(events: list[Event], history: list[Event], modes: list[tuple[float, Any]]) -> list[str]:
    """The stream invariants (issue 8), on the frames and Moves the robot received."""
    bad: list[str] = []
    accepting = (4, 500, 501, 801, 802)

    def accepting_at(t: float) -> bool:
        before = [s for s in history if s["t"] <= t]
        return bool(before) and bool(before[-1]["svc"]) and before[-1]["fsm"] in accepting

    changes = [s["t"] for s in history]
    last_w = None
    for e in events:
        if e["k"] != "frame" or e["topic"] != "arm_sdk":
            continue
        if e["w"] > 0 and not accepting_at(e["t"]) and not any(0 <= e["t"] - c <= GRACE_S for c in changes):
            bad.append(f"arm_sdk weight {e['w']:.3f} while the robot did not take arm_sdk")
            break
        if e["ok"]:
            if last_w is not None and abs(e["w"] - last_w) > ARM_STEP + 1e-6:
                bad.append(f"arm_sdk weight jumped {last_w:.3f} -> {e['w']:.3f}")
                break
            last_w = e["w"]
    left_low = [t for (t, m), (_, prev) in zip(modes[1:], modes[:-1], strict=False)
                if prev.mode == 3 and not prev.transition_in_progress and (m.mode != 3 or m.transition_in_progress)]
    for t_left in left_low:
        nxt = [t for t, m in modes if t > t_left and m.mode == 3 and not m.transition_in_progress]
        until = nxt[0] if nxt else float("inf")
        late = [e for e in events if e["k"] == "frame" and e["topic"] == "lowcmd" and e["kp_max"] > 0
                and t_left + GRACE_S < e["t"] < until]
        if late:
            bad.append(f"user lowcmd frame (kp {late[0]['kp_max']}) {late[0]['t'] - t_left:.3f} s after leaving LOW_LEVEL")
            break
    previous = (0.0, 0.0, 0.0)
    for e in events:
        if e.get("api") != api_ids.LOCO_SET_VELOCITY:
            continue
        if e["k"] == "done" and e["code"] == 0:
            v = velocity_of(e) or [0.0, 0.0, 0.0]
            if any(v) and any(abs(a - b) > step + 1e-6 for a, b, step in zip(v, previous, MOVE_STEP, strict=True)):
                bad.append(f"Move {v} after {list(previous)}: above the acceleration limit")
                break
            previous = (v[0], v[1], v[2])
    return bad


def run_actions(stack: Any, p: Plan, t0: float, stop: threading.Event) -> None:
    """The operators: each client in its own thread, actions at their planned times."""

    def client(k: int) -> None:
        for at, who, kind, arg in p.actions:
            if who != k:
                continue
            if stop.wait(max(0.0, t0 + at - time.monotonic())):
                return
            try:
                if kind == "mode":
                    stack.set_mode(arg, timeout_s=20.0)
                elif kind == "loco":
                    stack.loco(arg)
                elif kind == "drive":
                    stack.drive(0.3, 0.5, rate_hz=50.0)
                elif kind == "arm":
                    _stream(stack, "arm_cmd", _arm_msg(), 0.6, 50.0)
                else:
                    _stream(stack, "lowcmd", _lowcmd_msg(), 0.5, 100.0)
            except TimeoutError:
                pass

    threads = [threading.Thread(target=client, args=(k,), daemon=True) for k in (0, 1)]
    for th in threads:
        th.start()
    for th in threads:
        th.join(40.0)


def _arm_msg() -> Any:
    from sensor_msgs.msg import JointState

    return JointState(name=["left_shoulder_roll_joint", "right_shoulder_roll_joint"], position=[0.6, -0.6])


def _lowcmd_msg() -> Any:
    from g1_mode_manager_msgs.msg import JointCommand

    return JointCommand(name=["left_elbow_joint"], q=[1.0], dq=[0.0], tau=[0.0], kp=[40.0], kd=[2.0])


_PUBLISHERS: dict[tuple[int, str], Any] = {}


def _stream(stack: Any, topic: str, msg: Any, seconds: float, rate_hz: float) -> None:
    """Publish ``msg`` on the node's ``~/<topic>`` for ``seconds``."""
    key = (id(stack.ros.node), stack.name(topic))
    if key not in _PUBLISHERS:
        _PUBLISHERS[key] = stack.ros.node.create_publisher(type(msg), stack.name(topic), 10)
    pub = _PUBLISHERS[key]
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        pub.publish(msg)
        time.sleep(1.0 / rate_hz)
