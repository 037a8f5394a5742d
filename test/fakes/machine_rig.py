"""A mode machine wired to a fake robot, with everything it reports collected for assertions."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from fakes.fake_clock import FakeClock
from fakes.fake_robot import ACTIVE, FakeRobot
from g1_mode_manager.core.machine import MachineStatus, ModeMachine, TransitionRecord
from g1_mode_manager.core.modes import Mode


@dataclass
class Rig:
    robot: FakeRobot
    machine: ModeMachine
    clock: FakeClock | None
    records: list[TransitionRecord] = field(default_factory=list)
    statuses: list[MachineStatus] = field(default_factory=list)

    def bring_to(self, mode: Mode) -> None:
        """Reach ``mode`` the ordinary way (asserting it worked); the call log is kept."""
        if mode is Mode.UNINITIALIZED:
            return
        if mode is Mode.FAULT:  # entered by a body check, never requested
            self.bring_to(Mode.HIGH_LEVEL)
            assert self.machine.fault(("tilt: 1.32 rad > 1",))
            assert self.wait_damp_confirmed(), self.machine.status()
            return
        outcome = self.machine.estop() if mode is Mode.EMERGENCY else self.machine.request(mode)
        assert outcome.success, outcome
        assert self.machine.mode is mode


    def wait_damp_confirmed(self, timeout_s: float = 5.0) -> bool:
        return damp_confirmed_within(self.machine, timeout_s)


def damp_confirmed_within(machine: ModeMachine, timeout_s: float = 5.0) -> bool:
    """A stop's sequence runs in a thread of its own: wait (real time) until it verified the robot damped."""
    deadline = time.monotonic() + timeout_s
    while not machine.status().damp_confirmed:
        if time.monotonic() > deadline:
            return False
        time.sleep(0.001)
    return True


def make_rig(service: str = ACTIVE, *, real_time: bool = False, **machine_kwargs: object) -> Rig:
    """A fresh fake robot (``service`` active) and machine; fake time unless ``real_time``. ``on_record`` and
    ``on_change`` in ``machine_kwargs`` replace the rig's collectors."""
    robot = FakeRobot(service)
    clock = None if real_time else FakeClock()
    rig = Rig(robot=robot, machine=None, clock=clock)  # type: ignore[arg-type]
    timing = {"clock": time.monotonic, "sleep": time.sleep} if clock is None else {"clock": clock, "sleep": clock.sleep}
    machine_kwargs.setdefault("on_record", rig.records.append)
    machine_kwargs.setdefault("on_change", rig.statuses.append)
    rig.machine = ModeMachine(
        robot,
        **timing,  # type: ignore[arg-type]
        **machine_kwargs,  # type: ignore[arg-type]
    )
    return rig
