"""The squat that squat-to-stand (706) takes a standing G1 down to, as the vendor's remote guide uses it: damped
there, the robot stays folded on its feet (it tipped onto its back before: the knees folded, the hips did not);
706 from that damped squat stands it up; and 706 in the squat 706 left is refused, the way up goes through damping.
Runs MuJoCo: run under the sim CPU lock."""

from __future__ import annotations

import numpy as np
import pytest

from g1_mode_manager.protocol.api_ids import ERR_REFUSED_IN_STATE, OK
from g1_mode_manager.protocol.fsm import FsmId, FsmMode
from g1_sim.firmware import SimG1
from g1_sim.firmware.posture import Posture
from g1_sim.firmware.state import tilt_rad

pytestmark = pytest.mark.sim

#: Folded on its feet: the pelvis this low (standing 0.76, the squat 706 holds 0.23, damped 0.19) ...
FOLDED_BELOW_M = 0.3
#: ... and above this (lying on the floor 0.06-0.09) ...
ON_ITS_FEET_ABOVE_M = 0.15
#: ... tilted less than this (the fold leans 0.24-0.55 forward; lying 1.5-1.9, the fall check's angle 1.0).
FOLDED_TILT_RAD = 0.8
#: How long a damped squat is watched, s of sim time.
WATCH_S = 5.0


def run(sim: SimG1, seconds: float) -> None:
    sim.step(round(seconds / sim.dt))


def squatted_by_706() -> SimG1:
    sim = SimG1()
    assert sim.set_fsm_id(FsmId.SQUAT_TO_STAND) == OK  # StandUp2Squat
    run(sim, 3.0)
    assert sim.get_fsm_id() == (OK, FsmId.SQUAT_TO_STAND) and sim.get_fsm_mode() == (OK, FsmMode.STATIC)
    return sim


def folded(sim: SimG1) -> tuple[float, float]:
    """(pelvis height, tilt), asserted folded on its feet."""
    pose = sim.base_pose()
    z, tilt = float(pose.position[2]), tilt_rad(pose.quaternion)
    assert ON_ITS_FEET_ABOVE_M < z < FOLDED_BELOW_M and tilt < FOLDED_TILT_RAD, (z, tilt)
    assert sim.posture is Posture.UPRIGHT and not sim.fallen
    return z, tilt


def watch_damped(sim: SimG1) -> list[tuple[float, float]]:
    """Damp and watch for WATCH_S: every tenth of a second folded on its feet."""
    assert sim.set_fsm_id(FsmId.DAMP) == OK
    seen = []
    for _ in range(round(WATCH_S / 0.1)):
        run(sim, 0.1)
        seen.append(folded(sim))
    return seen


def test_the_706_squat_is_folded_and_balanced_on_the_feet() -> None:
    z, tilt = folded(squatted_by_706())
    print(f"706's squat: pelvis {z:.3f} m, tilt {tilt:.2f} rad")


def test_damped_in_the_706_squat_the_robot_stays_folded() -> None:
    sim = squatted_by_706()
    seen = np.array(watch_damped(sim))
    print(f"damped {WATCH_S:.0f} s: pelvis {seen[:, 0].min():.3f}-{seen[:, 0].max():.3f} m, "
          f"tilt {seen[:, 1].min():.2f}-{seen[:, 1].max():.2f} rad")
    assert sim.get_fsm_id() == (OK, FsmId.DAMP)


def test_706_stands_up_the_damped_squat() -> None:
    sim = squatted_by_706()
    watch_damped(sim)
    assert sim.set_fsm_id(FsmId.SQUAT_TO_STAND) == OK  # Squat2StandUp: the vendor's power-on flow
    run(sim, 0.1)
    assert sim.get_fsm_id() == (OK, FsmId.SQUAT_TO_STAND) and sim.get_fsm_mode() == (OK, FsmMode.DYNAMIC)
    run(sim, 4.0)
    assert sim.get_fsm_mode() == (OK, FsmMode.STATIC) and sim.standing_balanced and not sim.fallen
    assert sim.base_pose().position[2] > 0.7


def test_706_in_the_squat_706_left_is_refused_and_damping_leads_back_up() -> None:
    sim = squatted_by_706()
    before = sim.base_pose().position.copy()
    assert sim.set_fsm_id(FsmId.SQUAT_TO_STAND) == ERR_REFUSED_IN_STATE  # back up only through damping
    run(sim, 2.0)
    assert sim.get_fsm_id() == (OK, FsmId.SQUAT_TO_STAND)
    assert np.linalg.norm(sim.base_pose().position - before) < 0.01  # nothing moved
    assert sim.set_fsm_id(FsmId.DAMP) == OK
    run(sim, 0.5)
    assert sim.set_fsm_id(FsmId.SQUAT_TO_STAND) == OK
    run(sim, 4.0)
    assert sim.get_fsm_id() == (OK, FsmId.SQUAT_TO_STAND) and sim.standing_balanced
    assert sim.base_pose().position[2] > 0.7
