"""Measure the simulated G1's poses that core/posture.py's limits come from, and how each one reads.

Runs the sim in this process (no DDS) through the flows a posture verb meets: standing, walking, 706 down and
its squat, squat (2) and sit (3), damping from standing (the fall onto the back) and from the squat, a push
then damping (onto the front), the gantry damped and in zero torque, 702's get-up, and the two postures the sim
can boot in (folded in the squat, until the damped fold tips forward, and lying on its back). Prints a markdown table
(docs/posture.md) or, with ``--fixture``, the poses as Python for test/fakes/posture_poses.py. It loads MuJoCo
and steps physics for about a minute: run it under the sim CPU lock.

    flock /tmp/g1_sim_cpu.lock .venv/bin/python scripts/measure_postures.py [--fixture]
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import dataclass

from g1_mode_manager.core.posture import read_posture
from g1_mode_manager.protocol.fsm import FsmId
from g1_sim.firmware import SimG1


@dataclass(frozen=True)
class Measured:
    name: str
    flow: str
    fsm: int
    fsm_mode: int
    q: tuple[float, ...]
    quaternion: tuple[float, float, float, float]
    height_m: float

    @property
    def limp(self) -> bool:
        return self.fsm in (FsmId.DAMP, FsmId.ZERO_TORQUE)


def _run(sim: SimG1, seconds: float) -> None:
    sim.step(round(seconds / sim.dt))


def _take(sim: SimG1, name: str, flow: str) -> Measured:
    state = sim.lowstate()
    return Measured(name, flow, sim.get_fsm_id()[1], sim.get_fsm_mode()[1], tuple(round(float(v), 4) for v in state.q),
                    tuple(round(float(v), 5) for v in state.imu_quaternion),  # type: ignore[arg-type]
                    round(float(sim.base_pose().position[2]), 3))


def _flows() -> list[tuple[str, Callable[[], list[Measured]]]]:
    def standing() -> list[Measured]:
        sim = SimG1()
        _run(sim, 2.0)
        taken = [_take(sim, "standing", "boot in lock stand (fsm 4), 2 s")]
        sim.set_fsm_id(FsmId.START)
        _run(sim, 1.0)
        sim.set_velocity(1.0, 0.0, 0.0, 4.0)
        _run(sim, 2.0)
        taken.append(_take(sim, "walking", "start (500), then 1 m/s for 2 s"))
        return taken

    def squat_706() -> list[Measured]:
        sim = SimG1()
        _run(sim, 1.0)
        sim.set_fsm_id(FsmId.SQUAT_TO_STAND)
        _run(sim, 1.2)
        taken = [_take(sim, "squatting_down", "standing, 706 (StandUp2Squat), 1.2 s in")]
        _run(sim, 2.0)
        taken.append(_take(sim, "squatting_706", "standing, 706, 3.2 s"))
        sim.set_fsm_id(FsmId.DAMP)
        _run(sim, 3.0)
        taken.append(_take(sim, "squatting_damped", "706's squat, then damp, 3 s"))
        sim.set_fsm_id(FsmId.SQUAT_TO_STAND)
        _run(sim, 1.0)
        taken.append(_take(sim, "standing_up_706", "the damped squat, 706 (Squat2StandUp), 1 s in"))
        return taken

    def squat_and_sit() -> list[Measured]:
        sim = SimG1()
        _run(sim, 1.0)
        sim.set_fsm_id(FsmId.SQUAT)
        _run(sim, 3.0)
        taken = [_take(sim, "squatting_fsm2", "standing, squat (2), 3 s")]
        sim.set_fsm_id(FsmId.SIT)
        _run(sim, 3.0)
        taken.append(_take(sim, "sitting", "squat (2), then sit (3), 3 s"))
        return taken

    def lying() -> list[Measured]:
        sim = SimG1()
        _run(sim, 0.5)
        sim.set_fsm_id(FsmId.DAMP)
        _run(sim, 0.3)
        taken = [_take(sim, "falling_damped", "standing, damp, 0.3 s")]
        _run(sim, 2.7)
        taken.append(_take(sim, "lying_back", "standing, damp, 3 s"))
        sim.set_fsm_id(FsmId.LIE_TO_STAND)
        _run(sim, 3.0)
        taken.append(_take(sim, "getting_up", "lying on the back, lie_to_stand (702), 3 s in"))
        _run(sim, 5.0)
        taken.append(_take(sim, "standing_702", "lying on the back, lie_to_stand (702), 8 s"))
        sim = SimG1()
        sim.push((120.0, 0.0), 0.3)
        _run(sim, 2.5)
        sim.set_fsm_id(FsmId.DAMP)
        _run(sim, 2.5)
        taken.append(_take(sim, "lying_front", "pushed forward 120 N x 0.3 s, damp, 2.5 s"))
        return taken

    def gantry() -> list[Measured]:
        sim = SimG1()
        _run(sim, 0.5)
        sim.set_gantry(True)
        _run(sim, 1.0)
        sim.set_fsm_id(FsmId.DAMP)
        _run(sim, 3.0)
        taken = [_take(sim, "gantry_damped", "in the gantry, damp, 3 s")]
        sim.set_fsm_id(FsmId.ZERO_TORQUE)
        _run(sim, 3.0)
        taken.append(_take(sim, "hanging", "in the gantry, damp, then zero torque, 3 s"))
        return taken

    def booted() -> list[Measured]:
        sim = SimG1(start_posture="squat")
        _run(sim, 4.0)
        taken = [_take(sim, "squatting_booted", "booted folded in the squat (damped), 4 s")]
        _run(sim, 8.0)
        taken.append(_take(sim, "lying_front_tipped", "booted folded, 12 s (the damped fold tips forward at 10.8 s)"))
        sim = SimG1(start_posture="lying")
        _run(sim, 2.0)
        taken.append(_take(sim, "lying_back_booted", "booted lying on its back (damped), 2 s"))
        return taken

    return [("standing", standing), ("706", squat_706), ("2 and 3", squat_and_sit), ("lying", lying),
            ("gantry", gantry), ("booted", booted)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    parser.add_argument("--fixture", action="store_true", help="print the poses as Python (test/fakes/posture_poses.py)")
    args = parser.parse_args(argv)
    poses = [m for _name, flow in _flows() for m in flow()]
    if args.fixture:
        for m in poses:
            print(f"    # {m.flow}: fsm {m.fsm} (fsm_mode {m.fsm_mode}), pelvis {m.height_m:.3f} m")
            print(f'    "{m.name}": Pose(')
            for first, end in ((0, 6), (6, 12), (12, 15), (15, 22), (22, 29)):  # legs, waist, arms
                print(f"        {'q=(' if first == 0 else '   '}{', '.join(map(str, m.q[first:end]))}"
                      + ("," if end < 29 else "),"))
            print(f"        quaternion={m.quaternion!r}, height_m={m.height_m!r}, limp={m.limp!r}),")
        return 0
    print("| pose | how | fsm | pelvis m | tilt rad | knees rad | hips rad | reads as |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for m in poses:
        reading = read_posture(m.q, m.quaternion, limp=m.limp)
        knees, hips = f"{m.q[3]:.2f} / {m.q[9]:.2f}", f"{m.q[0]:.2f} / {m.q[6]:.2f}"
        print(f"| {m.name} | {m.flow} | {m.fsm} ({m.fsm_mode}) | {m.height_m:.2f} | {reading.tilt_rad:.2f} | {knees} "
              f"| {hips} | {reading.posture.value} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
