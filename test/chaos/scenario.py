"""The judge of a chaos scenario: the safety invariants, read from the robot's side only.

The judge reads the sim's record (requests and frames with receive times, state changes) and the sim's final
state. The node's replies and ``~/mode`` messages are used only to know what it *claimed* and when.

Joint frames: on the release path they go to rt/lowcmd; on the user_ctrl path to rt/user_lowcmd, where the
node's own hand-over and hold frames (kp ``HOLD_KP`` on every joint) keep a robot under user control commanded and
are told from the user's (the operators' stream has another kp) by their stiffness.
"""

from __future__ import annotations

import itertools
import threading
from dataclasses import dataclass, field
from typing import Any

from chaos import policy
from chaos.drivers import DriveLog, judge_drivers, judge_ramps
from g1_mode_manager.core.user_ctrl import UserCtrlConfig
from g1_mode_manager.protocol import api_ids
from support.sim_record import Event, confirming_damp, damped, fsm_of, requests, sent_at, states, velocity_of

#: After a FAULT was claimed, the robot must be seen damped within this (the e-stop's budget, its calls'
#: injected delays), s.
FAULT_DAMPED_S = 12.0
#: The node's stream limits (defaults of config/mode_manager.yaml), for the judge.
ARM_STEP = 1.0 / (2.0 * 50.0)  # arm_ramp_time_s 2 s at 50 Hz: the most the weight may change per frame
#: The soonest a node started after a SIGKILL can publish its first ``~/mode``, s (a process start and
#: rclpy's import alone take longer).
SUCCESSOR_EARLIEST_S = 0.3
GRACE_S = 0.06  # a frame in flight, plus one rt/sportmodestate period, after a change of state
#: The node's hand-over and hold frames' stiffness (user_ctrl_hold_kp's default).
HOLD_KP = UserCtrlConfig().hold_kp
JOINT_TOPICS = ("lowcmd", "user_lowcmd")


@dataclass
class Claims:
    """What the node said, with the test process's monotonic receive time."""

    t_estop: float = 0.0
    estop_success: bool | None = None
    t_answer: float = 0.0
    #: a second e-stop: (answered at, success) of each one answered (a topic e-stop has no answer)
    later_estops: list[tuple[float, bool]] = field(default_factory=list)
    #: (SIGKILLed at, the fresh node's first mode request sent at, or inf) of each restart
    restarts: list[tuple[float, float]] = field(default_factory=list)
    modes: list[tuple[float, Any]] = field(default_factory=list)  # (t, Mode msg)
    drives: DriveLog = field(default_factory=DriveLog)  # the hand-overs, take-overs and planner streams
    policy: list[tuple[float, str, str]] = field(default_factory=list)  # (t, phase, last_fault) of ~/policy/status
    engages: list[float] = field(default_factory=list)  # when each policy engage was sent
    lock: threading.Lock = field(default_factory=threading.Lock)


def _user_frame(e: Event) -> bool:
    """A joint frame that forwards a user's command: stiff, and not the node's own hold."""
    return (e["k"] == "frame" and e["topic"] in JOINT_TOPICS and e["kp_max"] > 0
            and not (e["topic"] == "user_lowcmd" and e["kp_max"] == HOLD_KP))


def judge(events: list[Event], claims: Claims, end_state: dict[str, Any], path: str = "release") -> list[str]:
    """Violations of the safety invariants, from the robot's record; [] if none. ``path``: the node's
    low_level_path."""
    bad: list[str] = _judge_path(events, path)
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
    confirming = confirming_damp(after)
    if confirming is None:
        bad.append("no Damp reached the robot after the e-stop")
    else:
        cut = confirming["t"]
        for e in after:
            if e["t"] <= cut:
                continue
            if e["k"] == "req" and any(velocity_of(e) or []):
                bad.append(f"Move after the e-stop: {e}")
            elif e["k"] == "req" and fsm_of(e) not in (None, 1):
                bad.append(f"SetFsmId {fsm_of(e)} after the e-stop")
            elif e["k"] == "frame" and e["topic"] == "arm_sdk" and e["w"] > 0:
                bad.append(f"arm_sdk weight {e['w']} after the e-stop")
            elif e["k"] == "frame" and e["topic"] in JOINT_TOPICS and e["kp_max"] > 0:
                bad.append(f"{e['topic']} frame (kp {e['kp_max']}) after the e-stop")
    for t_answer, success in claims.later_estops:
        at = state_at(t_answer)
        if success and (at is None or not damped(at)):
            bad.append(f"a second e-stop answered success but the robot was {at}")
    with claims.lock:
        modes = list(claims.modes)
    for t, msg in modes:
        if msg.damp_confirmed:
            at = state_at(t)
            if at is None or not damped(at):
                bad.append(f"~/mode claimed damped at {t:.3f} while the robot was {at}")
                break
    # one node's life each; a claim received just after a kill is the killed node's, sent before it died (a
    # fresh node takes far longer than SUCCESSOR_EARLIEST_S to start and publish)
    kills = [t + SUCCESSOR_EARLIEST_S for t, _ in claims.restarts]
    for lo, hi in itertools.pairwise([float("-inf"), *kills, float("inf")]):
        life = [(t, m) for t, m in modes if lo <= t < hi]
        bad += _judge_streams(events, history, life, killed_at=hi)
        bad += _judge_faults(events, history, life, killed_at=hi)
    bad += _judge_restarts(events, claims.restarts)
    bad += judge_drivers(events, modes, claims.drives, claims.restarts, GRACE_S)
    bad += judge_ramps(events, claims.drives)
    bad += policy.judge(events, claims.engages)
    return bad


def _judge_path(events: list[Event], path: str) -> list[str]:
    """What each LOW_LEVEL path promises of the robot's side. user_ctrl: the robot is never released (limp), no
    frame goes to rt/lowcmd, and a user's frame reaches rt/user_lowcmd only while the robot is under user control
    (fsm 1000 shown: the node forwards none before it saw 1000, and none after it left LOW_LEVEL). release: nothing
    on rt/user_lowcmd."""
    bad: list[str] = []
    if path == "release":
        if user := [e for e in events if e["k"] == "frame" and e["topic"] == "user_lowcmd"]:
            bad.append(f"a frame on rt/user_lowcmd on the release path: {user[0]}")
        return bad
    if released := [e for e in requests(events, api_ids.MS_RELEASE_MODE)]:
        bad.append(f"ReleaseMode on the user_ctrl path at {released[0]['t']:.3f}")
    if limp := [s for s in states(events) if not s["svc"]]:
        bad.append(f"the robot released (limp) on the user_ctrl path: {limp[0]}")
    if low := [e for e in events if e["k"] == "frame" and e["topic"] == "lowcmd"]:
        bad.append(f"a frame on rt/lowcmd on the user_ctrl path: {low[0]}")
    if outside := [e for e in events if _user_frame(e) and e["why"] == "not_user_ctrl"]:
        bad.append(f"a user frame (kp {outside[0]['kp_max']}) reached the robot outside user control at "
                   f"{outside[0]['t']:.3f}")
    return bad


#: How long before its ~/mode claim reaches the test the node's exit frames may reach the robot, s (the claim waits
#: for the publisher's change check and the delivery to the test; a loaded machine delays both).
EXIT_CLAIM_LAG_S = 2.0


def _own_frame(e: Event) -> bool:
    """A joint frame of the node's own: damping, or on rt/user_lowcmd its hand-over and hold frames."""
    return e["k"] == "frame" and e["topic"] in JOINT_TOPICS and (
        e["kp_max"] == 0 or (e["topic"] == "user_lowcmd" and e["kp_max"] == HOLD_KP))


def _sent_before_the_exit(events: list[Event], i: int, t_left: float) -> bool:
    """Whether the user frame ``events[i]``, which reached the robot after the leave was claimed, was sent before the
    node left LOW_LEVEL: leaving, the node writes its own exit frames (damping or a hold) before anything else, and one
    writer's frames reach the robot in order; so a user frame is excused when frames of the node's own on its topic
    reached the robot after it, and none since shortly before the claim before it (a loaded machine delays a frame in
    flight past GRACE_S). A record without the node's exit frames excuses nothing."""
    e = events[i]
    # from the user's last frame that reached the robot before the claim: the entry's hand-over frames come before
    # the user's first, and are no exit
    start = max((j for j, x in enumerate(events[:i]) if _user_frame(x) and x["topic"] == e["topic"] and x["t"] <= t_left),
                default=0)
    own = [j for j, x in enumerate(events) if j > start and _own_frame(x) and x["topic"] == e["topic"]
           and x["t"] >= t_left - EXIT_CLAIM_LAG_S]
    return bool(own) and min(own) > i


def _judge_restarts(events: list[Event], restarts: list[tuple[float, float]]) -> list[str]:
    """A SIGKILLed node sends nothing more, and its fresh successor forwards nothing before it is asked for a
    mode: between the kill (plus a frame in flight) and that request, no motion reaches the robot."""
    bad = []
    for t_kill, t_request in restarts:
        late = [(_sent(e) - t_kill, what) for e in events
                if t_kill + GRACE_S < _sent(e) < t_request and (what := _forwarded_motion(e))]
        if late:
            bad.append(f"{late[0][1]} reached the robot {late[0][0]:.3f} s after the node was killed, before its "
                       f"successor was asked for a mode")
    return bad


def _sent(e: Event) -> float:
    """When the node sent what the robot received: a request's own stamp (drivers._moves says why), a frame's
    receive time (a frame carries none: late, never early)."""
    return sent_at(e) if e["k"] == "req" else e["t"]


def _forwarded_motion(e: Event, *, arms: bool = True) -> str:
    """What motion (not damping) this record event forwarded to the robot, or ''. ``arms``: an arm_sdk weight
    above zero counts (not while a hold ramps the arms out)."""
    if arms and e["k"] == "frame" and e["topic"] == "arm_sdk" and e["w"] > 0:
        return f"arm_sdk weight {e['w']}"
    if e["k"] == "req" and any(velocity_of(e) or []):
        return f"Move {velocity_of(e)}"
    if e["k"] == "req" and fsm_of(e) not in (None, 1):
        return f"SetFsmId {fsm_of(e)}"
    if e["k"] == "frame" and e["topic"] in JOINT_TOPICS and e["kp_max"] > 0:
        return f"{e['topic']} frame (kp {e['kp_max']})"
    return ""


def _judge_faults(events: list[Event], history: list[Event], modes: list[tuple[float, Any]], *,
                  killed_at: float = float("inf")) -> list[str]:
    """FAULT (a body check's protective stop) and holds, on the robot's record: FAULT is left only to IDLE or
    EMERGENCY; from the moment it was claimed nothing but damping reaches the robot until it is left, and the
    robot is seen damped within FAULT_DAMPED_S; while a hold is claimed no Move and no user lowcmd reach it.
    ``modes`` are one node's; a node SIGKILLed at ``killed_at`` is judged only until then."""
    bad: list[str] = []
    if not modes:
        return bad
    fault_mode, idle, emergency = 5, 1, 4
    episodes: list[tuple[float, float]] = []  # (claimed, left) of each FAULT and hold period
    holds: list[tuple[float, float]] = []
    start = held = None
    for (t, m), nxt in zip(modes, [*modes[1:], (killed_at, None)], strict=True):
        if m.mode == fault_mode and start is None:
            start = t
        if start is not None and nxt[1] is not None and nxt[1].mode != fault_mode:
            if nxt[1].mode not in (idle, emergency):
                bad.append(f"FAULT left to {nxt[1].name}")
            episodes.append((start, nxt[0]))
            start = None
        if m.holds and held is None:
            held = t
        if held is not None and (nxt[1] is None or not nxt[1].holds):
            holds.append((held, nxt[0]))
            held = None
    if start is not None:
        episodes.append((start, killed_at))
    for t_fault, t_left in episodes:
        late = [(_sent(e) - t_fault, what) for e in events
                if t_fault + GRACE_S < _sent(e) < t_left and (what := _forwarded_motion(e))]
        if late:
            bad.append(f"{late[0][1]} reached the robot {late[0][0]:.3f} s into FAULT")
        end = min(events[-1]["t"] if events else t_fault, killed_at)  # a killed node keeps nothing damped
        # the state the robot was in when the claim arrived counts: the protective stop's Damp may reach the robot
        # before ~/mode says FAULT, and a robot damped from then on records no state change in the window
        seen = [s for s in history if s["t"] <= t_fault][-1:] + [s for s in history
                                                                 if t_fault < s["t"] <= t_fault + FAULT_DAMPED_S]
        if end - t_fault > FAULT_DAMPED_S and not any(damped(s) for s in seen):
            bad.append(f"robot not damped within {FAULT_DAMPED_S} s of FAULT")
    for t_held, t_released in holds:
        late = [what for e in events if t_held + GRACE_S < _sent(e) < t_released
                and (what := _forwarded_motion(e, arms=False)) and not what.startswith("SetFsmId")]
        if late:
            bad.append(f"{late[0]} reached the robot while a body check held motion")
    return bad


def _judge_streams(events: list[Event], history: list[Event], modes: list[tuple[float, Any]],
                   killed_at: float = float("inf")) -> list[str]:
    """The stream invariants (arm weight ramps, no user frames outside LOW_LEVEL), on what the robot received (the
    Moves: drivers.py). A node's life ends at ``killed_at``: the frames after it are its successor's, judged in that life."""
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
        # the node forwards the user's frames as soon as it is in LOW_LEVEL again, and the first may reach the robot
        # before its ~/mode says so reaches the test: a frame in flight before the claim, as after a change of state
        until = nxt[0] - GRACE_S if nxt else killed_at
        late = [e for i, e in enumerate(events) if _user_frame(e) and t_left + GRACE_S < e["t"] < until
                and not _sent_before_the_exit(events, i, t_left)]
        if late:
            bad.append(f"user lowcmd frame (kp {late[0]['kp_max']}) {late[0]['t'] - t_left:.3f} s after leaving LOW_LEVEL")
            break
    return bad
