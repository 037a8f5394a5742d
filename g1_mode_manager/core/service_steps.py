"""The two motion-switcher procedures the modes need: make the high-level service active, release it.

Both poll CheckMode within a bounded time and take the clock and sleep from the caller, so tests
run on fake time and a preemptible caller can interrupt the sleep.
"""

from __future__ import annotations

from collections.abc import Callable

from g1_mode_manager.core.port import ModePort
from g1_mode_manager.protocol.api_ids import HIGH_LEVEL_SERVICE_NAME


class StepTimeoutError(Exception):
    """A step gave up on its own (a timeout), as opposed to a robot call returning an error."""


def ensure_service_active(
    port: ModePort,
    *,
    timeout_s: float,
    poll_interval_s: float,
    clock: Callable[[], float],
    sleep: Callable[[float], None],
    on_selected: Callable[[], None] | None = None,
) -> bool:
    """Make sure a high-level service is active: SelectMode("ai") only if none is, then confirm.

    Returns True if SelectMode was sent: the robot then comes back limp, in zero torque.
    ``on_selected`` runs the moment SelectMode answered, before the confirmation (the e-stop's Damp: from
    then on no damping frame holds the robot, and a CheckMode round trip would leave it limp meanwhile).
    Raises StepTimeoutError if CheckMode still reports no service ``timeout_s`` after starting.
    """
    deadline = clock() + timeout_s
    if port.check_mode():
        return False
    port.select_mode(HIGH_LEVEL_SERVICE_NAME)
    if on_selected is not None:
        on_selected()
    while not port.check_mode():
        if clock() >= deadline:
            raise StepTimeoutError(f"high-level service still not active {timeout_s:g} s after SelectMode('ai')")
        sleep(poll_interval_s)
    return True


def release_service(
    port: ModePort,
    *,
    timeout_s: float,
    poll_interval_s: float,
    clock: Callable[[], float],
    sleep: Callable[[float], None],
) -> int:
    """ReleaseMode, repeatedly, until CheckMode reports "" (Unitree's official low-level entry).

    Returns how many ReleaseMode calls were sent. Raises StepTimeoutError after ``timeout_s``.
    """
    deadline = clock() + timeout_s
    releases = 0
    while port.check_mode():
        if clock() >= deadline:
            raise StepTimeoutError(f"high-level service still active after {timeout_s:g} s")
        port.release_mode()
        releases += 1
        sleep(poll_interval_s)
    return releases
