"""The posture read from the robot's joints and pelvis, on poses measured on the simulated G1 (fakes/posture_poses.py)
and on the limits' edges: lying flat and folded in a squat are told apart although both show fsm 1, and what
the joints cannot tell (a limp robot upright on bent legs) stays unknown."""

from __future__ import annotations

import math

import pytest

from fakes.posture_poses import POSES, Pose
from g1_mode_manager.core.posture import LIMITS, NO_READING, Posture, PostureReading, read_posture
from g1_mode_manager.protocol.motors import JOINT_INDEX

P = Posture
UPRIGHT = (1.0, 0.0, 0.0, 0.0)
KNEES = (JOINT_INDEX["left_knee_joint"], JOINT_INDEX["right_knee_joint"])
HIPS = (JOINT_INDEX["left_hip_pitch_joint"], JOINT_INDEX["right_hip_pitch_joint"])


def _read(pose: Pose, *, limp: bool | None = None, height: bool = False) -> Posture:
    limp = pose.limp if limp is None else limp
    return read_posture(pose.q, pose.quaternion, limp=limp, height_m=pose.height_m if height else None).posture


@pytest.mark.parametrize(("name", "posture"), [
    ("standing", P.STANDING), ("walking", P.STANDING), ("standing_702", P.STANDING),
    ("squatting_706", P.SQUATTING), ("squatting_fsm2", P.SQUATTING), ("squatting_damped", P.SQUATTING),
    ("sitting", P.SITTING), ("lying_back", P.LYING_BACK), ("lying_front", P.LYING_FRONT), ("hanging", P.HANGING),
    # the power-on postures, and the damped fold after it tipped forward onto its knees
    ("squatting_booted", P.SQUATTING), ("lying_back_booted", P.LYING_BACK), ("lying_front_tipped", P.LYING_FRONT),
    # on the way, or limp and upright on bent legs (falling, or held up by a gantry): nothing the verbs may act on
    ("getting_up", P.UNKNOWN), ("falling_damped", P.UNKNOWN), ("gantry_damped", P.UNKNOWN),
    # between the fold and standing, 706's legs pass through the sit: read as it, while 706 still moves (fsm_mode 1,
    # where no verb is sent and no outcome is taken)
    ("squatting_down", P.SITTING), ("standing_up_706", P.SITTING),
])
def test_each_measured_pose_reads_as_its_posture_with_and_without_its_height(name: str, posture: Posture) -> None:
    assert _read(POSES[name]) is posture
    assert _read(POSES[name], height=True) is posture


def test_lying_flat_and_folded_in_a_squat_differ_though_both_are_damped() -> None:
    folded, flat = POSES["squatting_damped"], POSES["lying_back"]
    assert folded.limp and flat.limp  # the same fsm (1): the controller lets both go
    assert _read(folded) is P.SQUATTING and _read(flat) is P.LYING_BACK
    assert _read(POSES["squatting_706"]) is P.SQUATTING  # the fold 706 squats down to, the pelvis pitched forward


def test_a_standing_pose_held_by_no_controller_is_not_standing() -> None:
    """Bent legs upright and limp: the robot is falling or hangs in a gantry, which the joints cannot tell apart;
    straight legs upright and limp: only something above holds it."""
    stand, hang = POSES["standing"], POSES["hanging"]
    assert _read(stand, limp=True) is P.UNKNOWN
    assert _read(hang, limp=False) is P.UNKNOWN  # a controller on straight legs: standing or hanging, not known
    assert read_posture(hang.q, hang.quaternion, limp=None).posture is P.UNKNOWN
    assert read_posture(stand.q, stand.quaternion, limp=None).posture is P.STANDING  # released: the user's frames


def _legs(knee: float, hip: float = -0.3) -> list[float]:
    q = [0.0] * 29
    for i in KNEES:
        q[i] = knee
    for i in HIPS:
        q[i] = hip
    return q


def _pitched(angle: float) -> tuple[float, float, float, float]:
    """Pitched about the body's y axis: positive leans back (the forward axis rises)."""
    return (math.cos(angle / 2), 0.0, -math.sin(angle / 2), 0.0)


@pytest.mark.parametrize(("knee", "hip", "tilt", "posture"), [
    (LIMITS.standing_knee_rad, -0.3, 0.0, P.STANDING),  # the edges belong to the posture they close
    (LIMITS.standing_knee_rad + 0.01, -0.3, 0.0, P.UNKNOWN),
    (LIMITS.folded_knee_rad - 0.01, -0.9, 0.0, P.UNKNOWN),
    (LIMITS.folded_knee_rad, -0.9, 0.0, P.SQUATTING),
    (2.4, LIMITS.sitting_hip_rad, 0.0, P.SITTING),
    (2.4, LIMITS.sitting_hip_rad + 0.01, 0.0, P.SQUATTING),
    (2.8, LIMITS.folded_hip_rad + 0.01, 0.3, P.SITTING),
    (2.8, LIMITS.folded_hip_rad, 0.3, P.SQUATTING),  # the thighs against the trunk: the fold
    (0.67, -0.3, LIMITS.upright_tilt_rad - 1e-9, P.STANDING),  # (a quaternion's tilt rounds either way at the edge)
    (0.67, -0.3, LIMITS.upright_tilt_rad + 0.01, P.UNKNOWN),  # leaning: falling, or lifted
    (1.9, -0.9, LIMITS.lying_tilt_rad - 1e-9, P.SQUATTING),  # folded legs stay a squat until the robot lies
    (1.9, -0.9, LIMITS.lying_tilt_rad + 0.01, P.LYING_BACK),
    (1.9, -0.9, -(LIMITS.lying_tilt_rad + 0.01), P.LYING_FRONT),
])
def test_the_limits(knee: float, hip: float, tilt: float, posture: Posture) -> None:
    assert read_posture(_legs(knee, hip), _pitched(tilt), limp=False).posture is posture


def test_the_knees_both_decide_one_straight_knee_of_a_walk_is_not_hanging() -> None:
    q = _legs(0.9)
    q[KNEES[1]] = 0.05  # the stance leg stretched, the swing leg bent
    assert read_posture(q, UPRIGHT, limp=True).posture is P.UNKNOWN
    assert read_posture(q, UPRIGHT, limp=False).posture is P.STANDING
    q[KNEES[0]] = 1.9  # one leg folded, the other not: on its way
    assert read_posture(q, UPRIGHT, limp=False).posture is P.UNKNOWN


@pytest.mark.parametrize(("name", "height"), [("standing", 0.4), ("squatting_706", 0.8), ("sitting", 0.65),
                                              ("lying_back", 0.6), ("hanging", 0.4)])
def test_a_height_that_contradicts_the_joints_makes_the_posture_unknown(name: str, height: float) -> None:
    pose = POSES[name]
    assert _read(pose) is not P.UNKNOWN
    assert read_posture(pose.q, pose.quaternion, limp=pose.limp, height_m=height).posture is P.UNKNOWN


def test_the_reading_carries_its_tilt_and_says_what_it_read() -> None:
    reading = read_posture(POSES["lying_back"].q, POSES["lying_back"].quaternion, limp=True)
    assert reading.posture is P.LYING_BACK and reading.tilt_rad == pytest.approx(1.86, abs=0.01)
    assert reading.describe() == "lying_back, tilt 1.86 rad"
    assert PostureReading(P.UNKNOWN, None) == NO_READING
    assert NO_READING.describe() == "posture unknown (no state sample)"


@pytest.mark.parametrize(("q", "quaternion"), [([0.0] * 12, UPRIGHT), ([0.7] * 29, (0.0, 0.0, 0.0, 0.0)),
                                               ([0.7] * 29, (math.nan, 0.0, 0.0, 0.0))])
def test_no_joints_or_no_attitude_reads_as_unknown(q: list[float], quaternion: tuple[float, ...]) -> None:
    assert read_posture(q, quaternion).posture is P.UNKNOWN  # type: ignore[arg-type]


def test_lying_is_the_two_lying_postures() -> None:
    assert {p for p in Posture if p.lying} == {P.LYING_BACK, P.LYING_FRONT}
