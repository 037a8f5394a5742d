"""What the policy loop's ticks cost and how regular they are, for its status topic: a reader can tell a slow
policy (inference) from a slow machine (the tick's period) and count the overruns; and what the robot gets of it:
how old the state a frame was computed from is when the frame is written (from the robot's publication of that
state, its DDS source timestamp), and how evenly the frames follow one another."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

#: Ticks the percentiles are taken over (10 s at 50 Hz).
WINDOW = 500


@dataclass
class TickStats:
    periods_s: deque[float] = field(default_factory=lambda: deque(maxlen=WINDOW))
    inference_s: deque[float] = field(default_factory=lambda: deque(maxlen=WINDOW))
    tick_s: deque[float] = field(default_factory=lambda: deque(maxlen=WINDOW))
    #: the state sample's publication by the robot to the frame computed from it written, s
    state_to_frame_s: deque[float] = field(default_factory=lambda: deque(maxlen=WINDOW))
    #: between two frames of the loop's written in a row, s
    frame_gaps_s: deque[float] = field(default_factory=lambda: deque(maxlen=WINDOW))
    last_frame_at: float | None = None
    ticks: int = 0
    overruns: int = 0
    overruns_in_a_row: int = 0
    skipped: int = 0  # shadow ticks without a fresh sample (nothing sent in the shadow)

    def add(self, period_s: float, inference_s: float, tick_s: float, overrun_s: float) -> int:
        """Count one tick; returns the overruns in a row (a tick whose work took longer than ``overrun_s``)."""
        self.ticks += 1
        self.periods_s.append(period_s)
        self.inference_s.append(inference_s)
        self.tick_s.append(tick_s)
        if tick_s > overrun_s:
            self.overruns += 1
            self.overruns_in_a_row += 1
        else:
            self.overruns_in_a_row = 0
        return self.overruns_in_a_row

    def frame_written(self, at: float, state_published: float, period_s: float) -> None:
        """A frame of the loop's went out at ``at`` (monotonic s), computed from a state the robot published at
        ``state_published`` (NaN: not known); a gap longer than two periods starts a new run (the loop did not
        send in between)."""
        if np.isfinite(state_published):
            self.state_to_frame_s.append(at - state_published)
        if self.last_frame_at is not None and at - self.last_frame_at <= 2.0 * period_s:
            self.frame_gaps_s.append(at - self.last_frame_at)
        self.last_frame_at = at

    def frame_not_written(self) -> None:
        self.last_frame_at = None

    def p99(self, values: deque[float]) -> float:
        return float(np.percentile(values, 99)) if values else 0.0

    def percentiles(self, values: deque[float], *qs: float) -> tuple[float, ...]:
        """The ``qs`` percentiles of ``values`` (0 each when empty)."""
        if not values:
            return (0.0,) * len(qs)
        return tuple(float(v) for v in np.percentile(values, qs))

    def rate_hz(self) -> float:
        return 1.0 / float(np.mean(self.periods_s)) if self.periods_s else 0.0
