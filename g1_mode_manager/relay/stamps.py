"""How old a stamped command is, ROS-free (a TwistStamped's header.stamp against the node's clock)."""

from __future__ import annotations

_NS_PER_S = 1_000_000_000


def stamp_age_s(now_ns: int, stamp_sec: int, stamp_nanosec: int) -> float:
    """Seconds from the stamp to now (negative for a stamp in the future: another machine's clock ahead).

    A zero stamp (sender never set it) counts as infinitely old: it cannot prove the command is fresh.
    """
    if stamp_sec == 0 and stamp_nanosec == 0:
        return float("inf")
    return (now_ns - (stamp_sec * _NS_PER_S + stamp_nanosec)) / _NS_PER_S
