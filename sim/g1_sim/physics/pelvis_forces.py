"""Forces from outside the robot on its pelvis: the gantry's elastic band and a push.

**Gantry.** A humanoid tested in low-level control hangs from a gantry so that a limp or badly commanded
robot does not fall. Unitree's own MuJoCo simulator (unitree_mujoco ``simulate_python``: class
``ElasticBand``, switched on by ``ENABLE_ELASTIC_BAND``) pulls the base link toward a point 3 m up with a
spring (200 N/m, rest length 0) damped along the band (100 N s/m), strong enough to lift the robot. This
band is our own: anchored ANCHOR_HEIGHT_M above the floor over where the pelvis was when it was switched
on, it hooks onto a harness HARNESS_ABOVE_PELVIS_M above the pelvis (so a limp robot hangs upright, not
head down as it does from a band at the pelvis itself), pulls with a spring and damps the hook's whole
velocity (so it stops swinging too). Its stiffness is set so that a limp G1 (33 kg) hangs with its pelvis
at about 0.74 m, the soles just touching the floor; a standing robot (pelvis 0.76 m) keeps about 15 % of
its weight on its feet, and the locomotion policy still stands in it.

**Push.** A horizontal force on the pelvis for a while, as a shove would be: it tests what a body
supervisor makes of a robot tipping over.

Both act through MjData ``qfrc_applied`` on the pelvis free joint's dofs: for the root body these are the
force at the pelvis origin (world frame) and the torque about it (pelvis frame), so a force at any point
of the pelvis needs no Jacobian. Not through ``xfrc_applied``: the controllers (squat/sit/stand-up
harness, walking torso stabiliser) own and rewrite the pelvis' row of it; nothing else writes
``qfrc_applied``. Applied each physics step, before ``mj_step``.
"""

from __future__ import annotations

from typing import Final

import mujoco
import numpy as np

ANCHOR_HEIGHT_M: Final = 2.0
BAND_STIFFNESS_N_PER_M: Final = 330.0
BAND_DAMPING_N_S_PER_M: Final = 100.0
#: The band hooks onto the harness this far above the pelvis origin (along the pelvis' z axis).
HARNESS_ABOVE_PELVIS_M: Final = 0.4


class PelvisForces:
    """The gantry (on/off) and the push under way, if any, summed into the pelvis' external force."""

    def __init__(self, pelvis_body: int) -> None:
        self._pelvis = pelvis_body  # the root body: its free joint's dofs are qvel[0:6]
        self._anchor: np.ndarray | None = None
        self._push = np.zeros(3)
        self._push_until = 0.0
        self._applied = False

    @property
    def gantry(self) -> bool:
        return self._anchor is not None

    def set_gantry(self, on: bool, data: mujoco.MjData) -> None:
        """Hang the pelvis from a band anchored above where it is now, or take the band away."""
        if on and self._anchor is None:
            x, y = data.xpos[self._pelvis][:2]
            self._anchor = np.array((x, y, ANCHOR_HEIGHT_M))
        elif not on:
            self._anchor = None

    def push(self, force_xy: tuple[float, float], duration_s: float, now: float) -> None:
        """Push the pelvis horizontally with ``force_xy`` (N, world frame) for ``duration_s`` from ``now``."""
        self._push = np.array((force_xy[0], force_xy[1], 0.0))
        self._push_until = now + duration_s

    def apply(self, data: mujoco.MjData) -> None:
        """Write this step's force into ``data.qfrc_applied`` (a no-op while nothing acts)."""
        pushing = self._push_until > data.time
        if self._anchor is None and not pushing:
            if self._applied:
                data.qfrc_applied[0:6] = 0.0
                self._applied = False
            return
        force = self._push.copy() if pushing else np.zeros(3)
        torque_body = np.zeros(3)  # about the pelvis origin, pelvis frame (the free joint's rotational dofs)
        if self._anchor is not None:
            rot = data.xmat[self._pelvis].reshape(3, 3)
            hook = np.array((0.0, 0.0, HARNESS_ABOVE_PELVIS_M))  # pelvis frame
            hook_velocity = data.qvel[0:3] + rot @ np.cross(data.qvel[3:6], hook)  # qvel[3:6]: pelvis frame
            band = (BAND_STIFFNESS_N_PER_M * (self._anchor - data.xpos[self._pelvis] - rot @ hook)
                    - BAND_DAMPING_N_S_PER_M * hook_velocity)
            force += band
            torque_body = np.cross(hook, rot.T @ band)
        data.qfrc_applied[0:3] = force
        data.qfrc_applied[3:6] = torque_body
        self._applied = True
