"""The node's side of the body checks: the body watch's thread and what /diagnostics shows of each check
(~/clear_fault, which releases what they latched, is served with the other services in services.py). The thread
also runs, after each step, whatever else reads the robot's remote (``on_step``)."""

from __future__ import annotations

import time
from collections.abc import Callable

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from g1_mode_manager.core.body.checks import BY_NAME, Reaction
from g1_mode_manager.core.body.monitor import BodyMonitor, CheckStatus
from g1_mode_manager.core.body.motion_allowance import MotionRecord
from g1_mode_manager.core.body.readings import BodyReadings
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.machine import ModeMachine
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import RobotPort
from g1_mode_manager.node.settings import Settings, parse_keys
from g1_mode_manager.relay.body_watch import BodyWatch
from g1_mode_manager.relay.periodic import PeriodicWorker

_LEVELS = {"fault": DiagnosticStatus.ERROR, "hold": DiagnosticStatus.ERROR, "warn": DiagnosticStatus.WARN,
           "no data": DiagnosticStatus.STALE}


class BodySupervision:
    def __init__(self, port: RobotPort, machine: ModeMachine, events: RelayEvents, settings: Settings,
                 on_error: Callable[[BaseException], None], motion: MotionRecord | None = None) -> None:
        s = settings
        self.monitor = BodyMonitor(clear_hold_s=s.fault_clear_hold_s, thresholds=s.body_thresholds())
        self.watch = BodyWatch(port, machine, self.monitor, events, estop_keys=parse_keys(s.remote_estop_keys),
                               deadman_keys=parse_keys(s.lowcmd_deadman_key),
                               fast_period_s=1.0 / s.body_check_rate_hz, slow_period_s=1.0 / s.body_check_slow_rate_hz,
                               enabled=s.body_checks_enabled, motion=motion)
        #: what else reads the remote at the watch's rate, after its step (set by whoever builds it: the policy's keys)
        self.on_step: Callable[[], None] = lambda: None
        #: each step's readings, the checks' states (core/body/monitor.py) and when the step began (before it acted
        #: on them), e.g. for the flight recorder
        self.on_reading: Callable[[BodyReadings, tuple[str, ...], float], None] = lambda *_: None
        self._worker = PeriodicWorker("body_watch", s.body_check_rate_hz, self._step, on_error,
                                      period_s=self.watch.period_s)

    def _step(self, _dt_s: float) -> None:
        began = time.monotonic()
        self.watch.step()
        self.on_reading(self.watch.readings, self.monitor.states(), began)
        self.on_step()

    def start(self) -> None:
        self._worker.start()

    def stop(self) -> None:
        self._worker.stop()

    def diagnostics(self, hardware_id: str, mode: Mode) -> list[DiagnosticStatus]:
        """One status per check: its value, threshold, state and what it does in the current mode."""
        return [self._status(c, hardware_id, mode) for c in self.monitor.statuses()]

    @staticmethod
    def _status(c: CheckStatus, hardware_id: str, mode: Mode) -> DiagnosticStatus:
        check = BY_NAME[c.check]
        status = DiagnosticStatus(name=f"g1_mode_manager: body {c.check}", hardware_id=hardware_id)
        status.level = _LEVELS.get(c.state, DiagnosticStatus.OK)
        status.message = f"{c.state}: {c.text}" if c.text else c.state
        value = "" if c.value is None else f"{c.value:.3f}"
        status.values = [KeyValue(key="value", value=value), KeyValue(key="threshold", value=f"{c.threshold:g}"),
                         KeyValue(key="unit", value=c.unit), KeyValue(key="state", value=c.state),
                         KeyValue(key="reaction_now", value=check.reaction(mode).name.lower()),
                         KeyValue(key="latched", value="" if c.latched is Reaction.NONE else c.latched.name.lower()),
                         KeyValue(key="reference", value=check.reference)]
        return status
