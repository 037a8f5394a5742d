"""The node's log lines for what its parts report, and the counters that /diagnostics shows; each line and each
transition attempt is also kept by the flight recorder."""

from __future__ import annotations

from rclpy.impl.rcutils_logger import RcutilsLogger

from g1_mode_manager.core.events import LogFn, RelayEvents
from g1_mode_manager.core.records import Result, TransitionRecord
from g1_mode_manager.flight_recorder.flight_recorder import FlightRecorder


def log_to(logger: RcutilsLogger) -> LogFn:
    """(level, text) -> ``logger``."""

    def write(level: str, text: str) -> None:
        # one call site per severity: rclpy refuses a second severity from the same line
        if level == "info":
            logger.info(text)
        elif level == "warn":
            logger.warn(text)
        else:
            logger.error(text)

    return write


class NodeLog:
    """Writes to the node's logger; ``events`` counts (and throttles) what the relays report."""

    def __init__(self, logger: RcutilsLogger, recorder: FlightRecorder | None = None) -> None:
        self._logger = logger
        self._write = log_to(logger)
        self._recorder = recorder
        self.events = RelayEvents(self.relay)

    def relay(self, level: str, text: str) -> None:
        if self._recorder is not None:
            self._recorder.note(level, text)
        self._write(level, text)

    def worker_error(self, exc: BaseException) -> None:
        self.events.count("relay_errors")
        self.relay("error", f"relay error (relay keeps running): {exc!r}")

    def record(self, record: TransitionRecord) -> None:
        """Every transition attempt, legal or not, with its outcome: info, warn (refused) or error (failed)."""
        if self._recorder is not None:
            self._recorder.attempt(record)
        text = (f"transition {record.source.name} -> {record.target.name}: {record.outcome.value} in "
                f"{record.duration_s * 1000:.0f} ms: {record.message}")
        if record.outcome is Result.OK:
            self._logger.info(text)
        elif record.outcome in (Result.REFUSED, Result.REGISTERED):
            self._logger.warn(text)
        else:
            self._logger.error(text)

    def alarm(self, text: str) -> None:
        self.events.count("supervision_alarms")
        self.relay("error", text)
