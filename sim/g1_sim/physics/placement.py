"""The robot put on the floor in a given pose and pitch: where a posture motion aims the pelvis, and where a boot
posture starts the robot.

The lowest point is found on the collision geoms themselves, a mesh by its vertices (MuJoCo collides a mesh's
convex hull, whose lowest point is a vertex). ``model.standing_qpos`` bounds a mesh by its sphere instead, which
is close enough for standing legs but lifts a folded one: in the folded squat the shins' spheres reach 4 cm
below the soles.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

import mujoco
import numpy as np

from g1_mode_manager.protocol.motors import NUM_JOINTS
from g1_sim.physics.model import QPOS0

#: Left between the lowest point and the floor, m: the robot settles onto the floor instead of starting in it.
CLEARANCE_M: Final = 0.001
_FEET: Final = ("left_ankle_roll_link", "right_ankle_roll_link")


@dataclass(frozen=True)
class Placed:
    """A pose on the floor: the full qpos, the pelvis's height (m) and how far the pelvis is ahead of the feet's
    midpoint along its heading (m; negative: behind)."""

    qpos: np.ndarray
    height: float
    ahead: float


def pitched(pitch: float) -> np.ndarray:
    """The pelvis's quaternion (w, x, y, z) facing +x, pitched ``pitch`` rad about y: positive leans forward,
    -pi/2 lies on the back."""
    return np.array((np.cos(0.5 * pitch), 0.0, np.sin(0.5 * pitch), 0.0))


def lowest_point(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """The lowest point of the robot's collision geoms, m (world z; ``data`` after a forward pass)."""
    low = np.inf
    for g in range(model.ngeom):
        if model.geom_bodyid[g] == 0 or not model.geom_contype[g]:
            continue
        rot = data.geom_xmat[g].reshape(3, 3)
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = model.geom_dataid[g]
            first = model.mesh_vertadr[mesh]
            vertices = model.mesh_vert[first : first + model.mesh_vertnum[mesh]]
            z = float((vertices @ rot[2]).min())  # world z of each vertex, less the geom's own height
        elif model.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE:
            z = -float(model.geom_size[g][0])
        else:  # the G1's other collision geoms are meshes and spheres; anything else by its bounding sphere
            z = -float(model.geom_rbound[g])
        low = min(low, float(data.geom_xpos[g][2]) + z)
    return low


def place(model: mujoco.MjModel, pose: np.ndarray, pitch: float = 0.0) -> Placed:
    """``pose`` (motor order, rad) with the pelvis at ``pitch``, its lowest point just above the floor at x = y = 0."""
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[0:3] = (0.0, 0.0, 1.0)
    data.qpos[3:7] = pitched(pitch)
    data.qpos[QPOS0 : QPOS0 + NUM_JOINTS] = pose
    mujoco.mj_forward(model, data)
    lift = CLEARANCE_M - lowest_point(model, data)
    qpos = data.qpos.copy()
    qpos[2] += lift
    feet_x = np.mean([data.xpos[model.body(name).id][0] for name in _FEET])
    return Placed(qpos=qpos, height=float(qpos[2]), ahead=float(qpos[0] - feet_x))
