"""Parameters of the mode manager node: their defaults, declared up front, validated at start.

:class:`Settings` is the one home of every parameter's default: the relays, the head LED and the velocity
limits take their values from it (none has a default of its own that could disagree). The e-stop's
timings are named from EstopTiming, whose defaults the mode machine also uses when built without the node.
config/mode_manager.yaml repeats each default (test/node/test_settings_yaml.py keeps the two equal). Each
parameter's description and range are in parameter_descriptions.py.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, fields
from itertools import combinations
from pathlib import Path

from rclpy.node import Node

from g1_mode_manager.core.body.checks import BY_NAME as BODY_CHECKS
from g1_mode_manager.core.estop_policy import EstopTiming
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.recorder.incidents import folder_for
from g1_mode_manager.core.user_ctrl import LowLevelPath, SilenceReaction, UserCtrlConfig
from g1_mode_manager.core.velocity import VelocityLimits
from g1_mode_manager.display.head_led import LedLook
from g1_mode_manager.flight_recorder.flight_recorder import RecorderConfig
from g1_mode_manager.node.parameter_descriptions import descriptor
from g1_mode_manager.node.renamed_parameters import read_old_names
from g1_mode_manager.policy_loop.policy_runner import DisengageTo, PolicyLimits
from g1_mode_manager.protocol.remote import KEY_NAMES, key_mask

#: The models set-up extracts from holosoma-inference's pinned wheel (scripts/fetch_assets.py), under the prefix.
POLICY_MODELS = Path("share", "g1_mode_manager", "sim_assets", "policy")


#: recorder_max_total_mb is in MB, as its name and docs/recorder.md say (not MiB).
BYTES_PER_MB = 1_000_000

@dataclass(frozen=True)
class Settings:
    network_interface: str = "lo"
    dds_domain: int = 0
    rpc_timeout_s: float = 1.0
    select_timeout_s: float = 10.0
    release_timeout_s: float = 5.0
    cmd_vel_timeout_s: float = 0.5
    cmd_vel_rate_hz: float = 10.0
    cmd_vel_max_rate_hz: float = 50.0
    move_duration_s: float = 1.0
    not_walking_after_s: float = 2.0
    max_vx: float = 0.8
    max_vy: float = 0.4
    max_wz: float = 1.0
    max_ax: float = 1.5
    max_ay: float = 1.0
    max_awz: float = 3.0
    # --- the autonomy: a planner's velocity, once an operator handed it the robot (core/drive.py) ---
    autonomy_topic: str = "cmd_vel_nav"
    autonomy_stamped: bool = False
    autonomy_timeout_s: float = 0.5
    autonomy_odom_timeout_s: float = 0.5
    autonomy_max_vx: float = 0.5
    autonomy_max_vy: float = 0.3
    autonomy_max_wz: float = 0.8
    autonomy_max_ax: float = 1.0
    autonomy_max_ay: float = 0.7
    autonomy_max_awz: float = 2.0
    arm_ramp_time_s: float = 2.0
    arm_cmd_timeout_s: float = 1.0
    arm_rate_hz: float = 50.0
    arm_kp: float = 60.0
    arm_kd: float = 1.5
    lowcmd_timeout_s: float = 0.1
    lowcmd_damping_rate_hz: float = 50.0
    lowcmd_exit_damping_s: float = 0.2
    link_timeout_s: float = 0.5
    mode_publish_rate_hz: float = 1.0
    mode_change_check_hz: float = 10.0
    diagnostics_rate_hz: float = 1.0
    loco_outcome_timeout_s: float = 3.0
    loco_motion_timeout_s: float = 6.0
    loco_get_up_timeout_s: float = 12.0
    odom_rate_hz: float = 0.0
    odom_frame_id: str = "odom"
    odom_child_frame_id: str = "pelvis"
    odom_publish_tf: bool = True
    estop_call_timeout_s: float = EstopTiming.call_s
    estop_select_timeout_s: float = EstopTiming.select_s
    estop_timeout_s: float = EstopTiming.total_s
    supervise_rate_hz: float = 10.0
    sportmodestate_rate_hz: float = 10.0
    estop_verify_period_s: float = EstopTiming.verify_period_s
    belief_check_period_s: float = EstopTiming.belief_period_s
    # --- head LED / TTS, joint states + IMU, stamped cmd_vel ---
    head_led_enabled: bool = True
    head_led_rate_hz: float = 10.0
    head_led_uninitialized: str = "0 0 0 solid"
    head_led_idle: str = "0 0 255 solid"
    head_led_high_level: str = "0 255 0 pulse 2.0"
    head_led_low_level: str = "255 120 0 pulse 1.0"
    head_led_emergency: str = "255 0 0 flash 0.2"
    head_led_fault: str = "255 80 0 flash 0.5"
    head_led_autonomy: str = "0 255 255 pulse 1.5"
    announce_modes: bool = False
    voice_timeout_s: float = 0.5
    joint_state_rate_hz: float = 0.0
    cmd_vel_stamped: bool = False
    # --- the robot's body: checks (thresholds from core/body/checks.py), FAULT, the remote ---
    body_checks_enabled: bool = True
    body_check_rate_hz: float = 100.0
    body_check_slow_rate_hz: float = 10.0
    tilt_limit_rad: float = BODY_CHECKS["tilt"].threshold
    spin_limit_rad_s: float = BODY_CHECKS["spin"].threshold
    joint_speed_limit_rad_s: float = BODY_CHECKS["joint_speed"].threshold
    winding_limit_c: float = BODY_CHECKS["winding_overheat"].threshold
    casing_limit_c: float = BODY_CHECKS["casing_overheat"].threshold
    winding_critical_c: float = BODY_CHECKS["winding_critical"].threshold
    casing_critical_c: float = BODY_CHECKS["casing_critical"].threshold
    battery_low_pct: float = BODY_CHECKS["battery_low"].threshold
    battery_critical_pct: float = BODY_CHECKS["battery_critical"].threshold
    state_lost_s: float = BODY_CHECKS["state_lost"].threshold
    fault_clear_hold_s: float = 2.0
    remote_estop_keys: str = "L2+B"
    lowcmd_deadman_key: str = ""
    # --- LOW_LEVEL's two paths (core/user_ctrl.py, docs/user_control.md) ---
    low_level_path: str = LowLevelPath.USER_CTRL.value
    user_ctrl_switch_timeout_s: float = UserCtrlConfig.switch_timeout_s
    user_ctrl_hold_kp: float = UserCtrlConfig.hold_kp
    user_ctrl_hold_kd: float = UserCtrlConfig.hold_kd
    user_ctrl_silence: str = UserCtrlConfig.silence.value
    user_ctrl_rest_speed_rad_s: float = UserCtrlConfig.rest_speed_rad_s
    user_ctrl_rest_timeout_s: float = UserCtrlConfig.rest_timeout_s
    user_ctrl_first_frame_s: float = UserCtrlConfig.first_frame_s
    # --- a policy in the node's own loop (policy_loop/policy_runner.py, docs/policies.md) ---
    policy: str = "loco_ppo"
    policy_dir: str = ""
    policy_blend_s: float = PolicyLimits.blend_s
    policy_engage_max_error_rad: float = PolicyLimits.engage_max_error_rad
    policy_state_timeout_s: float = PolicyLimits.state_timeout_s
    policy_overrun_s: float = PolicyLimits.overrun_s
    policy_max_overruns: int = PolicyLimits.max_overruns
    policy_clamp_max_s: float = PolicyLimits.clamp_max_s
    policy_disengage: str = PolicyLimits.disengage.value
    # the remote's keys for the policy (policy_loop/policy_keys.py): unitree_rl_lab's G1 deploy starts its velocity policy
    # on R1+X and stands the robot on L2+Up
    policy_engage_keys: str = "R1+X"
    policy_disengage_keys: str = "L2+Up"
    # --- the flight recorder (flight_recorder/flight_recorder.py, docs/recorder.md) ---
    recorder_enabled: bool = True
    recorder_dir: str = ""
    recorder_window_s: float = 30.0
    recorder_after_s: float = 3.0
    recorder_max_files: int = 50
    recorder_max_total_mb: float = 500.0
    recorder_frame_rate_hz: float = 10.0

    def estop_timing(self) -> EstopTiming:
        return EstopTiming(call_s=self.estop_call_timeout_s, select_s=self.estop_select_timeout_s,
                           total_s=self.estop_timeout_s, verify_period_s=self.estop_verify_period_s,
                           belief_period_s=self.belief_check_period_s, state_fresh_s=self.link_timeout_s)

    def user_ctrl_config(self) -> UserCtrlConfig | None:
        """The user_ctrl path's settings, or None on the release path."""
        if LowLevelPath(self.low_level_path) is LowLevelPath.RELEASE:
            return None
        return UserCtrlConfig(switch_timeout_s=self.user_ctrl_switch_timeout_s, hold_kp=self.user_ctrl_hold_kp,
                              hold_kd=self.user_ctrl_hold_kd, silence=SilenceReaction(self.user_ctrl_silence),
                              rest_speed_rad_s=self.user_ctrl_rest_speed_rad_s,
                              rest_timeout_s=self.user_ctrl_rest_timeout_s,
                              first_frame_s=self.user_ctrl_first_frame_s)

    def policy_limits(self) -> PolicyLimits:
        return PolicyLimits(blend_s=self.policy_blend_s, engage_max_error_rad=self.policy_engage_max_error_rad,
                            state_timeout_s=self.policy_state_timeout_s, overrun_s=self.policy_overrun_s,
                            max_overruns=self.policy_max_overruns,
                            clamp_max_s=self.policy_clamp_max_s, disengage=DisengageTo(self.policy_disengage))

    def policy_models(self) -> Path:
        """Where the built-in policies' models are: ``policy_dir``, or the ones set-up extracted into the prefix."""
        return Path(self.policy_dir).expanduser() if self.policy_dir else Path(sys.prefix) / POLICY_MODELS

    def recorder_config(self, node: str) -> RecorderConfig:
        """The flight recorder's settings; ``node``: the node's full name, for the files' metadata."""
        return RecorderConfig(folder_for(self.recorder_dir), enabled=self.recorder_enabled, window_s=self.recorder_window_s,
                              after_s=self.recorder_after_s, max_files=self.recorder_max_files,
                              max_bytes=int(self.recorder_max_total_mb * BYTES_PER_MB),
                              frame_rate_hz=self.recorder_frame_rate_hz,
                              body_rate_hz=max(self.body_check_rate_hz, self.body_check_slow_rate_hz), node=node)

    def velocity_limits(self) -> VelocityLimits:
        return VelocityLimits(self.max_vx, self.max_vy, self.max_wz, self.max_ax, self.max_ay, self.max_awz)

    def autonomy_limits(self) -> VelocityLimits:
        return VelocityLimits(self.autonomy_max_vx, self.autonomy_max_vy, self.autonomy_max_wz,
                              self.autonomy_max_ax, self.autonomy_max_ay, self.autonomy_max_awz)

    def body_thresholds(self) -> dict[str, float]:
        """Body check name -> threshold, as set."""
        return {check: getattr(self, name) for check, name in BODY_THRESHOLD_PARAMETERS.items()}

    def led_looks(self) -> dict[Mode, str]:
        """The head LED table: one 'R G B pattern period' text per mode."""
        return {mode: getattr(self, name) for mode, name in LED_PARAMETERS.items()}


#: The parameter that holds each mode's head LED look.
LED_PARAMETERS: dict[Mode, str] = {Mode.UNINITIALIZED: "head_led_uninitialized", Mode.IDLE: "head_led_idle",
                                   Mode.HIGH_LEVEL: "head_led_high_level", Mode.LOW_LEVEL: "head_led_low_level",
                                   Mode.EMERGENCY: "head_led_emergency", Mode.FAULT: "head_led_fault"}
#: The parameter that holds each body check's threshold.
BODY_THRESHOLD_PARAMETERS: dict[str, str] = {
    "tilt": "tilt_limit_rad", "spin": "spin_limit_rad_s", "joint_speed": "joint_speed_limit_rad_s",
    "winding_overheat": "winding_limit_c", "casing_overheat": "casing_limit_c",
    "winding_critical": "winding_critical_c", "casing_critical": "casing_critical_c",
    "battery_low": "battery_low_pct", "battery_critical": "battery_critical_pct", "state_lost": "state_lost_s",
}


def declare_settings(node: Node) -> Settings:
    """Declare every parameter (read-only: they are read once at start) and return their values.

    A bad value fails here, at start, with an error naming the parameter: rclpy raises for a wrong type or
    a value out of range, and this raises ValueError for a head LED look it cannot read.
    """
    defaults = {f.name: f.default for f in fields(Settings)}
    from_old_names = read_old_names(node, defaults)
    values = {}
    for name, default in defaults.items():
        if name in from_old_names:  # declared with the old name's value: `ros2 param get` shows what is used
            node.declare_parameter(name, from_old_names[name], descriptor(name, default), ignore_override=True)
        else:
            node.declare_parameter(name, default, descriptor(name, default))
        values[name] = node.get_parameter(name).value
    for name in (*LED_PARAMETERS.values(), "head_led_autonomy"):
        try:
            LedLook.parse(values[name])
        except ValueError as exc:
            raise ValueError(f"parameter {name}: {exc}") from None
    for name, choices in (("low_level_path", LowLevelPath), ("user_ctrl_silence", SilenceReaction),
                          ("policy_disengage", DisengageTo)):
        if values[name] not in {c.value for c in choices}:
            raise ValueError(f"parameter {name}: {values[name]!r} is none of {', '.join(c.value for c in choices)}")
    for name in ("remote_estop_keys", "lowcmd_deadman_key", *REMOTE_COMBINATIONS):
        try:
            parse_keys(values[name])
        except ValueError as exc:
            raise ValueError(f"parameter {name}: {exc}") from None
    if (clash := combination_clash(values)) is not None:
        raise ValueError(clash)
    return Settings(**values)


#: Remote combinations that act on a press. None may hold all of another's keys: a press of the larger would be a
#: press of the smaller too (a key in common, as L2+Up and L2+B have, is fine).
REMOTE_COMBINATIONS = ("remote_estop_keys", "policy_engage_keys", "policy_disengage_keys")
#: Unitree's key names, by their lower case: 'L2+Up' (as unitree_rl_lab writes it) is Unitree's 'L2+up'.
_KEY_NAME = {name.lower(): name for name in KEY_NAMES}


def combination_clash(values: dict[str, object]) -> str | None:
    """Why two of REMOTE_COMBINATIONS cannot both be set as they are (None: they can; '' is off)."""
    masks = {name: parse_keys(str(values[name])) for name in REMOTE_COMBINATIONS}
    for first, second in combinations(REMOTE_COMBINATIONS, 2):
        a, b = masks[first], masks[second]
        if not a or not b or a & b not in (a, b):
            continue
        how = "is the same combination as" if a == b else "holds every key of" if a & b == a else "is part of"
        return (f"parameter {second}: {values[second]!r} {how} {first} {values[first]!r}, so a press of one would act "
                f"as the other; choose combinations neither of which holds all the other's keys")
    return None


def parse_keys(text: str) -> int:
    """'L2+B' -> the remote's key mask (names in any case); '' -> 0 (off). Raises ValueError naming an unknown key."""
    names = [_KEY_NAME.get(part.strip().lower(), part.strip()) for part in text.split("+") if part.strip()]
    return key_mask(names) if names else 0
