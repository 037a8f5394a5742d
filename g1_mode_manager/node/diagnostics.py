"""/diagnostics for the mode manager: link health, mode, command counters, walking, driver, policy, recorder."""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from g1_mode_manager.core.drive import Driver
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.records import MachineStatus
from g1_mode_manager.flight_recorder.flight_recorder import RecorderReport
from g1_mode_manager.policy_loop.policy_runner import PolicyRunner
from g1_mode_manager.relay.drive_sources import Driving
from g1_mode_manager.relay.link_health import LinkReport
from g1_mode_manager.relay.walk_judge import WalkReport


def _kv(key: str, value: object) -> KeyValue:
    return KeyValue(key=key, value="" if value is None else (f"{value:.3f}" if isinstance(value, float) else str(value)))


def build_diagnostics(stamp, hardware_id: str, status: MachineStatus, link: LinkReport,
                      counts: dict[str, int]) -> DiagnosticArray:
    """Three statuses: the robot link (ERROR when lost), the mode, and the command streams."""
    link_status = DiagnosticStatus(name="g1_mode_manager: robot link", hardware_id=hardware_id)
    if not link.connected:
        link_status.level, link_status.message = DiagnosticStatus.OK, link.reason
    elif link.ok and link.lowstate_age_s is None:
        link_status.level = DiagnosticStatus.OK
        link_status.message = "rt/sportmodestate fresh (rt/lowstate not subscribed: nothing needs it now)"
    elif link.ok:
        link_status.level, link_status.message = DiagnosticStatus.OK, "rt/lowstate and rt/sportmodestate fresh"
    else:
        link_status.level, link_status.message = DiagnosticStatus.ERROR, f"robot link lost: {link.reason}; forwarding stopped"
    link_status.values = [
        _kv("lowstate_age_s", link.lowstate_age_s),
        _kv("sportmodestate_age_s", link.sportstate_age_s),
        _kv("rpc_failures", counts.get("rpc_failures", 0)),
    ]

    mode_status = DiagnosticStatus(name="g1_mode_manager: mode", hardware_id=hardware_id)
    if status.mode is Mode.EMERGENCY:
        mode_status.level = DiagnosticStatus.OK if status.damp_confirmed else DiagnosticStatus.ERROR
        mode_status.message = (
            "EMERGENCY, robot seen damped" if status.damp_confirmed
            else "EMERGENCY, robot NOT seen damped: supervision is re-damping it"
        )
    elif status.mode is Mode.FAULT:
        mode_status.level = DiagnosticStatus.ERROR
        damped = "robot seen damped" if status.damp_confirmed else "robot NOT seen damped yet: the protective stop goes on"
        mode_status.message = f"FAULT ({', '.join(status.faults)}); {damped}; ~/clear_fault once every check is clear"
    elif status.holds:
        mode_status.level = DiagnosticStatus.ERROR
        mode_status.message = f"{status.mode.name}, motion held ({', '.join(status.holds)}); ~/clear_fault releases it"
    elif status.robot_mismatch:
        mode_status.level = DiagnosticStatus.ERROR
        mode_status.message = f"{status.mode.name}: {status.robot_mismatch}; nothing forwarded until a mode is requested"
    else:
        mode_status.level, mode_status.message = DiagnosticStatus.OK, status.mode.name
    mode_status.values = [
        _kv("mode", status.mode.name),
        _kv("transition_in_progress", status.transition_in_progress),
        _kv("high_level_service", "unknown" if not status.service_known else
            ("active" if status.service_active else "released")),
        _kv("last_refusal", status.last_refusal),
        _kv("last_error", status.last_error),
        _kv("robot_mismatch", status.robot_mismatch),
        _kv("damp_confirmed", status.damp_confirmed),
        _kv("reasserts", status.reasserts),
        _kv("faults", "; ".join(status.faults)),
        _kv("holds", "; ".join(status.holds)),
    ]

    refused = sum(v for k, v in counts.items() if k.endswith(("_dropped", "_rejected")))
    streams = DiagnosticStatus(name="g1_mode_manager: commands", hardware_id=hardware_id)
    streams.level = DiagnosticStatus.OK
    streams.message = f"{refused} commands dropped or rejected"
    streams.values = [_kv(k, v) for k, v in sorted(counts.items())]
    return DiagnosticArray(header=_header(stamp), status=[link_status, mode_status, streams])


def walk_status(report: WalkReport, hardware_id: str) -> DiagnosticStatus:
    """Whether the robot walks when it acknowledges Moves (relay/walk_judge.py): WARN while it does not."""
    st = DiagnosticStatus(name="g1_mode_manager: walking", hardware_id=hardware_id)
    if report.warning:
        st.level, st.message = DiagnosticStatus.WARN, report.warning
    elif report.judged:
        st.level, st.message = DiagnosticStatus.OK, "Moves acknowledged and the odometry shows the robot walking"
    else:
        st.level = DiagnosticStatus.OK
        st.message = "not judged: no Move acknowledged lately, or no fresh odometry from the robot"
    st.values = [_kv("commanded_mps", report.commanded[0]), _kv("commanded_radps", report.commanded[1]),
                 _kv("measured_mps", report.measured[0]), _kv("measured_radps", report.measured[1])]
    return st


def drive_status(driving: Driving, hardware_id: str) -> DiagnosticStatus:
    """Who drives; WARN while the autonomy drives but its commands do not move the robot (suspended, silent)."""
    st = DiagnosticStatus(name="g1_mode_manager: driver", hardware_id=hardware_id)
    st.level = DiagnosticStatus.WARN if driving.autonomy_suspended else DiagnosticStatus.OK
    suspended = f": {driving.autonomy_suspended}" if driving.autonomy_suspended else ""
    st.message = {Driver.NOBODY: "nobody drives: velocity commands pass only in HIGH_LEVEL",
                  Driver.TELEOP: "the teleop drives (cmd_vel)",
                  Driver.AUTONOMY: f"the autonomy drives{suspended}"}[driving.driver]
    command = driving.autonomy_command
    st.values = [_kv("driver", driving.driver.value), _kv("autonomy_suspended", driving.autonomy_suspended),
                 *([] if command is None else [_kv("autonomy_vx", command.vx), _kv("autonomy_vy", command.vy),
                                               _kv("autonomy_wz", command.wz)])]
    return st


def _header(stamp):
    from std_msgs.msg import Header

    return Header(stamp=stamp)


def policy_status(runner: PolicyRunner, hardware_id: str) -> DiagnosticStatus:
    """The policy in the node's loop: OK while none runs or it runs without overruns, WARN with overruns or after
    the loop stopped it on a fault of its own (until the next load)."""
    st = DiagnosticStatus(name="g1_mode_manager: policy", hardware_id=hardware_id)
    controller, stats = runner.controller, runner.stats
    name = "" if controller is None else controller.name
    st.level = DiagnosticStatus.WARN if runner.last_fault or (runner.ticking() and stats.overruns) else \
        DiagnosticStatus.OK
    st.message = f"{name or 'no policy'}: {runner.phase.value}" + (f"; stopped: {runner.last_fault}"
                                                                     if runner.last_fault else "")
    st.values = [_kv("policy", name), _kv("phase", runner.phase.value), _kv("rate_hz", f"{stats.rate_hz():.1f}"),
                 _kv("inference_p99_ms", f"{stats.p99(stats.inference_s) * 1e3:.2f}"),
                 _kv("tick_p99_ms", f"{stats.p99(stats.tick_s) * 1e3:.2f}"), _kv("overruns", stats.overruns),
                 _kv("last_fault", runner.last_fault),
                 _kv("clamped", ", ".join(f"{j} {n}" for j, n in runner.clamp.clamped().items()))]
    return st


def recorder_status(report: RecorderReport, hardware_id: str) -> DiagnosticStatus:
    """The flight recorder: its last incident file, or WARN while incidents cannot be written (the robot is not
    affected: the node runs on, unrecorded)."""
    st = DiagnosticStatus(name="g1_mode_manager: recorder", hardware_id=hardware_id)
    if not report.enabled:
        st.level, st.message = DiagnosticStatus.OK, "off (recorder_enabled false): nothing is kept"
    elif report.error:
        st.level, st.message = DiagnosticStatus.WARN, f"incidents cannot be written: {report.error}"
    else:
        st.level = DiagnosticStatus.OK
        st.message = (f"last incident: {report.last_file} ({report.last_cause})" if report.last_file
                      else "recording; no incident written yet")
    st.values = [_kv("folder", report.folder), _kv("last_file", report.last_file), _kv("last_cause", report.last_cause),
                 _kv("pending", report.pending), _kv("written", report.written), _kv("error", report.error),
                 _kv("kept_events", report.kept_events), _kv("kept_kb", f"{report.kept_bytes / 1024:.0f}")]
    return st
