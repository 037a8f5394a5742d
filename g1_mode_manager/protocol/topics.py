"""DDS topic names of the G1 (the SDK's ``rt/`` prefix; ROS 2 sees them without it)."""

from typing import Final

LOWCMD: Final = "rt/lowcmd"
LOWSTATE: Final = "rt/lowstate"
ARM_SDK: Final = "rt/arm_sdk"
#: Joint commands while the robot is under user control (newer firmware, after SwitchToUserCtrl):
#: unitree_hg LowCmd_ as on rt/lowcmd, CRC filled.
USER_LOWCMD: Final = "rt/user_lowcmd"
SPORTMODESTATE: Final = "rt/sportmodestate"
#: The robot's low-rate copies: the same LowState_ decimated, and the battery (unitree_hg BmsState_).
LF_LOWSTATE: Final = "rt/lf/lowstate"
LF_BMSSTATE: Final = "rt/lf/bmsstate"

#: Rates of the robot's state topics in Hz.
LOWSTATE_RATE_HZ: Final = 500.0
SPORTMODESTATE_RATE_HZ: Final = 50.0
LF_LOWSTATE_RATE_HZ: Final = 20.0

#: The robot's state estimate (unitree_go SportModeState_, protocol.odom_fields), high-level mode only, recent
#: firmware; and the torso IMU (unitree_hg IMUState_), which Unitree's C++ ankle example reads.
ODOMMODESTATE: Final = "rt/odommodestate"
LF_ODOMMODESTATE: Final = "rt/lf/odommodestate"
SECONDARY_IMU: Final = "rt/secondary_imu"
ODOMMODESTATE_RATE_HZ: Final = 500.0
LF_ODOMMODESTATE_RATE_HZ: Final = 20.0
