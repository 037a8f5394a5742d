"""The node's log lines for what its parts report, and the counters that /diagnostics shows."""

from __future__ import annotations

from rclpy.impl.rcutils_logger import RcutilsLogger

from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.records import Result, TransitionRecord


class NodeLog:
    """Writes to the node's logger; ``events`` counts (and throttles) what the relays report."""

    def __init__(self, logger: RcutilsLogger) -> None:
        self._logger = logger
        self.events = RelayEvents(self.relay)

    def relay(self, level: str, text: str) -> None:
        # one call site per severity: rclpy refuses a second severity from the same line
        if level == "info":
            self._logger.info(text)
        elif level == "warn":
            self._logger.warn(text)
        else:
            self._logger.error(text)

    def worker_error(self, exc: BaseException) -> None:
        self.events.count("relay_errors")
        self._logger.error(f"relay error (relay keeps running): {exc!r}")

    def record(self, record: TransitionRecord) -> None:
        """Every transition attempt, legal or not, with its outcome: info, warn (refused) or error (failed)."""
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
        self._logger.error(text)
