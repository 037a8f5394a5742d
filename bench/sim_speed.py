"""Speed of the simulated G1: physics steps per second and real-time factor of the full loop
(firmware + policy at 50 Hz + PD every 2 ms step), standing and walking, and plain MuJoCo stepping.

    flock /tmp/g1_sim_cpu.lock .venv/bin/python -m bench.sim_speed [--seconds 10]
"""

from __future__ import annotations

import argparse
import time

import mujoco

from g1_mode_manager.protocol.api_ids import MOVE_CONTINUOUS_DURATION_S
from g1_mode_manager.protocol.fsm import FsmId
from g1_sim.firmware import SimG1


def measure(sim: SimG1, seconds: float) -> tuple[float, float]:
    """(steps/s, real-time factor) of ``seconds`` of sim time."""
    n = round(seconds / sim.dt)
    t0 = time.perf_counter()
    sim.step(n)
    wall = time.perf_counter() - t0
    return n / wall, seconds / wall


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="sim seconds per measurement")
    args = parser.parse_args(argv)

    t0 = time.perf_counter()
    sim = SimG1()
    print(f"SimG1() first construction (model compile + policy load): {time.perf_counter() - t0:.2f} s")

    rate, rtf = measure(sim, args.seconds)
    print(f"stand (policy, fsm 4):        {rate:8.0f} steps/s  {rtf:5.1f}x real time")
    sim.set_fsm_id(FsmId.START)
    sim.set_velocity(0.5, 0.0, 0.0, MOVE_CONTINUOUS_DURATION_S)
    rate, rtf = measure(sim, args.seconds)
    print(f"walk 0.5 m/s (policy, 500):   {rate:8.0f} steps/s  {rtf:5.1f}x real time")

    sim.set_fsm_id(FsmId.DAMP)
    rate, rtf = measure(sim, args.seconds)
    print(f"damp (no policy):             {rate:8.0f} steps/s  {rtf:5.1f}x real time")

    data = mujoco.MjData(sim.model)
    mujoco.mj_resetDataKeyframe(sim.model, data, 0)
    n = round(args.seconds / sim.dt)
    t0 = time.perf_counter()
    for _ in range(n):
        mujoco.mj_step(sim.model, data)
    wall = time.perf_counter() - t0
    print(f"plain mj_step (no control):   {n / wall:8.0f} steps/s  {args.seconds / wall:5.1f}x real time")

    policy = sim._loco.policy
    q, dq = sim.lowstate().q, sim.lowstate().dq
    quat, gyro = sim.base_pose().quaternion, sim.lowstate().imu_gyroscope
    t0 = time.perf_counter()
    for _ in range(500):
        policy.act(q, dq, quat, gyro, (0.5, 0.0, 0.0))
    print(f"policy inference:             {(time.perf_counter() - t0) / 500 * 1e3:8.3f} ms")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
