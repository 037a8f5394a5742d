"""Does the simulated G1 keep its balance while rt/arm_sdk moves the upper body? A fall-rate table.

Every case plays Unitree's stock arm_sdk program on :class:`SimG1` directly (no DDS): weight 1 at
once with targets = the measured pose, then over 6 s to the arm pose, held 1 s, back over 6 s, and
the weight ramped out over 3 s; kp 60, kd 1.5 on all 17 upper-body motors, 50 Hz. The grid is arm
poses x (fsm, command): lock stand (4), squat-to-stand (706) and walking (500) at several commands.

    flock /tmp/g1_sim_cpu.lock nice -n 10 .venv/bin/python -m bench.arm_balance [--markdown]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from typing import Final

import numpy as np

from g1_mode_manager.protocol.api_ids import MOVE_CONTINUOUS_DURATION_S, OK
from g1_mode_manager.protocol.fsm import FsmId
from g1_mode_manager.protocol.motors import ARM_SDK_JOINTS, JOINT_INDEX
from g1_sim.firmware import SimG1

KP: Final = 60.0
KD: Final = 1.5
RATE_HZ: Final = 50
MOVE_S: Final = 6.0
HOLD_S: Final = 1.0
RAMP_OUT_S: Final = 3.0
#: Watched after the program ends (weight 0): a robot that lets go of a lean falls within ~1.5 s.
SETTLE_S: Final = 3.0
#: A case counts as a fall when the pelvis drops below this (it stands at ~0.76 m, walks at ~0.72 m).
FALL_Z_M: Final = 0.6


def _slot(joint: str) -> int:
    return JOINT_INDEX[f"{joint}_joint"] - ARM_SDK_JOINTS[0]


def arm_pose(**joints: float) -> dict[int, float]:
    """Targets for some of the 17 arm_sdk slots by joint name (others keep their measured start)."""
    return {_slot(name): value for name, value in joints.items()}


#: The reference (arms out sideways, elbows bent) and extremes of shoulder pitch/roll, elbows, waist.
POSES: Final[dict[str, dict[int, float]]] = {
    "reference: arms out, elbows 90": arm_pose(
        left_shoulder_roll=np.pi / 2, right_shoulder_roll=-np.pi / 2, left_elbow=np.pi / 2,
        right_elbow=np.pi / 2, waist_yaw=0.0, waist_roll=0.0, waist_pitch=0.0),
    "arms forward (pitch -1.6)": arm_pose(
        left_shoulder_pitch=-1.6, right_shoulder_pitch=-1.6, left_elbow=0.0, right_elbow=0.0, waist_yaw=0.0),
    "arms overhead (pitch -2.9)": arm_pose(
        left_shoulder_pitch=-2.9, right_shoulder_pitch=-2.9, left_elbow=0.0, right_elbow=0.0, waist_yaw=0.0),
    "arms back (pitch +1.2)": arm_pose(
        left_shoulder_pitch=1.2, right_shoulder_pitch=1.2, left_elbow=0.3, right_elbow=0.3, waist_yaw=0.0),
    "one fwd one back": arm_pose(
        left_shoulder_pitch=-1.6, right_shoulder_pitch=1.2, left_elbow=0.0, right_elbow=0.0, waist_yaw=0.0),
    "arms up sideways (roll +/-2.2)": arm_pose(
        left_shoulder_roll=2.2, right_shoulder_roll=-2.2, left_elbow=0.0, right_elbow=0.0, waist_yaw=0.0),
    "elbows 2.0": arm_pose(left_elbow=2.0, right_elbow=2.0, waist_yaw=0.0),
    "waist yaw +1.5, arms out": arm_pose(
        waist_yaw=1.5, left_shoulder_roll=np.pi / 2, right_shoulder_roll=-np.pi / 2),
    "waist yaw -1.5": arm_pose(waist_yaw=-1.5),
}


@dataclass(frozen=True)
class Case:
    label: str
    fsm: int
    command: tuple[float, float, float] = (0.0, 0.0, 0.0)


CASES: Final = (
    Case("fsm 4 stand", FsmId.STAND_UP),
    Case("fsm 706 stand", FsmId.SQUAT_TO_STAND),
    Case("500 vx 0", FsmId.START),
    Case("500 vx 0.3", FsmId.START, (0.3, 0.0, 0.0)),
    Case("500 vx 0.5", FsmId.START, (0.5, 0.0, 0.0)),
    Case("500 vy 0.3", FsmId.START, (0.0, 0.3, 0.0)),
    Case("500 yaw 0.5", FsmId.START, (0.0, 0.0, 0.5)),
)


def enter(sim: SimG1, case: Case) -> None:
    """Bring a freshly booted sim (lock stand) into the case's fsm and command, then let it settle."""
    steps = round(1.0 / sim.dt)
    if case.fsm == FsmId.SQUAT_TO_STAND:
        assert sim.set_fsm_id(FsmId.SQUAT) == OK  # from a squat: damped, the robot would lie, and 706 not lift it
        sim.step(round(3.0 / sim.dt))
        assert sim.set_fsm_id(FsmId.SQUAT_TO_STAND) == OK
        while not sim.standing_balanced:
            sim.step(steps // 10)
    elif case.fsm != FsmId.STAND_UP:
        assert sim.set_fsm_id(case.fsm) == OK
        if any(case.command):
            assert sim.set_velocity(*case.command, MOVE_CONTINUOUS_DURATION_S) == OK
    sim.step(2 * steps)


def play_reference(sim: SimG1, pose: dict[int, float]) -> tuple[float, float]:
    """Unitree's arm_sdk program towards ``pose``; return the lowest pelvis height seen (m) and the walking
    torso stabiliser's largest torque (N m; see LocomotionController)."""
    n = len(ARM_SDK_JOINTS)
    start = sim.lowstate().q[list(ARM_SDK_JOINTS)].copy()
    goal = start.copy()
    for slot, value in pose.items():
        goal[slot] = value
    zeros, kp, kd = np.zeros(n), np.full(n, KP), np.full(n, KD)
    per_frame = round(1.0 / (RATE_HZ * sim.dt))
    lowest = float(sim.base_pose().position[2])
    assist = 0.0

    def frames(seconds: float):
        for i in range(round(seconds * RATE_HZ)):
            yield (i + 1) / (seconds * RATE_HZ)

    def send(q: np.ndarray, weight: float) -> None:
        nonlocal lowest, assist
        sim.apply_arm_sdk(q, zeros, zeros, kp, kd, weight)
        for _ in range(per_frame):
            sim.step(1)
            assist = max(assist, sim.walk_assist_nm)
        lowest = min(lowest, float(sim.base_pose().position[2]))

    for a in frames(MOVE_S):
        send(start + a * (goal - start), 1.0)
    for _ in frames(HOLD_S):
        send(goal, 1.0)
    for a in frames(MOVE_S):
        send(goal + a * (start - goal), 1.0)
    for a in frames(RAMP_OUT_S):
        send(start, 1.0 - a)
    return lowest, assist


def run_case(pose: dict[int, float], case: Case) -> tuple[bool, float, float]:
    """(fell, lowest pelvis height in m, the stabiliser's largest torque in N m) of one pose in one case,
    on a fresh sim."""
    sim = SimG1()
    enter(sim, case)
    lowest, assist = play_reference(sim, pose)
    sim.step(round(SETTLE_S / sim.dt))
    lowest = min(lowest, float(sim.base_pose().position[2]))
    return lowest < FALL_Z_M or sim.fallen, lowest, assist


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", nargs="*", help="substrings of pose names to run (default all)")
    parser.add_argument("--cases", nargs="*", help="substrings of case labels to run (default all)")
    args = parser.parse_args(argv)
    poses = {k: v for k, v in POSES.items() if not args.poses or any(p in k for p in args.poses)}
    cases = [c for c in CASES if not args.cases or any(p in c.label for p in args.cases)]

    t0 = time.perf_counter()
    print("| arm pose | " + " | ".join(c.label for c in cases) + " |")
    print("|---|" + "---|" * len(cases))
    falls = 0
    for name, pose in poses.items():
        cells = []
        for case in cases:
            fell, lowest, assist = run_case(pose, case)
            falls += fell
            cells.append(f"{'FALL' if fell else 'ok'} {lowest:.2f}" + (f" ({assist:.0f})" if assist > 0.0 else ""))
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
    total = len(poses) * len(cases)
    print(f"\nfalls: {falls}/{total} ({100.0 * falls / total:.0f} %); cells: outcome and lowest pelvis z (m), "
          "in brackets the walking torso stabiliser's largest torque (N m, capped at 35); "
          f"{time.perf_counter() - t0:.0f} s wall")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
