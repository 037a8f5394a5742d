"""What the policy loop's ticks cost and how regular they are, for its status topic: a reader can tell a slow
policy (inference) from a slow machine (the tick's period) and count the overruns."""

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

    def p99(self, values: deque[float]) -> float:
        return float(np.percentile(values, 99)) if values else 0.0

    def rate_hz(self) -> float:
        return 1.0 / float(np.mean(self.periods_s)) if self.periods_s else 0.0
