"""The console's picture of the robot: what the page shows and plots, from the node's public topics."""

from __future__ import annotations

import math
from types import SimpleNamespace

from fakes.fake_clock import FakeClock
from g1_mode_manager.console.robot_view import (
    AUTONOMY_LOOK,
    DIAGNOSTICS_STALE_S,
    MODE_SILENT_S,
    DiagStatus,
    RobotView,
    mode_fields,
)
from g1_mode_manager.display.head_led import LedLook


def mode_msg(name: str = "HIGH_LEVEL", value: int = 2, **overrides) -> SimpleNamespace:
    fields = dict(mode=value, name=name, transition_in_progress=False, transition_target=0,
                  high_level_service_known=True, high_level_service_active=True, damp_confirmed=False, link_ok=True,
                  last_refusal="", last_error="", robot_mismatch="", reasserts=0, faults=[], holds=[], warnings=[],
                  driver="teleop", autonomy_suspended="", posture="standing")
    fields.update(overrides)
    return SimpleNamespace(**fields)


def diagnostics(moves_sent: int, commanded: float, tilt: str = "0.050") -> list[DiagStatus]:
    prefix = "g1_mode_manager: "
    return [DiagStatus(prefix + "robot link", 0, "rt/lowstate and rt/sportmodestate fresh", {}),
            DiagStatus(prefix + "commands", 0, "0 dropped", {"moves_sent": str(moves_sent)}),
            DiagStatus(prefix + "walking", 0, "", {"commanded_mps": f"{commanded:.3f}"}),
            DiagStatus(prefix + "body tilt", 0, "ok", {"value": tilt, "threshold": "1", "unit": "rad", "state": "ok"}),
            DiagStatus(prefix + "body battery_low", 0, "ok", {"value": "87.000", "threshold": "20", "unit": "%",
                                                              "state": "ok"}),
            DiagStatus(prefix + "body winding_overheat", 0, "ok", {"value": "", "threshold": "120", "unit": "°C",
                                                                   "state": "no data"})]


def test_driving_is_blocked_unless_the_node_is_fresh_in_high_level_and_free_to_move() -> None:
    clock, view = FakeClock(), RobotView()
    assert view.drive_block(clock()) == "no ~/mode from the mode manager"
    view.on_mode(mode_fields(mode_msg("IDLE", 1)), clock())
    assert "needs HIGH_LEVEL" in view.drive_block(clock())
    view.on_mode(mode_fields(mode_msg(transition_in_progress=True, transition_target=3)), clock())
    assert view.drive_block(clock()) == "a transition is in progress"
    view.on_mode(mode_fields(mode_msg(holds=["battery_critical: 8 % < 10"])), clock())
    assert view.drive_block(clock()).startswith("motion held")
    view.on_mode(mode_fields(mode_msg()), clock())
    assert view.drive_block(clock()) is None
    clock.advance(MODE_SILENT_S + 0.1)  # the node went silent (it publishes ~/mode at 1 Hz)
    assert view.drive_block(clock()) == "no ~/mode from the mode manager"
    assert not view.snapshot(clock())["mode_fresh"]


def test_snapshot_shows_the_mode_in_its_led_look_and_the_body_values() -> None:
    clock, view = FakeClock(), RobotView()
    view.set_looks({"EMERGENCY": LedLook.parse("255 0 0 flash 0.2")})
    view.on_mode(mode_fields(mode_msg("EMERGENCY", 4, damp_confirmed=True, transition_target=9,
                                      posture="lying_back")), clock())
    view.on_diagnostics(diagnostics(5, 0.0), clock())
    snap = view.snapshot(clock())
    assert snap["mode"]["name"] == "EMERGENCY" and snap["mode"]["damp_confirmed"]
    assert snap["mode"]["posture"] == "lying_back"  # the posture ~/mode read from the robot's body
    assert snap["mode"]["transition_target"] == "9"  # not a mode: shown as the number
    assert snap["led"] == {"rgb": [255, 0, 0], "pattern": "flash", "period_s": 0.2}
    assert snap["body"]["battery_pct"] == 87.0 and snap["body"]["tilt_rad"] == 0.05
    assert snap["body"]["winding_max_c"] is None  # no data: unknown, not 0
    assert snap["link"]["message"].startswith("rt/lowstate")


def test_plot_samples_take_each_value_from_its_freshest_source() -> None:
    clock, view = FakeClock(), RobotView(history_len=3)
    view.on_diagnostics(diagnostics(10, 0.4), clock())  # first message: no baseline for moves_sent
    point = view.sample(clock(), 0.0, (0.3, 0.4, 0.1))
    assert point["cmd"] == 0.5 and point["cmd_wz"] == 0.1 and point["ack"] == 0.0
    assert point["meas"] is None and point["tilt"] == 0.05  # the body check's value: no IMU, no odometry
    view.on_diagnostics(diagnostics(15, 0.4), clock())  # Moves acknowledged since the last message
    view.on_odom(0.3, 0.0, (math.cos(0.05), math.sin(0.05), 0.0, 0.0), clock())  # 0.1 rad about x
    point = view.sample(clock(), 0.1, None)
    assert point["cmd"] == 0.0 and point["ack"] == 0.4 and point["meas"] == 0.3
    assert abs(point["tilt"] - 0.1) < 1e-3
    view.on_imu((math.cos(0.1), 0.0, math.sin(0.1), 0.0), clock())  # the IMU wins: 0.2 rad about y
    assert abs(view.sample(clock(), 0.2, None)["tilt"] - 0.2) < 1e-3
    clock.advance(1.0)  # odometry and IMU stale: back to the body check's value
    point = view.sample(clock(), 1.2, None)
    assert point["meas"] is None and point["tilt"] == 0.05
    assert [p["t"] for p in view.history()] == [0.1, 0.2, 1.2]  # bounded


def driver_status(driver: str, suspended: str = "", command: tuple[float, float, float] | None = None) -> DiagStatus:
    """The node's "driver" status: the autonomy's command only while it drives."""
    values = {"driver": driver, "autonomy_suspended": suspended}
    if command is not None:
        values.update(zip(("autonomy_vx", "autonomy_vy", "autonomy_wz"), (f"{c:.3f}" for c in command), strict=True))
    return DiagStatus("g1_mode_manager: driver", 1 if suspended else 0, f"the {driver} drives", values)


def test_who_drives_reaches_the_page_and_the_autonomy_s_command_is_plotted_while_it_drives() -> None:
    clock, view = FakeClock(), RobotView()
    view.on_mode(mode_fields(mode_msg(driver="autonomy", autonomy_suspended="silent: no cmd_vel_nav for 0.5 s")),
                 clock())
    mode = view.snapshot(clock())["mode"]
    assert mode["driver"] == "autonomy" and mode["autonomy_suspended"] == "silent: no cmd_vel_nav for 0.5 s"
    assert view.sample(clock(), 0.0, None)["auto"] is None  # no driver status yet: a gap, not 0
    view.on_diagnostics([*diagnostics(3, 0.3), driver_status("autonomy", command=(0.3, -0.4, 0.2))], clock())
    point = view.sample(clock(), 0.1, (0.1, 0.0, 0.0))
    assert point["auto"] == 0.5 and point["cmd"] == 0.1  # the planner's speed in the plane, beside this console's
    view.on_diagnostics([driver_status("autonomy", "suspended: odometry 0.80 s old", (0.2, 0.0, 0.0))], clock())
    assert view.sample(clock(), 0.2, None)["auto"] == 0.2  # suspended: its command still shown (the robot stops)
    view.on_diagnostics([driver_status("teleop")], clock())  # taken over: the autonomy commands nothing
    assert view.sample(clock(), 0.3, None)["auto"] is None
    view.on_diagnostics([driver_status("autonomy", command=(0.25, 0.0, 0.0))], clock())
    clock.advance(DIAGNOSTICS_STALE_S + 0.1)  # the node's diagnostics went silent
    assert view.sample(clock(), 3.5, None)["auto"] is None


def test_the_head_shows_the_autonomy_s_led_look_while_it_drives_in_high_level() -> None:
    clock, view = FakeClock(), RobotView()
    view.set_looks({"HIGH_LEVEL": LedLook.parse("0 255 0 pulse 2.0"), AUTONOMY_LOOK: LedLook.parse("0 255 255 pulse 1.5")})
    view.on_mode(mode_fields(mode_msg()), clock())
    assert view.snapshot(clock())["led"] == {"rgb": [0, 255, 0], "pattern": "pulse", "period_s": 2.0}
    view.on_mode(mode_fields(mode_msg(driver="autonomy")), clock())
    assert view.snapshot(clock())["led"] == {"rgb": [0, 255, 255], "pattern": "pulse", "period_s": 1.5}
