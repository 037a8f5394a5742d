"""The channels of an incident file (docs/recorder.md, "The file"): the names its writer writes and its readers
(the operator console's incident card, a test) look for, so both sides name each channel once."""

from __future__ import annotations

from typing import Final

PREFIX: Final = "/recorder"
STATUS: Final = f"{PREFIX}/status"
TRANSITIONS: Final = f"{PREFIX}/transitions"
NOTES: Final = f"{PREFIX}/notes"
SERVICES: Final = f"{PREFIX}/services"
ROBOT_CALLS: Final = f"{PREFIX}/robot_calls"
ESTOP: Final = f"{PREFIX}/estop"
BODY: Final = f"{PREFIX}/body"  # /<reading> (Float64) and /verdicts (String)
DRIVE: Final = f"{PREFIX}/drive"  # /<source> (Twist) and /not_taken (String)
MOVES: Final = f"{PREFIX}/moves"  # /<driver> (Twist)
ODOMETRY: Final = f"{PREFIX}/odometry"  # the robot's estimate (Twist, body frame)
FRAMES: Final = f"{PREFIX}/frames"  # /<topic> (JointCommand), /arm_sdk/weight (Float64)

#: BodyReadings field -> its channel under BODY.
BODY_READINGS: Final = {"tilt_rad": "tilt_rad", "gyro_max": "gyro_max_rad_s", "joint_speed_max": "joint_speed_max_rad_s",
                        # what the speed checks judged: the readings less what a playing motion allows
                        "gyro_judged": "gyro_judged_rad_s", "joint_speed_judged": "joint_speed_judged_rad_s",
                        "winding_max_c": "winding_max_c", "casing_max_c": "casing_max_c",
                        "soc_pct": "battery_soc_pct", "state_age_s": "state_age_s"}
TILT: Final = f"{BODY}/{BODY_READINGS['tilt_rad']}"
