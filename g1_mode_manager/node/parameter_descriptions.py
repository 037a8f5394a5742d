"""What each parameter of the node means and may hold: its description and its range, as ROS shows them.

The defaults live in settings.py (:class:`Settings`); this is the text of `ros2 param describe`.
"""

from __future__ import annotations

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

from g1_mode_manager.core.joint_commands import MAX_KD, MAX_KP
from g1_mode_manager.core.velocity import MAX_MOVE_DURATION_S

DESCRIPTIONS: dict[str, str] = {
    "network_interface": "Network interface of the robot side (Unitree SDK2 / Cyclone DDS): 'lo' for the sim, "
    "e.g. 'eth0' for a real G1. Read at start.",
    "dds_domain": "Cyclone DDS domain of the robot side (a real G1 uses 0). Read at start.",
    "rpc_timeout_s": "Timeout of one robot RPC (loco and motion switcher calls), s.",
    "loco_outcome_timeout_s": "~/loco_command answers success only once the robot shows the command's outcome "
    "(fsm id, balance mode, stand height, arm task); it waits at most this long for it, s.",
    "loco_motion_timeout_s": "The same for stand_up, squat and sit, which start a posture motion of seconds: "
    "answered when the motion finished (fsm_mode 0), s.",
    "loco_get_up_timeout_s": "The same for lie_to_stand, the get-up from the floor (702): answered when the robot "
    "stands balanced (fsm 702, fsm_mode 0); the robot's time is not documented, the sim's about 6 s, s.",
    "not_walking_after_s": "Moves acknowledged for this long while the robot's odometry shows it not walking "
    "(below a fifth of the command) -> a WARN on /diagnostics and in ~/mode, s.",
    "odom_rate_hz": "Publish odom (nav_msgs/Odometry) and the odom -> child frame TF from the robot's "
    "rt/lf/odommodestate at most this often, each sample once; 0 = off.",
    "odom_frame_id": "Frame of the robot's odometry (header.frame_id of odom, parent of the TF).",
    "odom_child_frame_id": "Body frame of the odometry (child_frame_id, the TF's child); the G1's URDF root is pelvis.",
    "odom_publish_tf": "Also publish the odom -> child frame transform on /tf (when odom_rate_hz > 0).",
    "select_timeout_s": "How long SelectMode('ai') plus its confirmation may take, s (a real robot takes seconds).",
    "release_timeout_s": "How long ReleaseMode may take until CheckMode reports no service, s.",
    "cmd_vel_timeout_s": "Watchdog: no /cmd_vel for this long sends one StopMove, s.",
    "cmd_vel_rate_hz": "Keep-alive rate of a steady Move, Hz (a new /cmd_vel is sent at once, a ramp steps at 20 Hz, "
    "the watchdog has its own deadline).",
    "cmd_vel_max_rate_hz": "At most this many Moves per second reach the robot (two may go back to back), whatever "
    "the /cmd_vel rate, Hz.",
    "move_duration_s": "Lease of each Move (at most 2 s): the robot stops by itself if no newer Move arrives, s. "
    "The real robot ignores velocities below about 0.1; such commands are sent as one StopMove.",
    "max_vx": "Clamp of forward velocity, m/s.",
    "max_vy": "Clamp of lateral velocity, m/s.",
    "max_wz": "Clamp of yaw rate, rad/s.",
    "max_ax": "Forward acceleration limit, m/s^2.",
    "max_ay": "Lateral acceleration limit, m/s^2.",
    "max_awz": "Yaw acceleration limit, rad/s^2.",
    "autonomy_topic": "The autonomy's velocity input (a planner, e.g. Nav2's controller or collision monitor output): "
    "relayed only in HIGH_LEVEL after ~/hand_over_to_autonomy, until a non-zero cmd_vel or ~/take_over takes the "
    "robot back; relative like cmd_vel; '' = no autonomy. Read at start.",
    "autonomy_stamped": "The autonomy's input is geometry_msgs/TwistStamped (stamps older than autonomy_timeout_s are "
    "dropped) instead of Twist. Read at start.",
    "autonomy_timeout_s": "The autonomy silent for this long while it drives: a StopMove (it keeps the robot: its "
    "next command moves it again, nobody else's does), s.",
    "autonomy_odom_timeout_s": "The autonomy is suspended (StopMove, the reason in ~/mode) while the robot's "
    "odometry (rt/lf/odommodestate) is older than this, s.",
    "autonomy_max_vx": "Clamp of the autonomy's forward velocity, m/s.",
    "autonomy_max_vy": "Clamp of the autonomy's lateral velocity, m/s.",
    "autonomy_max_wz": "Clamp of the autonomy's yaw rate, rad/s.",
    "autonomy_max_ax": "The autonomy's forward acceleration limit, m/s^2.",
    "autonomy_max_ay": "The autonomy's lateral acceleration limit, m/s^2.",
    "autonomy_max_awz": "The autonomy's yaw acceleration limit, rad/s^2.",
    "arm_ramp_time_s": "Time for the rt/arm_sdk blend weight to go 0 -> 1 or 1 -> 0, s.",
    "arm_cmd_timeout_s": "No ~/arm_cmd for this long ramps the arms back to the controller, s.",
    "arm_rate_hz": "Rate of rt/arm_sdk frames while the weight is above zero, Hz.",
    "arm_kp": "Stiffness of arm_sdk targets, N m/rad.",
    "arm_kd": "Damping of arm_sdk targets, N m s/rad.",
    "lowcmd_timeout_s": "No ~/lowcmd for this long in LOW_LEVEL sends damping frames (kp 0, kd > 0), s.",
    "lowcmd_damping_rate_hz": "Rate of damping frames while ~/lowcmd is silent (or the link lost) in LOW_LEVEL, Hz.",
    "lowcmd_exit_damping_s": "After LOW_LEVEL -> IDLE, damping frames go on this long (the robot holds the last frame), s.",
    "link_timeout_s": "rt/lowstate (and in HIGH_LEVEL rt/sportmodestate) older than this = link lost, s.",
    "mode_publish_rate_hz": "Rate at which ~/mode is re-published besides every change, Hz.",
    "mode_change_check_hz": "Rate at which what ~/mode carries (holds, warnings, the autonomy's state...) is compared "
    "with what was published last, and published if it changed; a mode change or a change of driver is published "
    "at once, Hz.",
    "diagnostics_rate_hz": "Rate of /diagnostics, Hz.",
    "estop_call_timeout_s": "Timeout of each Damp and GetFsmId of an e-stop (short: a dead link must not hold it), s.",
    "estop_select_timeout_s": "Timeout of an e-stop's motion switcher calls (CheckMode, SelectMode('ai') and its "
    "confirmation), s.",
    "estop_timeout_s": "An e-stop answers within this (plus one call timeout): verified damped, or failed while "
    "supervision keeps trying, s.",
    "supervise_rate_hz": "Rate at which the robot is checked against the mode (EMERGENCY: re-damped if seen out of "
    "damping), Hz.",
    "sportmodestate_rate_hz": "Rate at which ~/sportmodestate mirrors the newest rt/sportmodestate (a sample is "
    "published once; none while the robot is silent); 0 = off, Hz.",
    "estop_verify_period_s": "In EMERGENCY: period of CheckMode + GetFsmId re-verification of the robot, s.",
    "belief_check_period_s": "Outside EMERGENCY: period of the CheckMode that confirms the robot still matches the "
    "mode, s.",
    "head_led_enabled": "Show the mode on the robot's head LED (voice service; a failure is counted, never fatal).",
    "head_led_rate_hz": "Rate of the head LED worker; a colour is sent only when it changes, Hz.",
    "head_led_uninitialized": "Head LED in UNINITIALIZED: 'R G B [solid|pulse|flash] [period_s]'.",
    "head_led_idle": "Head LED in IDLE: 'R G B [solid|pulse|flash] [period_s]'.",
    "head_led_high_level": "Head LED in HIGH_LEVEL: 'R G B [solid|pulse|flash] [period_s]'.",
    "head_led_low_level": "Head LED in LOW_LEVEL: 'R G B [solid|pulse|flash] [period_s]'.",
    "head_led_emergency": "Head LED in EMERGENCY: 'R G B [solid|pulse|flash] [period_s]'.",
    "head_led_fault": "Head LED in FAULT: 'R G B [solid|pulse|flash] [period_s]'.",
    "head_led_autonomy": "Head LED in HIGH_LEVEL while the autonomy drives: 'R G B [solid|pulse|flash] [period_s]'.",
    "announce_modes": "Announce every mode change through the robot's speaker (TTS).",
    "voice_timeout_s": "Timeout of one head LED or TTS call, s (the LED worker waits, nothing else does).",
    "joint_state_rate_hz": "Rate of joint_states (sensor_msgs/JointState) and ~/imu from rt/lowstate; 0 = off, Hz.",
    "body_checks_enabled": "Watch the robot's body (falls, heat, battery, a lost state stream) and react per mode "
    "(warn, hold, FAULT). The remote's e-stop works either way.",
    "body_check_rate_hz": "Rate of the body checks while rt/lowstate is received (IDLE, LOW_LEVEL, arms in play), Hz.",
    "body_check_slow_rate_hz": "Rate of the body checks on rt/lf/lowstate alone (an idle HIGH_LEVEL), Hz.",
    "tilt_limit_rad": "A fall: body z axis further than this from vertical while something holds the robot up, rad.",
    "spin_limit_rad_s": "Any gyro axis faster than this while something holds the robot up, rad/s.",
    "joint_speed_limit_rad_s": "Any joint faster than this while something holds the robot up, rad/s.",
    "winding_limit_c": "Hottest motor winding (temperature[1]) above this: LOW_LEVEL FAULT, HIGH_LEVEL hold, degC.",
    "casing_limit_c": "Hottest motor casing (temperature[0]) above this: LOW_LEVEL FAULT, HIGH_LEVEL hold, degC.",
    "winding_critical_c": "Hottest winding above this: FAULT in every mode, degC.",
    "casing_critical_c": "Hottest casing above this: FAULT in every mode, degC.",
    "battery_low_pct": "Battery state of charge below this: a warning, %.",
    "battery_critical_pct": "Battery below this: no new motion in HIGH_LEVEL and LOW_LEVEL, %.",
    "state_lost_s": "No robot state (rt/lowstate, or rt/lf/lowstate) for this long: FAULT in LOW_LEVEL, s.",
    "fault_clear_hold_s": "~/clear_fault succeeds only once every tripped check has been clear this long, s.",
    "remote_estop_keys": "Keys of the robot's remote that e-stop in every mode when held together, e.g. 'L2+B' "
    "(the combination the built-in controller damps on); '' = off.",
    "lowcmd_deadman_key": "LOW_LEVEL dead-man: user lowcmd passes only while this remote key (or 'A+B') is held, "
    "damping frames otherwise; '' = off.",
    "low_level_path": "How LOW_LEVEL is entered and left. 'user_ctrl' (newer firmware): a hand-over frame holds the "
    "measured pose, SwitchToUserCtrl, fsm 1000 seen before a user frame passes; ~/lowcmd -> rt/user_lowcmd; exits hand "
    "the robot back to its own controller (never limp). 'release': ReleaseMode, ~/lowcmd -> rt/lowcmd, the robot limp "
    "on entry and exit. Firmware without user control refuses 'user_ctrl' with nothing changed. Read at start.",
    "user_ctrl_switch_timeout_s": "user_ctrl: after SwitchToUserCtrl answered, GetFsmId must show 1000 within this "
    "(else SwitchToInternalCtrl LAST and refused); after SwitchToInternalCtrl, another fsm within this, s.",
    "user_ctrl_hold_kp": "user_ctrl: stiffness of the hand-over / hold frame (every joint at its measured pose) on "
    "rt/user_lowcmd, N m/rad.",
    "user_ctrl_hold_kd": "user_ctrl: damping of the hand-over / hold frame, N m s/rad.",
    "user_ctrl_silence": "user_ctrl: what no ~/lowcmd for lowcmd_timeout_s does. 'hand_back': SwitchToInternalCtrl "
    "WALKRUN when upright (|roll| <= 1.0, |pitch| <= 0.8 rad) and LOW_LEVEL -> IDLE, PASSIVE and FAULT when not; "
    "'damp': damping frames on rt/user_lowcmd, LOW_LEVEL kept.",
    "user_ctrl_rest_speed_rad_s": "user_ctrl: the entry waits until every joint is slower than this (the hand-over "
    "frame holds a pose; one taken mid-step falls over), rad/s.",
    "user_ctrl_rest_timeout_s": "user_ctrl: how long the entry waits for the robot at rest before it refuses, s.",
    "user_ctrl_first_frame_s": "user_ctrl: after the entry, the hand-over frame holds the robot this long for the "
    "user's first frame before silence (lowcmd_timeout_s) counts, s: time for a fresh ROS publisher to be heard.",
    "policy": "The policy ~/policy/load loads when its request names none: a built-in (loco_ppo, loco_fastsac, "
    "dance_ppo, dance_fastsac) or a deploy config's path (.yaml; docs/policies.md).",
    "policy_dir": "Where the policies' ONNX models are; '' = the ones set-up extracted from holosoma-inference's "
    "wheel into <prefix>/share/g1_mode_manager/sim_assets/policy. Read at start.",
    "policy_blend_s": "Engage: the policy's targets are blended in from the measured pose over this long, s.",
    "policy_engage_max_error_rad": "Engage is refused while the shadow's latest target of any joint is further than "
    "this from its measured position, rad.",
    "policy_state_timeout_s": "An engaged policy ticks only on an rt/lowstate sample at most this old; an older "
    "one (a frozen or lost stream) is a fault of the loop: hold, then hand back, s.",
    "policy_overrun_s": "A tick (state sample to frame) longer than this is an overrun, s; policy_max_overruns in a "
    "row are a fault of the loop.",
    "policy_max_overruns": "Overruns in a row that stop the policy (hold, then hand back).",
    "policy_clamp_max_s": "A policy's target past its joint's range + margin is clamped there; held clamped longer "
                          "than this, s, it stops the policy (hold, then hand back).",
    "policy_disengage": "~/policy/disengage: 'walkrun' hands the robot back to its own controller standing "
    "(SwitchToInternalCtrl WALKRUN, LOW_LEVEL -> HIGH_LEVEL); 'hold' holds the last pose in LOW_LEVEL "
    "(disengage again to hand back).",
    "policy_engage_keys": "Keys of the robot's remote that engage the loaded and shadowed policy when pressed together "
    "(once per press, as ~/policy/engage), e.g. 'R1+X' (unitree_rl_lab's G1 velocity policy); '' = off.",
    "policy_disengage_keys": "Keys of the robot's remote that disengage the policy when pressed together (once per "
    "press, as ~/policy/disengage), e.g. 'L2+Up' (unitree_rl_lab's G1 stand); '' = off. Neither may hold all the "
    "keys of the other or of remote_estop_keys, nor be part of them.",
    "cmd_vel_stamped": "cmd_vel is geometry_msgs/TwistStamped (stamps older than cmd_vel_timeout_s are dropped) "
    "instead of Twist. Read at start.",
    "recorder_enabled": "Keep the node's recent past and write incident files (the flight recorder); false: nothing "
                        "is kept, no file is written, ~/snapshot refuses.",
    "recorder_dir": "Folder of the flight recorder's incident files (MCAP); '' = $XDG_STATE_HOME/g1_mode_manager/"
    "incidents (~/.local/state/g1_mode_manager/incidents without XDG_STATE_HOME). Made if missing.",
    "recorder_window_s": "The flight recorder keeps this much of the node's past; an incident holds it before its "
    "cause, s.",
    "recorder_after_s": "An EMERGENCY or FAULT incident also holds this long after its entry (written then), s.",
    "recorder_max_files": "Incident files kept in recorder_dir; the oldest go first.",
    "recorder_max_total_mb": "Incident files kept in recorder_dir together at most this large (the newest always "
    "stays); the oldest go first, MB.",
    "recorder_frame_rate_hz": "Joint frames (rt/lowcmd, rt/user_lowcmd, rt/arm_sdk) the flight recorder keeps per "
    "topic and second, Hz.",
}

#: Float ranges other than the default (1e-3, 1e6).
RANGES: dict[str, tuple[float, float]] = {
    "move_duration_s": (0.1, MAX_MOVE_DURATION_S),  # continuous Moves (864000 s) would outlive a dead node
    "joint_state_rate_hz": (0.0, 1000.0),  # 0 = off
    "sportmodestate_rate_hz": (0.0, 1000.0),  # 0 = off
    "odom_rate_hz": (0.0, 500.0),  # 0 = off
    "battery_low_pct": (0.0, 100.0),
    "battery_critical_pct": (0.0, 100.0),
    "body_check_rate_hz": (1.0, 500.0),
    "body_check_slow_rate_hz": (1.0, 500.0),
    "user_ctrl_switch_timeout_s": (0.05, 10.0),
    "user_ctrl_hold_kp": (0.0, MAX_KP),
    "user_ctrl_hold_kd": (0.0, MAX_KD),
    "user_ctrl_first_frame_s": (0.0, 10.0),
    "policy_blend_s": (0.0, 30.0),
    "policy_engage_max_error_rad": (0.0, 3.0),
    "policy_state_timeout_s": (0.004, 1.0),
    "policy_overrun_s": (1e-6, 1.0),
    "policy_clamp_max_s": (0.02, 10.0),
    "recorder_window_s": (1.0, 600.0),  # memory grows with it (docs/recorder.md)
    "recorder_after_s": (0.0, 60.0),
    "recorder_max_total_mb": (1.0, 1e6),
    "recorder_frame_rate_hz": (0.1, 500.0),
}


#: Integer ranges other than the default (0, 10).
INT_RANGES: dict[str, tuple[int, int]] = {
    "policy_max_overruns": (1, 100),  # 0 would stop every policy at its first tick
    "recorder_max_files": (1, 100000),
}


def descriptor(name: str, default: object) -> ParameterDescriptor:
    desc = ParameterDescriptor(description=DESCRIPTIONS[name], read_only=True)
    if isinstance(default, bool | str):
        pass
    elif isinstance(default, float):
        low, high = RANGES.get(name, (1e-3, 1e6))
        desc.floating_point_range = [FloatingPointRange(from_value=low, to_value=high)]
    elif name == "dds_domain":
        desc.integer_range = [IntegerRange(from_value=0, to_value=230, step=1)]
    elif isinstance(default, int):
        low, high = INT_RANGES.get(name, (0, 10))
        desc.integer_range = [IntegerRange(from_value=low, to_value=high, step=1)]
    return desc
