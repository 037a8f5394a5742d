"""Motor order and joint names of the 29-dof G1 (unitree_hg), defined once."""

from typing import Final

#: Unitree joint names in motor index order (MuJoCo Menagerie joint names are these).
JOINT_NAMES: Final = (
    "left_hip_pitch_joint", "left_hip_roll_joint", "left_hip_yaw_joint",
    "left_knee_joint", "left_ankle_pitch_joint", "left_ankle_roll_joint",
    "right_hip_pitch_joint", "right_hip_roll_joint", "right_hip_yaw_joint",
    "right_knee_joint", "right_ankle_pitch_joint", "right_ankle_roll_joint",
    "waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint",
    "left_shoulder_pitch_joint", "left_shoulder_roll_joint", "left_shoulder_yaw_joint",
    "left_elbow_joint", "left_wrist_roll_joint", "left_wrist_pitch_joint", "left_wrist_yaw_joint",
    "right_shoulder_pitch_joint", "right_shoulder_roll_joint", "right_shoulder_yaw_joint",
    "right_elbow_joint", "right_wrist_roll_joint", "right_wrist_pitch_joint", "right_wrist_yaw_joint",
)
NUM_JOINTS: Final = 29
JOINT_INDEX: Final = {name: i for i, name in enumerate(JOINT_NAMES)}

#: unitree_hg LowCmd_/LowState_ carry 35 motor slots; the G1 29-dof uses the first 29.
NUM_MOTOR_SLOTS: Final = 35
#: LowCmd_.mode_machine of the 29-dof G1 (copy it from rt/lowstate; the robot ignores a mismatch).
MODE_MACHINE_G1_29DOF: Final = 5
#: LowCmd_.mode_pr: 0 = PR (pitch/roll ankle) mode.
MODE_PR: Final = 0
#: MotorCmd_.mode: 1 = enabled, 0 = disabled.
MOTOR_ENABLED: Final = 1
MOTOR_DISABLED: Final = 0

#: rt/arm_sdk commands motors 12..28 (waist and arms); motor_cmd[29].q is the blend weight 0..1.
ARM_SDK_JOINTS: Final = tuple(range(12, 29))
ARM_SDK_JOINT_NAMES: Final = tuple(JOINT_NAMES[i] for i in ARM_SDK_JOINTS)
ARM_SDK_WEIGHT_INDEX: Final = 29

#: Effort limits in N m, by motor index: the joints' actuatorfrcrange in Unitree's G1 model (MuJoCo
#: Menagerie unitree_g1/g1.xml, the sim's model).
_LEG = (88.0, 139.0, 88.0, 139.0, 50.0, 50.0)
_ARM = (25.0, 25.0, 25.0, 25.0, 25.0, 5.0, 5.0)
EFFORT_LIMIT_NM: Final = (*_LEG, *_LEG, 88.0, 50.0, 50.0, *_ARM, *_ARM)

#: MotorState_.temperature holds two int16 in deg C: [casing, winding] (Unitree's terminations.hpp checks
#: temperature[0] against the casing limit and temperature[1] against the winding limit).
CASING_TEMPERATURE_INDEX: Final = 0
WINDING_TEMPERATURE_INDEX: Final = 1

#: Damping gain used when a joint must go soft (kp 0), N m s / rad.
DAMPING_KD: Final = 8.0

#: Joint position ranges in rad, by motor index: the joints' ``range`` in Unitree's G1 model (MuJoCo Menagerie
#: unitree_g1/g1.xml, the sim's model; test/sdk/test_joint_ranges.py holds them against it).
_LEFT_LEG_RANGE = ((-2.5307, 2.8798), (-0.5236, 2.9671), (-2.7576, 2.7576), (-0.087267, 2.8798),
                   (-0.87267, 0.5236), (-0.2618, 0.2618))
_RIGHT_LEG_RANGE = ((-2.5307, 2.8798), (-2.9671, 0.5236), (-2.7576, 2.7576), (-0.087267, 2.8798),
                    (-0.87267, 0.5236), (-0.2618, 0.2618))
_WAIST_RANGE = ((-2.618, 2.618), (-0.52, 0.52), (-0.52, 0.52))
_WRISTS_RANGE = ((-1.97222, 1.97222), (-1.61443, 1.61443), (-1.61443, 1.61443))
_LEFT_ARM_RANGE = ((-3.0892, 2.6704), (-1.5882, 2.2515), (-2.618, 2.618), (-1.0472, 2.0944), *_WRISTS_RANGE)
_RIGHT_ARM_RANGE = ((-3.0892, 2.6704), (-2.2515, 1.5882), (-2.618, 2.618), (-1.0472, 2.0944), *_WRISTS_RANGE)
JOINT_RANGE_RAD: Final = (*_LEFT_LEG_RANGE, *_RIGHT_LEG_RANGE, *_WAIST_RANGE, *_LEFT_ARM_RANGE, *_RIGHT_ARM_RANGE)

#: Joint speed limits in rad/s, by motor index: each joint's ``velocity`` limit in Unitree's G1 29-dof URDF (the one
#: holosoma's models carry as ``robot_urdf``; test/sdk/test_joint_ranges.py holds them against it): the motors' top
#: speed. The joint-speed check never allows more (core/body/joint_speed.py).
_LEG_SPEED = (32.0, 20.0, 32.0, 20.0, 37.0, 37.0)
_ARM_SPEED = (37.0, 37.0, 37.0, 37.0, 37.0, 22.0, 22.0)
VELOCITY_LIMIT_RAD_S: Final = (*_LEG_SPEED, *_LEG_SPEED, 32.0, 37.0, 37.0, *_ARM_SPEED, *_ARM_SPEED)
