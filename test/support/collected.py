"""Every sample of a low-rate SDK topic, taken by a listener in the test process (20 Hz of sim time: cheap)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from unitree_sdk2py.core.channel import ChannelSubscriber


@dataclass
class Collected:
    topic: str
    idl_type: type
    samples: list[Any] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._sub = ChannelSubscriber(self.topic, self.idl_type)
        self._sub.Init(self.samples.append, 50)
