"""The mode is decided once per frame: on the forward path a cmd_vel message and a ~/lowcmd frame take the
machine's state lock once, under the forward gate, and nothing before or after asks the mode again.

The real ModeMachine, LinkHealth and relays against the fake port, called the way their threads call them
(cmd_vel: ``submit`` then the sender's ``step``; ~/lowcmd: ``submit``, which writes). Every lock they create
counts its acquisitions (fakes/counting_locks.py). ``python test/relay/test_locks_per_frame.py`` prints the
count of every lock per message (and per ~/arm_cmd frame), up to the write and in all; docs/figures.md keeps the figures.
"""

from __future__ import annotations

import sys
from collections import Counter
from collections.abc import Callable
from pathlib import Path

if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fakes.counting_locks import counting_locks
from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.machine import ModeMachine
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.velocity import VelocityLimits
from g1_mode_manager.relay.arm import ArmRelay
from g1_mode_manager.relay.cmd_vel import CmdVelRelay
from g1_mode_manager.relay.link_health import LinkHealth
from g1_mode_manager.relay.lowcmd import LowCmdRelay

STATE_LOCK = "core/machine/state.py: self.lock"
GATE_LOCK = "core/machine/gate.py: self.lock"
#: Steep enough that every command is a Move of its own (no ramp steps, no keep-alive skipped).
LIMITS = VelocityLimits(max_vx=0.8, max_vy=0.4, max_wz=1.0, max_ax=100.0, max_ay=100.0, max_awz=100.0)
KNEE = ["left_knee_joint"], [0.5], [], [], [100.0], [1.0]
MESSAGES = 20


def _per_message(counts: Counter[str], port: FakeRobotPort, write: str, send: Callable[[int], None],
                 ) -> tuple[Counter[str], Counter[str]]:
    """The locks taken per message (up to the port's write, and in all), averaged over MESSAGES; each message
    must reach the port."""
    written = getattr(port, write)
    to_write: Counter[str] = Counter()
    marks: list[Counter[str]] = []

    def noted(*args: object) -> object:
        marks.append(Counter(counts))
        return written(*args)

    setattr(port, write, noted)
    total: Counter[str] = Counter()
    for i in range(MESSAGES):
        start = Counter(counts)
        send(i)
        assert len(marks) == i + 1, f"message {i} was not written"
        to_write += marks[-1] - start
        total += Counter(counts) - start
    return (Counter({k: v // MESSAGES for k, v in to_write.items()}),
            Counter({k: v // MESSAGES for k, v in total.items()}))


def cmd_vel_locks() -> tuple[Counter[str], Counter[str]]:
    with counting_locks() as counts:
        port = FakeRobotPort()
        machine = ModeMachine(port)
        relay = CmdVelRelay(port, machine, LinkHealth(port, machine, 0.5), RelayEvents(lambda *_: None),
                            limits=LIMITS, timeout_s=5.0, move_duration_s=1.0, rate_hz=10.0, max_rate_hz=50.0)
    assert machine.request(Mode.HIGH_LEVEL).success

    def send(i: int) -> None:
        relay.submit(0.3 + 0.1 * (i % 2), 0.0, 0.0)
        relay.step()

    return _per_message(counts, port, "send_velocity", send)


def lowcmd_locks() -> tuple[Counter[str], Counter[str]]:
    with counting_locks() as counts:
        port = FakeRobotPort()
        machine = ModeMachine(port)
        relay = LowCmdRelay(port, machine, LinkHealth(port, machine, 0.5), RelayEvents(lambda *_: None),
                            silence_timeout_s=0.1, exit_damping_s=0.2, service_active=lambda: False)
    assert machine.request(Mode.LOW_LEVEL).success
    return _per_message(counts, port, "write_lowcmd", lambda _i: relay.submit(*KNEE))


def arm_locks() -> tuple[Counter[str], Counter[str]]:
    with counting_locks() as counts:
        port = FakeRobotPort()
        machine = ModeMachine(port)
        relay = ArmRelay(port, machine, LinkHealth(port, machine, 0.5), RelayEvents(lambda *_: None),
                         ramp_time_s=1.0, silence_timeout_s=0.5, kp=60.0, kd=1.5, period_s=0.02)
    assert machine.request(Mode.HIGH_LEVEL).success

    def send(_i: int) -> None:
        relay.submit(["left_elbow_joint"], [0.5])
        relay.tick(0.02)

    return _per_message(counts, port, "write_arm_sdk", send)


def test_a_cmd_vel_message_reads_the_mode_once_under_the_forward_gate() -> None:
    to_write, total = cmd_vel_locks()
    assert to_write[STATE_LOCK] == 1 and to_write[GATE_LOCK] == 1, to_write
    assert total[STATE_LOCK] == 1 and total[GATE_LOCK] == 1, total  # the reply's settling asks nothing more


def test_a_lowcmd_frame_reads_the_mode_once_under_the_forward_gate() -> None:
    to_write, total = lowcmd_locks()
    assert to_write[STATE_LOCK] == 1 and to_write[GATE_LOCK] == 1, to_write
    assert total[STATE_LOCK] == 1 and total[GATE_LOCK] == 1, total


def test_an_arm_frame_reads_the_mode_once_under_the_forward_gate() -> None:
    """One decision per arm_sdk frame: ramp in, hold or ramp out all follow from it."""
    _, total = arm_locks()
    assert total[STATE_LOCK] == 1 and total[GATE_LOCK] == 1, total


def _table(name: str, to_write: Counter[str], total: Counter[str]) -> None:
    ours = sorted(k for k in total if not k.startswith("fakes/"))
    width = max(map(len, ours))
    print(f"{name}: locks per message (up to the write / in all); the fake port's own locks left out")
    for key in ours:
        print(f"  {key:<{width}}  {to_write[key]:>2} / {total[key]:>2}")
    print(f"  {'total':<{width}}  {sum(to_write[k] for k in ours):>2} / {sum(total[k] for k in ours):>2}")


if __name__ == "__main__":
    _table("cmd_vel (submit + step)", *cmd_vel_locks())
    _table("~/lowcmd (submit)", *lowcmd_locks())
    _table("~/arm_cmd (submit + one tick)", *arm_locks())
