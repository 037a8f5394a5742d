"""SimG1: the simulated robot as the DDS bridge sees it (sport service, motion switcher, streams, state).

One class per part of the firmware, each in its module, all over the one state and the one lock of
:mod:`~g1_sim.firmware.core` (RPC handlers call in from other threads while a loop thread calls ``step``):

* ``loop``: the physics step and the firmware's 50 Hz tick (velocity lease, fsm_mode, falls, body, remote);
* ``handover``: which built-in controller holds the joints after each change of state;
* ``loco_api``: the sport service (SetFsmId, balance, velocity, speed mode, heights);
* ``arm_service``: SetArmTask and the arm service's actions;
* ``motion_switcher``: CheckMode, SelectMode, ReleaseMode;
* ``user_ctrl_service``: SwitchToUserCtrl and SwitchToInternalCtrl (newer firmware);
* ``intake``: rt/arm_sdk, rt/lowcmd and rt/user_lowcmd frames;
* ``publication``: rt/lowstate, the torso IMU, rt/sportmodestate, odometry, the body, and the readings tests take;
* ``outside``: the operator's remote, the gantry and pushes.

Switching rules live in :mod:`g1_sim.firmware.rules` (user control's in :mod:`g1_sim.firmware.user_ctrl`);
torques come from the controllers in :mod:`g1_sim.physics.controllers`; the body around the motors is
:mod:`g1_sim.firmware.body`'s (temperatures, battery) and the state estimator :mod:`g1_sim.firmware.odometry`'s.
"""

from __future__ import annotations

from g1_sim.firmware.arm_service import ArmService
from g1_sim.firmware.intake import CommandIntake
from g1_sim.firmware.loco_api import LocoApi
from g1_sim.firmware.loop import FirmwareLoop
from g1_sim.firmware.motion_switcher import MotionSwitcher
from g1_sim.firmware.outside import Outside
from g1_sim.firmware.publication import StatePublication
from g1_sim.firmware.user_ctrl_service import UserCtrlService


class SimG1(LocoApi, ArmService, MotionSwitcher, UserCtrlService, CommandIntake, StatePublication, Outside,
            FirmwareLoop):
    """The simulated G1 and its firmware rules. Return values are RPC codes of ``protocol.api_ids``."""
