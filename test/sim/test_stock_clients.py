"""The sim as a robot's user meets it: stock SDK2 clients, initialised the SDK's own way, on both Cyclones.

A robot is found by whatever the SDK's plain ``ChannelFactoryInitialize(d, "lo")`` does: on cyclonedds 11
that is multicast on lo, on the robot's Cyclone 0.10.2 unicast with participant indices; our own clients
are unicast-only. The bridge must serve all of them at once, so each stock client runs in a subprocess
(the SDK's channel factory is a process-wide singleton) while this process's unicast status client reads
the sim. What the robot did is judged from its own record and status, not from the clients' replies.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from support.cyclone010 import STOCK_CLIENT, json_lines, side_python
from support.processes import ManagedProcess
from support.sim_bridge import SimStatus, shared_sim_status, start_sim_bridge
from support.sim_record import SimRecord, states
from support.timing import QUIET_WINDOW_S

pytestmark = pytest.mark.sim

CLIENT_TIMEOUT_S = 60.0


@pytest.fixture(scope="module")
def _bridge_record(sdk_channels: int, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """One bridge for the file (its start, MuJoCo model and policy, takes seconds): each test gets it reset."""
    path = tmp_path_factory.mktemp("stock_clients") / "robot.jsonl"
    bridge = start_sim_bridge(sdk_channels, speed=1.0, extra_args=("--record", str(path)))
    yield path
    code = bridge.stop()
    if code not in (0, None):
        print(f"sim_bridge exited with {code}:\n{bridge.output()}")


@pytest.fixture
def robot(_bridge_record: Path) -> tuple[SimStatus, SimRecord]:
    """The file's bridge back to its boot state (a fresh robot: standing, "ai", no faults, counters at zero), with
    a view of its record from just before the reset."""
    status = shared_sim_status()  # unicast-only (our configuration), reading while the stock clients drive
    status.wait_ready(15.0)
    record = SimRecord(_bridge_record, from_now=True)
    status.reset()
    return status, record


def _run_stock_client(python: str, domain: int, *args: str) -> list[dict]:
    """Run the stock client to its end; returns its step lines (fails with its output if it did not finish)."""
    proc = ManagedProcess([python, "-u", str(STOCK_CLIENT), str(domain), *args], name="stock_client")
    try:
        proc.proc.wait(CLIENT_TIMEOUT_S)
    finally:
        code = proc.stop()
    assert code == 0, f"stock client exited with {code}:\n{proc.output()}"
    return json_lines(proc)


def _step(lines: list[dict], name: str) -> dict:
    found = [line for line in lines if line["step"] == name]
    assert found, f"no {name!r} step: {lines}"
    return found[-1]


def _check_walk(record: SimRecord, lines: list[dict], walked_m: float, *, stood: bool) -> None:
    """Walking (200, the SDK's Start) on the robot's side after Damp -> stand-up if asked, and the base moved."""
    t0, t1 = _step(lines, "connected")["t"], _step(lines, "walk")["t"]
    fsms = [s["fsm"] for s in states(record.events(since=t0)) if s["t"] <= t1]
    assert 200 in fsms and (not stood or fsms[:2] == [1, 4]), f"robot states {fsms}"
    assert walked_m >= 0.4, f"walked only {walked_m:.2f} m"


def _position(status: dict) -> np.ndarray:
    return np.array(status["base"]["position"][:2])


def test_stock_clients_on_cyclone_11_multicast_and_on_0_10_walk_the_sim(sdk_channels: int, robot) -> None:
    status, record = robot
    s0 = status.wait_ready()

    # cyclonedds 11 + the robot type fix + plain ChannelFactoryInitialize(d, "lo"): multicast discovery.
    # (The sim boots standing: walking from there.)
    lines = _run_stock_client(sys.executable, sdk_channels, "--type-fix", "walk")
    assert _step(lines, "connected")["codes"] == [0, 0]
    s1 = status.get()
    walked = float(np.linalg.norm(_position(s1) - _position(s0)))
    print(f"cyclonedds 11 stock client walked {walked:.2f} m")
    _check_walk(record, lines, walked, stood=False)

    # Cyclone 0.10.2 (the robot's) + the same SDK code: stand up, walk, arm_sdk, release, select + damp.
    lines = _run_stock_client(side_python(), sdk_channels, "stand", "walk", "arm", "release", "damp")
    s2 = status.get()
    assert s2["firmware"].get("falls", 0) == 0, s2["firmware"]
    walked = float(np.linalg.norm(_position(s2) - _position(s1)))
    print(f"Cyclone 0.10.2 stock client walked {walked:.2f} m")
    assert _step(lines, "stand") == {**_step(lines, "stand"), "code": 0, "static": 0}
    _check_walk(record, lines, walked, stood=True)
    t_arm0, t_arm1 = _step(lines, "walk")["t"], _step(lines, "arm")["t"]
    frames = [e for e in record.events(since=t_arm0) if e["k"] == "frame" and e["topic"] == "arm_sdk"
              and e["t"] <= t_arm1 + 0.1]
    accepted = [e for e in frames if e["ok"]]
    assert len(accepted) >= 90 and max(e["w"] for e in accepted) >= 0.99, f"{len(accepted)} arm_sdk frames accepted"
    assert _step(lines, "release")["check"] == {"form": "0", "name": ""}
    damp = _step(lines, "damp")
    assert (damp["select_code"], damp["damp_code"]) == (0, 0)
    last = states(record.events(since=_step(lines, "arm")["t"]))
    assert [s["svc"] for s in last][:1] == [""] and (last[-1]["fsm"], last[-1]["svc"]) == (1, "ai"), last
    time.sleep(0.2)
    assert status.get()["sport"]["fsm_id"] == 1


def test_unitree_loco_example_posture_options_behave_as_documented(sdk_channels: int, robot) -> None:
    """The G1 loco example's Lie2StandUp (the robot on its back, after a Damp) gets the robot up; a StandUp of
    the lying robot answers 0 and leaves it down; StandUp2Squat squats a standing robot (fsm 706)."""
    status, record = robot
    # the StandUp of the lying robot is watched for QUIET_WINDOW_S (something that must not happen); Start is
    # all the claim after the get-up needs (walking is the other test's)
    lines = _run_stock_client(sys.executable, sdk_channels, "--type-fix", f"--quiet-s={QUIET_WINDOW_S}",
                              "getup", "start", "stand", "squat")
    getup = _step(lines, "getup")
    assert getup["lying"], getup  # the IMU showed the robot on the floor before the StandUp
    assert (getup["stand_up_code"], getup["after_stand_up"]) == (0, 1), getup  # answered 0, stayed damped
    assert (getup["static"], getup["fsm"]) == (0, 702), getup
    seen = states(record.events(since=_step(lines, "connected")["t"]))
    fsms = [s["fsm"] for s in seen if s["t"] <= getup["t"]]
    assert 4 not in fsms and fsms[-1] == 702, fsms  # the StandUp never reached the controller's state
    started = [s["fsm"] for s in seen if getup["t"] < s["t"] <= _step(lines, "start")["t"]]
    assert 200 in started, started  # Start from the stand 702 left
    squat = _step(lines, "squat")
    assert (squat["static"], squat["fsm"]) == (0, 706), squat
    s = status.get()
    assert s["body"]["pelvis_z"] < 0.65 and s["body"]["posture"] == "upright", s["body"]
    assert s["firmware"].get("posture_ignored") == 1, s["firmware"]
