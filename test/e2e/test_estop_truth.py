"""The e-stop judged by the robot: the sim's own record of what it received and what state it was in.

Every scenario makes a race window as long as it is on a real G1 (ReleaseMode/SelectMode take seconds)
with the sim's delay faults, fires the e-stop inside it, and asserts on the sim's record: the robot is
damping with "ai" selected when the e-stop answers success, and stays so; a call that was in flight
and landed after the e-stop's Damp is followed by a re-damp. The e-stop mid-walk is read from its incident file
too (support/incidents.py): the node's own account of the same Moves and the stop's steps.
"""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from g1_mode_manager.protocol import api_ids
from support.incidents import ROBOT_CALLS, answered, json_of, messages, metadata, wait_for_incident
from support.mode_manager import wait_until
from support.sim_record import confirming_damp, damped, is_damp, requests, states, velocity_of
from support.timing import INCIDENT_AFTER_S, INCIDENT_WRITE_S, QUIET_WINDOW_S

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

#: How long after the e-stop's answer the robot must stay damped: a watch for something that must not happen. The
#: e-stop answers only once the call it raced has landed and been overridden, so no held call is left to land in it.
SETTLE_S = QUIET_WINDOW_S


def _assert_damped_from(stack, t_answer: float) -> list[dict]:
    """The sim's record: damped (fsm 1, "ai") at the moment the e-stop answered and ever after."""
    time.sleep(SETTLE_S)
    events = stack.record.events()
    history = states(events)
    before = [s for s in history if s["t"] <= t_answer]
    after = [s for s in history if s["t"] > t_answer]
    assert before and damped(before[-1]), f"robot not damped when the e-stop answered: {before[-3:]}"
    assert all(damped(s) for s in after), f"robot left damping after the e-stop answered: {after}"
    sport = stack.sim.get()["sport"]
    assert sport["fsm_id"] == 1 and sport["mode"] == "ai", sport
    return events


def _estop_in(stack, pool: ThreadPoolExecutor, action, slow_api: int, delay_s: float):
    """Start ``action`` in the pool, fire the e-stop ``delay_s`` after the robot received the slow call
    ``slow_api`` (so the e-stop lands while it is in flight, however long the transition took to send it);
    (e-stop reply, time requested, time answered)."""
    since = time.monotonic()
    pending = pool.submit(action)
    sent = lambda: requests(stack.record.events(since=since), slow_api)  # noqa: E731
    assert wait_until(lambda: bool(sent()), 15.0), f"the transition never sent API {slow_api} to the robot"
    time.sleep(max(0.0, sent()[0]["t"] + delay_s - time.monotonic()))
    t_request = time.monotonic()
    reply = stack.estop(timeout_s=30.0)
    t_answer = time.monotonic()
    pending.result(30.0)
    return reply, t_request, t_answer


def test_estop_during_a_slow_release_mode_ends_damped_on_the_robot(shared_stack_factory) -> None:
    """The issue's scenario: ReleaseMode takes 2 s, the e-stop comes 1 s into LOW_LEVEL entry."""
    stack = shared_stack_factory(faults={"delay_s": {str(api_ids.MS_RELEASE_MODE): 2.0}})
    assert stack.set_mode("high_level").success
    with ThreadPoolExecutor(1) as pool:
        reply, t_request, t_answer = _estop_in(stack, pool, lambda: stack.set_mode("low_level"),
                                                 api_ids.MS_RELEASE_MODE, 1.0)
    assert reply.success, reply.message
    events = _assert_damped_from(stack, t_answer)
    # the race really happened: the ReleaseMode landed after the e-stop's first Damp, and was overridden
    first_damp = next(e["t"] for e in requests(events) if is_damp(e) and e["t"] >= t_request)
    release_landed = next(e["t"] for e in requests(events, api_ids.MS_RELEASE_MODE, kind="done"))
    assert release_landed > first_damp
    released = [s for s in states(events) if s["t"] > first_damp and not s["svc"]]
    assert released, "the robot was never released: the scenario exercised nothing"
    reselect = [e for e in requests(events, api_ids.MS_SELECT_MODE) if e["t"] > released[0]["t"]]
    assert reselect and any(is_damp(e) and e["t"] > reselect[0]["t"] for e in requests(events))
    print(f"e-stop answered {t_answer - t_request:.2f} s after the request; ReleaseMode landed "
          f"{release_landed - first_damp:.2f} s after the first Damp")


def test_estop_during_a_slow_select_mode_ends_damped_on_the_robot(shared_stack_factory) -> None:
    stack = shared_stack_factory(faults={"delay_s": {str(api_ids.MS_SELECT_MODE): 2.0}})
    assert stack.set_mode("low_level").success
    with ThreadPoolExecutor(1) as pool:
        reply, _t_request, t_answer = _estop_in(stack, pool, lambda: stack.set_mode("high_level"),
                                                  api_ids.MS_SELECT_MODE, 1.0)
    assert reply.success, reply.message
    _assert_damped_from(stack, t_answer)


def test_estop_during_a_slow_check_mode_ends_damped_on_the_robot(shared_stack_factory) -> None:
    stack = shared_stack_factory(faults={"delay_s": {str(api_ids.MS_CHECK_MODE): 1.0}})
    assert stack.set_mode("high_level").success
    with ThreadPoolExecutor(1) as pool:
        reply, _t_request, t_answer = _estop_in(stack, pool, lambda: stack.set_mode("low_level"),
                                                  api_ids.MS_CHECK_MODE, 0.5)
    assert reply.success, reply.message
    _assert_damped_from(stack, t_answer)


def test_a_loco_command_racing_the_estop_is_followed_by_a_redamp(shared_stack_factory) -> None:
    """StandUp (accepted from Damp) takes 1.5 s inside the robot; the e-stop's Damps land first. The robot hangs
    in the gantry, as a G1 is stood up from damping: free, it would lie on the floor by the time the StandUp
    lands, and a lying robot does not take it."""
    stack = shared_stack_factory(node_params=("rpc_timeout_s:=3.0",),  # the StandUp's reply comes back in time
                                 bridge_args=("--gantry",))
    assert stack.set_mode("high_level").success
    assert stack.loco("damp").success
    assert wait_until(lambda: stack.sim.get()["sport"]["fsm_id"] == 1, 3.0)
    # the StandUp is slow; everything after it (the e-stop's Damps) is fast
    stack.set_faults({"delay_s": {str(api_ids.LOCO_SET_FSM_ID): 1.5}})
    with ThreadPoolExecutor(1) as pool:
        pending = pool.submit(stack.loco, "stand_up")
        assert wait_until(lambda: any(e["p"] == '{"data": 4}' for e in requests(stack.record.events(),
                                                                                  api_ids.LOCO_SET_FSM_ID)), 3.0)
        stack.set_faults({})
        t_request = time.monotonic()
        reply = stack.estop(timeout_s=30.0)
        t_answer = time.monotonic()
        pending.result(30.0)
    assert reply.success, reply.message
    events = _assert_damped_from(stack, t_answer)
    stood = [s for s in states(events) if s["t"] > t_request and s["fsm"] == 4]
    assert stood, "the StandUp never landed after the e-stop: the scenario exercised nothing"
    assert any(is_damp(e) and e["t"] > stood[0]["t"] for e in requests(events)), "no Damp after the late StandUp"


def test_another_program_undamping_the_robot_is_overridden_within_1_s(shared_stack_factory) -> None:
    """The robot hangs in the gantry: free and damped, it lies on the floor within a second or two, and a lying
    robot takes the other program's StandUp without moving (it gets up only through 702), so on a loaded machine,
    where the other program's first call came late, the robot never left damping and nothing was tested."""
    stack = shared_stack_factory(bridge_args=("--gantry",))
    other = _other_program()
    other.wait_ready(10.0)
    assert stack.estop().success
    t_other = time.monotonic()
    other.set_fsm_id(4, timeout_s=5.0)  # another program stands the robot up after the e-stop

    def left_and_back(events: list[dict]) -> tuple[dict | None, dict | None]:
        left = next((s for s in states(events) if s["t"] > t_other and s["fsm"] != 1), None)
        back = left and next((s for s in states(events) if s["t"] > left["t"] and damped(s)), None)
        return left, back

    # waited on the record, not the sim's live state: the sim records a state after the handler that set it
    # returns, so the live state can show the re-damp before the record has it
    wait_until(lambda: left_and_back(stack.record.events())[1] is not None, 3.0)
    events = stack.record.events()
    left, back = left_and_back(events)
    seen = [(round(e["t"] - t_other, 4), e["k"], e.get("api"), e.get("p"), e.get("fsm"), e.get("code"))
            for e in events if e["t"] > t_other - 0.5 and e["k"] in ("req", "done", "state")]
    assert left is not None, f"the robot never left damping on the record: {seen}; node: {stack.node.lines[-15:]}"
    assert back is not None, f"the robot never went back to damping on the record: {seen}; node: {stack.node.lines[-15:]}"
    print(f"robot out of damping for {back['t'] - left['t']:.3f} s")
    assert back["t"] - left["t"] < 1.0
    assert "EMERGENCY re-asserted" in "\n".join(stack.node.lines)


def test_no_move_reaches_the_robot_after_the_estop_and_its_incident_holds_the_moves_and_the_steps(
        shared_stack_factory, tmp_path: Path) -> None:
    """A teleop keeps publishing through the e-stop: nothing but Damp after the e-stop's Damp. The stop's incident
    file (_the_estops_incident) holds the same Moves and the e-stop's steps."""
    incidents = tmp_path / "incidents"
    stack = shared_stack_factory(node_params=(f"recorder_dir:={incidents}", f"recorder_after_s:={INCIDENT_AFTER_S}"))
    assert stack.set_mode("high_level").success
    assert stack.loco("start").success
    stop_driving = threading.Event()

    def drive() -> None:  # a teleop at 100 Hz until told to stop
        while not stop_driving.is_set():
            stack.drive(0.4, 0.1, rate_hz=100.0)

    with ThreadPoolExecutor(1) as pool:
        driving = pool.submit(drive)
        since = time.monotonic()

        def walking() -> bool:  # the e-stop goes out while Moves are reaching the robot (a loaded machine may lag)
            moves = [e for e in requests(stack.record.events(since=since), api_ids.LOCO_SET_VELOCITY) if any(velocity_of(e))]
            return len(moves) >= 10 and time.monotonic() - moves[-1]["t"] < 0.1

        assert wait_until(walking, 3.0), "no stream of Moves reached the robot"
        t_request = time.monotonic()
        assert stack.estop().success
        # the teleop goes on after the answer: a Move let through would come at the relay's next 20 Hz tick,
        # so this window holds ~20 chances for one
        time.sleep(QUIET_WINDOW_S)
        stop_driving.set()
        driving.result(10.0)
    events = stack.record.events(since=t_request)
    confirming = confirming_damp(events)
    assert confirming is not None
    # after the Damp that the e-stop sent once it registered, no Move (a StopMove, SetVelocity 0 0 0, may still
    # come: it moves nothing)
    cut = confirming["t"]
    late = [(e["t"] - cut, e["p"]) for e in requests(events, api_ids.LOCO_SET_VELOCITY)
            if e["t"] > cut and any(velocity_of(e))]
    assert late == [], late
    # the scenario exercised something: Moves flowed (the ramp at 20 Hz, then the 10 Hz keep-alive) up to the
    # e-stop, the last one within a few keep-alive periods of it
    received = [e for e in requests(stack.record.events(), api_ids.LOCO_SET_VELOCITY) if any(velocity_of(e))]
    before = [e for e in received if e["t"] < t_request]
    assert len(before) >= 10, f"{len(before)} Moves before the e-stop: the scenario exercised nothing"
    assert t_request - before[-1]["t"] < 0.3, "Moves had stopped before the e-stop"
    _the_estops_incident(incidents, stack.name("estop"), received)


def _the_estops_incident(folder: Path, service: str, received: list[dict]) -> None:
    """The e-stop's incident file, in the node's order: the Moves, each answered by the robot with its latency,
    every one of them the robot received; then the e-stop's first packet (DampNoReply), its request, EMERGENCY (no
    Move from here: the forward gate closed), the Damp and its answer, the robot seen damped, the answer."""
    path = wait_for_incident(folder, "emergency", INCIDENT_AFTER_S + INCIDENT_WRITE_S)
    info = metadata(path)
    assert info["cause"] == f"EMERGENCY from HIGH_LEVEL ({service})" and info["mode"] == "EMERGENCY", info
    got = messages(path)
    [request] = [m for m, e in json_of(got, "/recorder/estop") if e["step"] == "request" and e["via"] == service]
    answer = [(m, e) for m, e in json_of(got, "/recorder/estop") if e["step"] == "answer" and e["via"] == service]
    assert len(answer) == 1 and answer[0][1]["detail"].startswith("success=True"), answer
    statuses = json_of(got, "/recorder/status")
    emergency = next(m for m, s in statuses if s["mode"] == "EMERGENCY")
    confirmed = next(m for m, s in statuses if s["mode"] == "EMERGENCY" and s["damp_confirmed"])
    calls = json_of(got, ROBOT_CALLS)
    shot = [m for m, c in calls if c["verb"] == "DampNoReply" and c["phase"] == "no_reply" and c["code"] == 0]
    assert shot and shot[0].order < request.order, "the DampNoReply did not go out before the request was noted"
    damp = next((m, c) for m, c in calls if c["verb"] == "Damp" and c["phase"] == "request"
                and m.order > emergency.order)
    damped, damped_value = answered(got, damp)
    assert damped_value["code"] == 0 and damped_value["latency_ms"] > 0.0, damped_value
    assert shot[0].order < request.order < emergency.order < damp[0].order < damped.order < confirmed.order \
        < answer[0][0].order

    moves = [(m, c) for m, c in calls if c["verb"] == "SetVelocity" and c["phase"] == "request"
             and any(c["parameter"][axis] != 0.0 for axis in ("vx", "vy", "wz"))]
    # the gate closes at EMERGENCY: a Move it let through just before may be noted after the request
    assert [m.t - emergency.t for m, _c in moves if m.order > emergency.order] == []
    assert len(moves) == len(received), f"{len(moves)} Moves in the file, {len(received)} on the robot"
    replies = [answered(got, move)[1] for move in moves]
    acknowledged = [a for a in replies if a["code"] == 0]
    assert len(acknowledged) >= 3 and all(a["latency_ms"] > 0.0 for a in acknowledged), replies[:5]
    assert any(m.data.linear.x > 0.0 for m in got if m.topic == "/recorder/moves/teleop" and m.t < request.t)
    latencies = [a["latency_ms"] for a in acknowledged]
    noted_late = sum(1 for m, _c in moves if m.order > request.order)
    print(f"incident {path.name}: {len(got)} messages; {len(moves)} Moves ({len(acknowledged)} acknowledged in "
          f"{min(latencies):.1f}-{max(latencies):.1f} ms, {noted_late} noted between the request and EMERGENCY); "
          f"the Damp {1000 * (damp[0].t - request.t):.1f} ms after the request, answered in "
          f"{damped_value['latency_ms']:.1f} ms; answered {1000 * (answer[0][0].t - request.t):.0f} ms after it")


_OTHER: list = []


def _other_program():
    """An SDK loco client in this process (kept for the session: see harness.sim_bridge's pitfall)."""
    if not _OTHER:
        from g1_mode_manager.sdk.loco_client import LocoClient

        _OTHER.append(LocoClient(1.0))
    return _OTHER[0]
