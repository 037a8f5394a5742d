"""Torque controllers of the simulated G1: each a small object the firmware swaps in and out.

Every controller is called once per physics step with the same :class:`Sensed` view and returns 29
motor torques (motor order, N m, clipped to the G1 effort limits). Controllers that run slower (the
policy at 50 Hz) count steps themselves, so the physics loop stays one tight, uniform loop.
"""

from __future__ import annotations

from typing import Final, Protocol

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from g1_mode_manager.protocol.motors import ARM_SDK_JOINTS, DAMPING_KD, NUM_JOINTS
from g1_sim.physics.model import DEFAULT_POSE, EFFORT_LIMIT, QPOS0, QVEL0, TIMESTEP_S, G1Model
from g1_sim.physics.policy import RATE_HZ, LocomotionPolicy

ARM0: Final = ARM_SDK_JOINTS[0]
#: The ankles' pitch and roll motors of both legs, motor order, and the share of the stance's integral gain they get.
ANKLES: Final = (4, 5, 10, 11)
ANKLE_INTEGRAL_SHARE: Final = 0.2
#: First arm motor (left shoulder pitch); arm_sdk also drives the three waist motors before it.
ARM_SDK_FIRST_ARM_JOINT: Final = ARM0 + 3
N_ARM: Final = len(ARM_SDK_JOINTS)
GRAVITY: Final = 9.81


class Sensed:
    """Live views into MjData (no copies): what the robot's own sensors and encoders would give."""

    def __init__(self, g1: G1Model, data: mujoco.MjData) -> None:
        self.g1 = g1
        self.data = data
        self.q = data.qpos[QPOS0 : QPOS0 + NUM_JOINTS]
        self.dq = data.qvel[QVEL0 : QVEL0 + NUM_JOINTS]
        self.pos = data.qpos[0:3]
        self.quat = data.qpos[3:7]  # pelvis orientation, w x y z
        self.ang_vel_body = data.qvel[3:6]  # free joint angular velocity is in the body frame
        self.lin_vel_world = data.qvel[0:3]

    @property
    def time(self) -> float:
        return float(self.data.time)


class Controller(Protocol):
    def reset(self, s: Sensed) -> None:
        """Called when the controller takes over."""

    def torques(self, s: Sensed) -> np.ndarray:
        """Motor torques for this physics step."""

    def release(self, s: Sensed) -> None:
        """Called when another controller takes over (undo any side effects on the model)."""


def pd(q_des: np.ndarray, dq_des: np.ndarray, tau_ff: np.ndarray, kp: np.ndarray, kd: np.ndarray,
       q: np.ndarray, dq: np.ndarray, limit: np.ndarray = EFFORT_LIMIT) -> np.ndarray:
    """The G1 motor driver law: tau + kp (q_des - q) + kd (dq_des - dq), clipped to the effort limits."""
    return np.clip(tau_ff + kp * (q_des - q) + kd * (dq_des - dq), -limit, limit)


class ZeroTorqueController:
    """fsm 0 and debug mode without commands: every motor limp, the robot falls."""

    def __init__(self) -> None:
        self._zero = np.zeros(NUM_JOINTS)

    def reset(self, s: Sensed) -> None:
        pass

    def torques(self, s: Sensed) -> np.ndarray:
        return self._zero

    def release(self, s: Sensed) -> None:
        pass


class DampController:
    """fsm 1: kp 0, kd ~8 on every motor, so the robot sinks slowly instead of dropping."""

    def __init__(self, kd: float = DAMPING_KD) -> None:
        self.kd = kd

    def reset(self, s: Sensed) -> None:
        pass

    def torques(self, s: Sensed) -> np.ndarray:
        return np.clip(-self.kd * s.dq, -EFFORT_LIMIT, EFFORT_LIMIT)

    def release(self, s: Sensed) -> None:
        pass


#: The walking torso stabiliser under arm_sdk (LocomotionController): N m per unit of sin(tilt), N m s/rad,
#: and the cap, N m (m g x ~0.1 m: the centre of pressure moved by half a foot).
ASSIST_KP: Final = 300.0
ASSIST_KD: Final = 30.0
ASSIST_LIMIT_NM: Final = 35.0


class LocomotionController:
    """Balance stand and walking: the policy sets PD targets at 50 Hz; PD runs every physics step.

    ``command`` is (vx, vy, wz) in the body frame; zero means stand still. ``step_in_place`` keeps the
    gait running at zero command (continuous gait).

    While rt/arm_sdk drives the upper body (``arm_weight`` > 0), the policy is shown the arm and waist-yaw
    positions it was trained on, its own targets, instead of the measured ones: poses it never saw made
    it stumble and fall (``bench/arm_balance.py``; its counts are in docs/arm_balance.md). Waist roll
    and pitch stay measured (hiding them too made it worse: they tilt the torso, which the policy must
    know). The blend follows the weight, so ramps stay smooth.

    Also while arm_sdk drives the upper body, a **torso stabiliser** that is NOT the robot's: a torque on
    the pelvis (roll and pitch only, ``xfrc_applied``) that rights its tilt, scaled by the weight and capped
    at ASSIST_LIMIT_NM, about what moving the centre of pressure under the feet can give this robot. It
    stands in for what the real locomotion controller has and this policy lacks (training with upper-body
    perturbation: none ships in a wheel on PyPI). Without it walking cells of ``bench/arm_balance.py``
    fall (the waist turned 1.5 rad, arms overhead at 0.5 m/s; docs/arm_balance.md); the bench prints the
    peak torque each cell took. Walking without arm_sdk never gets it. ``assist_nm`` is the last torque.
    """

    def __init__(self, policy: LocomotionPolicy) -> None:
        self.policy = policy
        self.decimation = round(1.0 / (RATE_HZ * TIMESTEP_S))
        self.command = np.zeros(3)
        self.step_in_place = False
        self.targets = DEFAULT_POSE.copy()
        self.arm_weight = 0.0
        self.masked = np.r_[ARM0, ARM_SDK_FIRST_ARM_JOINT:NUM_JOINTS]  # waist yaw and both arms
        self.assist_nm = 0.0
        self._zeros = np.zeros(NUM_JOINTS)
        self._count = 0

    def reset(self, s: Sensed) -> None:
        self.policy.reset()
        self.command[:] = 0.0
        self.targets = DEFAULT_POSE.copy()
        self._count = 0

    def torques(self, s: Sensed) -> np.ndarray:
        if self._count % self.decimation == 0:
            q, dq = s.q, s.dq
            if self.arm_weight > 0.0:
                q, dq, w, m = q.copy(), dq.copy(), self.arm_weight, self.masked
                q[m] += w * (self.targets[m] - q[m])
                dq[m] *= 1.0 - w
            self.targets = self.policy.act(q, dq, s.quat, s.ang_vel_body, self.command,
                                           step_in_place=self.step_in_place)
        self._count += 1
        self._assist(s)
        return pd(self.targets, self._zeros, self._zeros, self.policy.kp, self.policy.kd, s.q, s.dq)

    def _assist(self, s: Sensed) -> None:
        """The torso stabiliser (see the class doc): on while arm_sdk has weight, else off."""
        pelvis = s.g1.pelvis_body
        if self.arm_weight <= 0.0:
            if self.assist_nm:
                s.data.xfrc_applied[pelvis, 3:6] = 0.0
                self.assist_nm = 0.0
            return
        up = s.data.xmat[pelvis].reshape(3, 3)[:, 2]
        omega = s.data.cvel[pelvis][:3]  # world frame
        torque = ASSIST_KP * np.cross(up, (0.0, 0.0, 1.0)) - ASSIST_KD * np.array((omega[0], omega[1], 0.0))
        norm = float(np.linalg.norm(torque))
        if norm > ASSIST_LIMIT_NM:
            torque *= ASSIST_LIMIT_NM / norm
        torque *= self.arm_weight
        s.data.xfrc_applied[pelvis, 3:6] = torque
        self.assist_nm = float(np.linalg.norm(torque))

    def release(self, s: Sensed) -> None:
        if self.assist_nm:
            s.data.xfrc_applied[s.g1.pelvis_body, 3:6] = 0.0
            self.assist_nm = 0.0


#: Lock-stand gains by motor (N m/rad, N m s/rad): stiff legs and waist, arms firm, wrists soft.
_STANCE_LEG_KP: Final = (350.0, 350.0, 250.0, 450.0, 500.0, 300.0)
_STANCE_LEG_KD: Final = (8.0, 8.0, 6.0, 10.0, 10.0, 6.0)
_STANCE_ARM_KP: Final = (80.0, 80.0, 80.0, 80.0, 20.0, 20.0, 20.0)
_STANCE_ARM_KD: Final = (2.0, 2.0, 2.0, 2.0, 1.0, 1.0, 1.0)
STANCE_KP: Final = np.array((*_STANCE_LEG_KP, *_STANCE_LEG_KP, 300.0, 300.0, 300.0, *_STANCE_ARM_KP, *_STANCE_ARM_KP))
STANCE_KD: Final = np.array((*_STANCE_LEG_KD, *_STANCE_LEG_KD, 6.0, 6.0, 6.0, *_STANCE_ARM_KD, *_STANCE_ARM_KD))


class StanceController:
    """Lock stand (fsm 4, and 702/706 once up): a stiff joint-position hold, as the robot's lock stand is.

    The legs keep the pose they had when the stance took over (feet stay where they are, no stepping),
    shifted along the knee-bend family of :class:`~g1_sim.physics.model.StandPoses` to the requested
    pelvis height; waist and arms go to the default pose. Targets move in a straight line at most ``rate`` rad/s, so a
    height change or a takeover from walking is smooth. A slow integral term on legs and waist removes
    the static error gravity leaves under PD, so the pelvis does not sag; a fifth of it on the ankles: they
    carry the body's sway over the feet (an inverted pendulum), and the full integral there lagged the sway
    and fed it, so a small sway (a push, or what a get-up leaves) grew until the robot fell
    (docs/arm_balance.md). Slower, it still takes the stand back to where it booted.
    Torques are clipped to the G1 effort limits.

    Balance (what a plain PD hold lacks when arm_sdk swings the upper body): the centre of mass is kept
    over the feet by leaning both legs about the ankles (ankle pitch/roll one way, hip pitch/roll the
    other, so pelvis and feet keep their orientation), an integrator on the horizontal error. Tuned with
    ``bench/arm_balance.py``: without it, arms raised forward at arm_sdk's kp 60 bend the waist and the
    robot tips over its toes. The servo runs only while ``balancing`` (the firmware sets it while arm_sdk
    moves the upper body): the plain hold stands still without it, and at straight knees (HighStand)
    the servo set up a slow rocking of its own. The lean also follows the centre of mass's velocity at once
    (``com_damping``, rad per m/s): the integrator alone let the body rock at ~1 Hz under a soft arm_sdk
    waist, and a lean frozen mid-swing when the weight reached 0 tipped it over backwards (arms overhead,
    fsm 4 and 706); with it the grid's stance cases hold for com_gain 1-3.
    """

    def __init__(self, g1: G1Model, *, kp: np.ndarray = STANCE_KP, kd: np.ndarray = STANCE_KD,
                 rate: float = 0.5, integral_per_s: float = 1.0, integral_share: float = 0.3,
                 com_gain: float = 2.0, lean_limit: float = 0.25, lead_s: float = 0.8, com_damping: float = 0.15) -> None:
        self.poses = g1.stand_poses
        self.kp = kp
        self.kd = kd
        self.rate = rate
        self.height = self.poses.default_height
        self._reference = self.poses.pose(self.poses.default_height)
        self._captured = DEFAULT_POSE.copy()
        self.q_des = DEFAULT_POSE.copy()
        self._goal: np.ndarray | None = None  # goal()'s, for _goal_height
        self._goal_height = self.height
        self._arrived = False  # q_des has reached _arrived_at
        self._arrived_at: np.ndarray | None = None
        self._zeros = np.zeros(NUM_JOINTS)
        self._ki = np.where(np.arange(NUM_JOINTS) < ARM0 + 3, integral_per_s * kp, 0.0)
        self._ki[list(ANKLES)] *= ANKLE_INTEGRAL_SHARE
        self._i_limit = integral_share * EFFORT_LIMIT
        self._i_term = np.zeros(NUM_JOINTS)
        self.com_gain = com_gain
        self.lead_s = lead_s
        self.lean_limit = lean_limit
        self.com_damping = com_damping
        self.lean = np.zeros(2)  # (forward, sideways) lean of the legs about the ankles, rad
        self.balancing = False
        #: rt/arm_sdk's weight on motors 12..28: their integral term winds only as far as the hold is in charge
        #: (else it winds up against the user's PD and throws the upper body when the weight ramps out).
        self.upper_weight = 0.0
        #: A built-in arm motion (arm tasks): targets of motors 12..28 and how much they replace the hold's.
        self.upper: tuple[np.ndarray, float] | None = None
        self._feet = [g1.model.body(f"{side}_ankle_roll_link").id for side in ("left", "right")]
        self._pelvis = g1.pelvis_body

    def reset(self, s: Sensed) -> None:
        self._captured = s.q.copy()
        self._captured[12:] = DEFAULT_POSE[12:]
        self._goal = None
        self._arrived = False
        self.q_des = s.q.copy()
        self._i_term[:] = 0.0
        self.lean[:] = 0.0

    def com_state(self, s: Sensed) -> tuple[np.ndarray, np.ndarray]:
        """The centre of mass's error, led by its velocity (``lead_s``; damps the servo), from its place over
        the feet (m), and its velocity (m/s); both in the pelvis heading frame (forward, left)."""
        d = s.data
        mujoco.mj_subtreeVel(s.g1.model, d)
        velocity = d.subtree_linvel[self._pelvis][:2]
        err = d.subtree_com[self._pelvis][:2] + self.lead_s * velocity
        err = err - 0.5 * (d.xpos[self._feet[0]][:2] + d.xpos[self._feet[1]][:2])
        heading = d.xmat[self._pelvis].reshape(3, 3)[:2, 0]
        c, si = heading / max(float(np.linalg.norm(heading)), 1e-9)
        to_heading = np.array(((c, si), (-si, c)))
        return to_heading @ err - (self.poses.com_ahead, 0.0), to_heading @ velocity

    def goal(self) -> np.ndarray:
        """The pose being held once the targets arrive: captured legs bent to :attr:`height` (read-only: kept
        until the height or the captured pose changes, as it is asked for at every step)."""
        if self._goal is None or self._goal_height != self.height:
            self._goal = self._captured + (self.poses.pose(self.height) - self._reference)
            self._goal.flags.writeable = False
            self._goal_height = self.height
        return self._goal

    def torques(self, s: Sensed) -> np.ndarray:
        goal = self.goal()
        if not self._arrived or goal is not self._arrived_at:
            delta = goal - self.q_des  # move along the straight line, so hip + knee + ankle stay balanced
            largest = float(np.abs(delta).max())
            self.q_des += delta * min(1.0, self.rate * TIMESTEP_S / max(largest, 1e-9))
            # once there the targets stay put until the goal changes: no need to measure the way at every step
            self._arrived, self._arrived_at = largest <= self.rate * TIMESTEP_S, goal
        lean = self.lean
        if self.balancing:
            err, velocity = self.com_state(s)
            self.lean = np.clip(self.lean + self.com_gain * err * TIMESTEP_S * (1.0, -1.0), -self.lean_limit,
                                self.lean_limit)
            lean = self.lean + self.com_damping * velocity * (1.0, -1.0)
        q_des = self.q_des.copy()
        q_des[[4, 10]] += lean[0]  # ankle pitch +: the legs lean back, the pelvis moves back
        q_des[[0, 6]] -= lean[0]
        q_des[[5, 11]] += lean[1]  # ankle roll +: the pelvis moves left
        q_des[[1, 7]] -= lean[1]
        if self.upper is not None:
            targets, weight = self.upper
            q_des[ARM0:] += weight * (targets - q_des[ARM0:])
        ki = self._ki
        if self.upper_weight > 0.0:
            ki = ki.copy()
            ki[ARM0:] *= 1.0 - self.upper_weight
        self._i_term = np.clip(self._i_term + ki * (q_des - s.q) * TIMESTEP_S, -self._i_limit, self._i_limit)
        return pd(q_des, self._zeros, self._i_term, self.kp, self.kd, s.q, s.dq)

    def release(self, s: Sensed) -> None:
        pass


def _smoothstep(x: float) -> float:
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


class PostureHarness:
    """Squat, sit and the stand-up motion, for which the policy has no skill.

    NOT the robot's real controller: a soft joint PD towards a posture plus a *virtual harness*, a
    spring-damper wrench on the pelvis (height, horizontal position, tilt; yaw is free) with gravity
    compensation, applied through ``xfrc_applied``. Pose and harness targets ramp from where the robot
    is to the goal over ``ramp_s``. ``pitch``: the pelvis's goal lean, rad, forward positive (upright by
    default). ``ahead``: the pelvis's goal place ahead of the feet's midpoint along its heading, m (None: it
    stays where it was). ``support`` (0..1) scales the harness, so it can be faded out.
    """

    def __init__(self, g1: G1Model, pose: np.ndarray, height: float, *, ramp_s: float = 2.0,
                 kp: np.ndarray | float = 120.0, kd: np.ndarray | float = 6.0, pitch: float = 0.0,
                 ahead: float | None = None) -> None:
        self.goal_pose = np.asarray(pose, dtype=float)
        self.goal_height = height
        self.goal_pitch = pitch
        self.goal_ahead = ahead
        self._feet = [g1.model.body(f"{side}_ankle_roll_link").id for side in ("left", "right")]
        self.ramp_s = ramp_s
        self.kp = np.broadcast_to(np.asarray(kp, dtype=float), (NUM_JOINTS,))
        self.kd = np.broadcast_to(np.asarray(kd, dtype=float), (NUM_JOINTS,))
        self.support = 1.0
        self._weight = float(g1.model.body_subtreemass[g1.pelvis_body]) * GRAVITY
        self._body = g1.pelvis_body
        self._zeros = np.zeros(NUM_JOINTS)
        self._t0 = 0.0
        self._q0 = DEFAULT_POSE.copy()
        self._z0 = height
        self._xy0 = np.zeros(2)
        self._xy_goal = np.zeros(2)
        self._up0 = np.array([0.0, 0.0, 1.0])
        self._up_goal = np.array([0.0, 0.0, 1.0])
        self._progress = 0.0
        self._elapsed = 0.0

    def reset(self, s: Sensed) -> None:
        self._t0 = s.time
        self._q0 = s.q.copy()
        self._z0 = float(s.pos[2])
        self._xy0 = s.pos[0:2].copy()
        rot = s.data.xmat[self._body].reshape(3, 3)
        self._up0 = rot[:, 2].copy()
        heading = rot[:2, 0] / max(float(np.linalg.norm(rot[:2, 0])), 1e-9)
        self._xy_goal = self._xy0.copy()
        if self.goal_ahead is not None:
            feet = 0.5 * (s.data.xpos[self._feet[0]][:2] + s.data.xpos[self._feet[1]][:2])
            self._xy_goal = feet + self.goal_ahead * heading
        self._up_goal = np.array((*(np.sin(self.goal_pitch) * heading), np.cos(self.goal_pitch)))
        self.support = 1.0

    @property
    def progress(self) -> float:
        """0 at the start of the ramp, 1 once the targets reached the goal."""
        return self._progress

    @property
    def elapsed(self) -> float:
        return self._elapsed

    def torques(self, s: Sensed) -> np.ndarray:
        self._elapsed = s.time - self._t0
        a = _smoothstep(self._elapsed / self.ramp_s) if self.ramp_s > 0 else 1.0
        self._progress = a
        self.apply_harness(s, a)
        q_des = self._q0 + a * (self.goal_pose - self._q0)
        return pd(q_des, self._zeros, self._zeros, self.kp, self.kd, s.q, s.dq)

    def apply_harness(self, s: Sensed, a: float) -> None:
        z_des = self._z0 + a * (self.goal_height - self._z0)
        up_des = self._up0 + a * (self._up_goal - self._up0)
        up_des /= np.linalg.norm(up_des)
        xy_des = self._xy0 + a * (self._xy_goal - self._xy0)
        v = s.lin_vel_world
        force = np.array([
            600.0 * (xy_des[0] - s.pos[0]) - 150.0 * v[0],
            600.0 * (xy_des[1] - s.pos[1]) - 150.0 * v[1],
            self._weight + 4000.0 * (z_des - s.pos[2]) - 500.0 * v[2],
        ])
        up = s.data.xmat[self._body].reshape(3, 3)[:, 2]
        omega_world = s.data.xmat[self._body].reshape(3, 3) @ s.ang_vel_body
        torque = 500.0 * np.cross(up, up_des) - 60.0 * omega_world
        torque[2] = -20.0 * omega_world[2]
        s.data.xfrc_applied[self._body, 0:3] = self.support * force
        s.data.xfrc_applied[self._body, 3:6] = self.support * torque

    def release(self, s: Sensed) -> None:
        s.data.xfrc_applied[self._body] = 0.0


class StandUpSequence:
    """fsm 4 (and 702/706) from damp, squat or sit: harness up to the standing pose, then hand over to
    ``then`` (the lock-stand hold) while the harness fades out. ``done`` once ``then`` stands alone."""

    def __init__(self, g1: G1Model, then: Controller, stand_height: float, *, ramp_s: float = 2.0,
                 hold_s: float = 0.5, fade_s: float = 0.6, kp: np.ndarray | float = 120.0,
                 kd: np.ndarray | float = 6.0) -> None:
        self.harness = PostureHarness(g1, DEFAULT_POSE, stand_height, ramp_s=ramp_s, kp=kp, kd=kd)
        self.then = then
        self.hold_s = hold_s
        self.fade_s = fade_s
        self.done = False
        self._t_then = 0.0
        self._on_then = False

    def reset(self, s: Sensed) -> None:
        self.harness.reset(s)
        self.done = False
        self._on_then = False

    def torques(self, s: Sensed) -> np.ndarray:
        if not self._on_then:
            tau = self.harness.torques(s)
            if self.harness.elapsed >= self.harness.ramp_s + self.hold_s:
                self._on_then = True
                self._t_then = s.time
                self.then.reset(s)
            return tau
        fade = 1.0 - (s.time - self._t_then) / self.fade_s
        if fade > 0.0:
            self.harness.support = fade
            self.harness.apply_harness(s, 1.0)
        elif not self.done:
            self.harness.release(s)
            self.done = True
        return self.then.torques(s)

    def release(self, s: Sensed) -> None:
        self.harness.release(s)


class LowLevelController:
    """Debug mode: per motor tau + kp (q_des - q) + kd (dq_des - dq) from the latest LowCmd; disabled
    motors (mode 0) and a robot that has received no LowCmd yet are limp. The last command is held."""

    def __init__(self) -> None:
        self.q = np.zeros(NUM_JOINTS)
        self.dq = np.zeros(NUM_JOINTS)
        self.tau = np.zeros(NUM_JOINTS)
        self.kp = np.zeros(NUM_JOINTS)
        self.kd = np.zeros(NUM_JOINTS)
        self.enabled = np.zeros(NUM_JOINTS, dtype=bool)

    def set_command(self, q: ArrayLike, dq: ArrayLike, tau: ArrayLike, kp: ArrayLike, kd: ArrayLike,
                    enabled: ArrayLike) -> None:
        self.q[:] = q
        self.dq[:] = dq
        self.tau[:] = tau
        self.kp[:] = kp
        self.kd[:] = kd
        self.enabled[:] = np.asarray(enabled, dtype=bool)

    def clear(self) -> None:
        self.set_command(0, 0, 0, 0, 0, False)

    def reset(self, s: Sensed) -> None:
        pass

    def torques(self, s: Sensed) -> np.ndarray:
        return np.where(self.enabled, pd(self.q, self.dq, self.tau, self.kp, self.kd, s.q, s.dq), 0.0)

    def release(self, s: Sensed) -> None:
        pass


class ArmSdkBlend:
    """rt/arm_sdk: on motors 12..28, tau = (1 - w) tau_builtin + w tau_armsdk, w the stream's weight 0..1.

    Torques rather than targets are blended, so the built-in controller's own gains never leak into
    the user's PD; the legs (0..11) always stay with the built-in controller.
    """

    def __init__(self) -> None:
        self.q = np.zeros(N_ARM)
        self.dq = np.zeros(N_ARM)
        self.tau = np.zeros(N_ARM)
        self.kp = np.zeros(N_ARM)
        self.kd = np.zeros(N_ARM)
        self.weight = 0.0

    def set_command(self, q: ArrayLike, dq: ArrayLike, tau: ArrayLike, kp: ArrayLike, kd: ArrayLike,
                    weight: float) -> None:
        self.q[:] = q
        self.dq[:] = dq
        self.tau[:] = tau
        self.kp[:] = kp
        self.kd[:] = kd
        self.weight = float(np.clip(weight, 0.0, 1.0))

    def blend(self, tau_builtin: np.ndarray, s: Sensed) -> np.ndarray:
        if self.weight <= 0.0:
            return tau_builtin
        arm = slice(ARM0, ARM0 + N_ARM)
        user = pd(self.q, self.dq, self.tau, self.kp, self.kd, s.q[arm], s.dq[arm], EFFORT_LIMIT[arm])
        out = tau_builtin.copy()
        out[arm] = (1.0 - self.weight) * tau_builtin[arm] + self.weight * user
        return out
