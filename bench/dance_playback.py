"""A tracking policy played on the sim's own MuJoCo model with no DDS, no node and no latency: the physical limit of
this pipeline. The node's own controller (``policy/``, loaded as the node loads it) steps at its rate on the state
of the physics step it is computed at, and its targets act from that very step, the motors' PD law at every physics
step (zero-order hold), as the sim applies a frame. What the node adds (a state sample's age, the loop's timing,
DDS both ways) is what ``bench.dance`` measures beside this.

Flow as the node's: the robot stands in the sim's standing keyframe, the ready pose held under the ready gains for
``--ready-s``, then the policy (its start hold, then the clip) to the clip's end plus ``--after-s``. With
``--from-walker S`` the robot starts as the node starts it: the sim's own walker walks it S s at 0.4 m/s and stands it
2 s, then the engage's blend (0.5 s) takes it to the ready pose.

    .venv/bin/python -m bench.dance_playback [--policy dance_fastsac] [--runs 1] [--latency-ms 0]

Prints one ``PLAYBACK key=value ...`` line a run: played (the clip's share), fell and when (s after the policy
started), the RMS joint error against the clip's reference (median, max over the policy's ticks), the lowest pelvis
height, the largest torso tilt, and the targets past a joint's range + the frame check's margin (how many ticks, the
most), which ``--clamp`` clamps as the node's loop does, and what the node's joint-speed and spin checks would have
done at their rate on the same motion (``core/body/motion_allowance.py``, the checks' own thresholds and debounce):
how many times each would have tripped, the first trip, and the largest speed over a joint's bound.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from g1_mode_manager.core.body.checks import BY_NAME as CHECKS
from g1_mode_manager.core.body.motion_allowance import NO_ALLOWANCE, MotionRecord
from g1_mode_manager.core.controller.interface import Command, RobotState
from g1_mode_manager.core.joint_commands import RANGE_MARGIN_RAD
from g1_mode_manager.core.user_ctrl import UserCtrlConfig
from g1_mode_manager.node.settings import POLICY_MODELS
from g1_mode_manager.policy.loader import load_policy
from g1_mode_manager.policy.motion_tracking import MotionTrackingController
from g1_mode_manager.protocol.motors import JOINT_NAMES, JOINT_RANGE_RAD, NUM_JOINTS
from g1_sim.physics.controllers import LocomotionController, Sensed, pd
from g1_sim.physics.model import QPOS0, QVEL0, TIMESTEP_S, G1Model, build_model
from g1_sim.physics.policy import LocomotionPolicy

#: Fallen: the pelvis below this height, m, or the body's z axis this far from vertical, rad (terminations.hpp).
FALLEN_Z_M = 0.4
FALLEN_TILT_RAD = 1.0
#: The sim's own walker (its walk-run controller's model) and the node's engage blend (policy_blend_s), s.
WALKER_MODEL = "ppo_g1_29dof.onnx"
BLEND_S = 0.5
#: The user-control entry's hand-over frame holds the robot this long before the blend begins, s (the switch and its
#: fsm 1000 seen; the sim's user_ctrl_delay_s is 0.05 of sim time).
HAND_OVER_S = 0.1
#: The body watch's rate in the node (body_check_rate_hz), Hz.
BODY_CHECK_HZ = 100.0
_LOW = np.array([r[0] for r in JOINT_RANGE_RAD]) - RANGE_MARGIN_RAD
_HIGH = np.array([r[1] for r in JOINT_RANGE_RAD]) + RANGE_MARGIN_RAD


@dataclass
class Playback:
    policy: str
    played: float = 0.0
    fell_at_s: float | None = None
    errors: list[float] = field(default_factory=list)
    lowest_z: float = 9.0
    worst_tilt: float = 0.0
    past_stops: int = 0  # ticks with a target past a joint's range + margin
    past_by: float = 0.0  # the most past, rad
    past_joint: str = ""
    past_run: int = 0  # the most ticks in a row one joint's target stayed past its range + margin
    first_past: str = ""  # when (s after the policy started) and which joint's target first went past
    speed_over_ref: float = 0.0  # the largest |dq| - |reference dq| over the ticks, rad/s
    speed: float = 0.0  # the largest |dq|, rad/s
    trips: dict[str, int] = field(default_factory=lambda: {"joint_speed": 0, "spin": 0})  # what the checks would do
    first_trip: str = ""
    over_bound: float = float("-inf")  # the largest |dq| less its joint's bound at a check, rad/s
    over_bound_at: str = ""

    def line(self) -> str:
        med = statistics.median(self.errors) if self.errors else float("nan")
        fell = "none" if self.fell_at_s is None else f"{self.fell_at_s:.2f}"
        return (f"PLAYBACK policy={self.policy} played_pct={100 * self.played:.1f} fell_at_s={fell} "
                f"rms_err_median={med:.3f} rms_err_max={max(self.errors, default=float('nan')):.3f} "
                f"lowest_pelvis_z={self.lowest_z:.3f} max_tilt={self.worst_tilt:.3f} past_stop_ticks={self.past_stops} "
                f"past_stop_most={self.past_by:.3f} past_stop_joint={self.past_joint or '-'} past_stop_run={self.past_run} "
                f"first_past={self.first_past or '-'} "
                f"max_dq={self.speed:.2f} max_dq_over_reference={self.speed_over_ref:.2f} "
                f"joint_speed_trips={self.trips['joint_speed']} spin_trips={self.trips['spin']} "
                f"first_trip={self.first_trip or '-'} most_over_bound={self.over_bound:.2f}:{self.over_bound_at or '-'}")


class CheckReplica:
    """The node's joint-speed and spin checks at the body watch's rate on the playback's state, judged less what the
    motion allows as the node judges them (the product's MotionRecord on the playback's clock)."""

    def __init__(self, out: Playback, clock: list[float]) -> None:
        self._out = out
        self._clock = clock
        self._checks = (CHECKS["joint_speed"], CHECKS["spin"])
        self.record = MotionRecord(CHECKS["joint_speed"].threshold, CHECKS["spin"].threshold, clock=lambda: clock[0])
        self._above_since: dict[str, float | None] = {"joint_speed": None, "spin": None}
        self._tripped: dict[str, bool] = {"joint_speed": False, "spin": False}

    def step(self, dq: np.ndarray, gyro: np.ndarray) -> None:
        now, out = self._clock[0], self._out
        allowed = self.record.current() or NO_ALLOWANCE
        joint_base = CHECKS["joint_speed"].threshold
        judged_joints = np.abs(dq) - np.asarray(allowed.joints)
        worst = int(np.argmax(judged_joints))
        if judged_joints[worst] - joint_base > out.over_bound:
            out.over_bound = float(judged_joints[worst] - joint_base)
            out.over_bound_at = f"{now:.2f}s:{JOINT_NAMES[worst]}:{abs(dq[worst]):.2f}"
        values = {"joint_speed": float(judged_joints[worst]),
                  "spin": float(np.max(np.abs(gyro) - np.asarray(allowed.spin)))}
        for check in self._checks:
            if not check.trips(values[check.name]):
                self._above_since[check.name], self._tripped[check.name] = None, False
                continue
            since = self._above_since[check.name]
            if since is None:
                self._above_since[check.name] = since = now
            if now - since >= check.debounce_s - 1e-9 and not self._tripped[check.name]:
                self._tripped[check.name] = True
                out.trips[check.name] += 1
                if not out.first_trip:
                    where = f":{JOINT_NAMES[worst]}" if check.name == "joint_speed" else ""
                    out.first_trip = f"{now:.2f}s:{check.name}{where}:{values[check.name]:.2f}"


def _tilt(quat_wxyz: np.ndarray) -> float:
    _, x, y, _ = quat_wxyz / np.linalg.norm(quat_wxyz)
    return float(np.arccos(np.clip(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0)))


def _from_walker(g1: G1Model, data: mujoco.MjData, walk_s: float, ready_q: np.ndarray, ready_kp: np.ndarray,
                 ready_kd: np.ndarray) -> None:
    """The robot as the node finds it: the sim's walker walks it ``walk_s`` at 0.4 m/s and stands it 2 s; the
    user-control entry holds the measured pose (its hand-over frame, ``HAND_OVER_S``), then the engage's blend
    (0.5 s) takes it to the ready pose under the ready gains, one frame per 50 Hz tick, as the node's loop sends it."""
    s = Sensed(g1, data)
    walker = LocomotionController(LocomotionPolicy(Path(sys.prefix) / POLICY_MODELS / WALKER_MODEL))
    walker.reset(s)
    for k in range(round((walk_s + 2.0) / TIMESTEP_S)):
        walker.command[:] = (0.4, 0.0, 0.0) if k * TIMESTEP_S < walk_s else 0.0
        data.ctrl[:NUM_JOINTS] = walker.torques(s)
        mujoco.mj_step(g1.model, data)
    zeros, hold = np.zeros(NUM_JOINTS), s.q.copy()
    kp, kd = np.full(NUM_JOINTS, UserCtrlConfig.hold_kp), np.full(NUM_JOINTS, UserCtrlConfig.hold_kd)
    for _ in range(round(HAND_OVER_S / TIMESTEP_S)):
        data.ctrl[:NUM_JOINTS] = pd(hold, zeros, zeros, kp, kd, s.q, s.dq)
        mujoco.mj_step(g1.model, data)
    start, ticks, per_tick = s.q.copy(), round(BLEND_S * 50), round(0.02 / TIMESTEP_S)
    for tick in range(ticks):
        target = start + (tick + 1) / ticks * (ready_q - start)
        for _ in range(per_tick):
            data.ctrl[:NUM_JOINTS] = pd(target, zeros, zeros, ready_kp, ready_kd, s.q, s.dq)
            mujoco.mj_step(g1.model, data)


def play(policy: str, *, latency_ms: float = 0.0, ready_s: float = 1.0, after_s: float = 1.0,
         clamp: bool = False, seconds: float | None = None, seed: int = 0, from_walker_s: float | None = None
         ) -> Playback:
    g1 = build_model()
    model, data = g1.model, mujoco.MjData(g1.model)
    g1.reset(data)
    rng = np.random.default_rng(seed)
    data.qvel[QVEL0:QVEL0 + NUM_JOINTS] += rng.normal(0.0, 1e-3, NUM_JOINTS)  # runs differ as runs on the sim do
    controller = load_policy(policy, Path(sys.prefix) / POLICY_MODELS)
    if not isinstance(controller, MotionTrackingController):
        raise SystemExit(f"{policy} is not a tracking policy")
    ready = controller.ready()
    if from_walker_s is not None:
        _from_walker(g1, data, from_walker_s, ready.q, ready.kp, ready.kd)
        ready_s = 0.0
    per_tick = round(1.0 / (controller.rate_hz * TIMESTEP_S))
    delay = round(latency_ms * 1e-3 / TIMESTEP_S)
    gyro = g1.gyro_adr
    q, dq = data.qpos[QPOS0:QPOS0 + NUM_JOINTS], data.qvel[QVEL0:QVEL0 + NUM_JOINTS]
    out = Playback(policy)
    zeros = np.zeros(NUM_JOINTS)
    command = (ready.q, zeros, zeros, ready.kp, ready.kd)
    pending: list[tuple[int, tuple[np.ndarray, ...]]] = []
    runs = np.zeros(NUM_JOINTS, dtype=int)
    clock = [0.0]  # s since the policy started: the checks' replica's clock
    checks = CheckReplica(out, clock)
    check_every = round(1.0 / (BODY_CHECK_HZ * TIMESTEP_S))
    ready_steps = round(ready_s / TIMESTEP_S)
    total = controller.motion_steps / controller.rate_hz + controller.start_hold_s
    end = ready_steps + round((seconds if seconds is not None else total + after_s) / TIMESTEP_S)
    for step in range(end):
        if step >= ready_steps and (step - ready_steps) % per_tick == 0:
            state = RobotState.of(q.copy(), dq.copy(), data.qpos[3:7].copy(), data.sensordata[gyro:gyro + 3].copy(),
                                  0.0)
            if step == ready_steps:
                controller.activate(state)
            clock[0] = (step - ready_steps) * TIMESTEP_S
            targets = controller.step(state, Command())
            checks.record.note(*controller.reference_speeds())
            reference = controller.reference()
            out.errors.append(float(np.sqrt(np.mean((state.q - reference) ** 2))))
            over = np.maximum(targets.q - _HIGH, _LOW - targets.q)
            runs = np.where(over > 0.0, runs + 1, 0)
            if over.max() > 0.0 and not out.first_past:
                joint = int(np.argmax(over))
                out.first_past = f"{(step - ready_steps) * TIMESTEP_S:.2f}s:{JOINT_NAMES[joint]}:{targets.q[joint]:.3f}"
            out.past_run = max(out.past_run, int(runs.max()))
            if over.max() > 0.0:
                out.past_stops += 1
                if over.max() > out.past_by:
                    out.past_by, out.past_joint = float(over.max()), JOINT_NAMES[int(np.argmax(over))]
            target_q = np.clip(targets.q, _LOW, _HIGH) if clamp else targets.q
            ref_dq = controller.reference_dq
            out.speed = max(out.speed, float(np.abs(state.dq).max()))
            out.speed_over_ref = max(out.speed_over_ref, float((np.abs(state.dq) - np.abs(ref_dq)).max()))
            pending.append((step + delay, (target_q, targets.dq, targets.tau, targets.kp, targets.kd)))
            out.played = controller.progress() or 0.0
        while pending and pending[0][0] <= step:
            command = pending.pop(0)[1]
        data.ctrl[:NUM_JOINTS] = pd(*command, q, dq)
        mujoco.mj_step(model, data)
        z, tilt = float(data.qpos[2]), _tilt(data.qpos[3:7])
        if step >= ready_steps and step % check_every == 0:
            clock[0] = (step - ready_steps) * TIMESTEP_S
            checks.step(dq, data.sensordata[gyro:gyro + 3])
        if step >= ready_steps:
            out.lowest_z, out.worst_tilt = min(out.lowest_z, z), max(out.worst_tilt, tilt)
        if z < FALLEN_Z_M or tilt > FALLEN_TILT_RAD:
            out.fell_at_s = (step - ready_steps) * TIMESTEP_S
            break
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="bench.dance_playback", description=__doc__.split("\n\n")[0])
    parser.add_argument("--policy", default="dance_fastsac", help="a built-in name or a deploy config's path")
    parser.add_argument("--runs", type=int, default=1, help="runs, each with its own seed (0, 1, ...)")
    parser.add_argument("--latency-ms", type=float, default=0.0, help="a target acts this long after its state")
    parser.add_argument("--ready-s", type=float, default=1.0, help="the ready pose held this long first, s")
    parser.add_argument("--seconds", type=float, default=None, help="stop this long after the policy starts, s")
    parser.add_argument("--clamp", action="store_true", help="clamp targets into range + margin (the node's loop)")
    parser.add_argument("--from-walker", type=float, default=None, metavar="S",
                        help="start as the node does: the sim's walker walks S s, stands 2 s, then the engage's blend")
    args = parser.parse_args(argv)
    for seed in range(args.runs):
        print(play(args.policy, latency_ms=args.latency_ms, ready_s=args.ready_s, clamp=args.clamp,
                   seconds=args.seconds, seed=seed, from_walker_s=args.from_walker).line(), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
