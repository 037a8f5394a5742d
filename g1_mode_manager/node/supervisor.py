"""The supervisor's step: the robot checked against the mode, then rt/lowstate received or not as needed."""

from __future__ import annotations

from g1_mode_manager.core.machine import ModeMachine
from g1_mode_manager.core.port import RobotPort
from g1_mode_manager.relay.lowstate_demand import LowStateDemand


class RobotSupervisor:
    """``step`` runs at supervise_rate_hz on a worker of its own."""

    def __init__(self, port: RobotPort, machine: ModeMachine, lowstate_demand: LowStateDemand) -> None:
        self._port = port
        self._machine = machine
        self._lowstate_demand = lowstate_demand
        self._restarts_seen = 0

    def step(self, _dt_s: float) -> None:
        """EMERGENCY re-damped if seen out of damping, a mismatch (another program, a reboot seen in
        rt/lowstate's tick) stops forwarding. Then rt/lowstate is subscribed or not as needed."""
        restarts = self._port.lowstate_restarts()
        if restarts > self._restarts_seen:
            self._restarts_seen = restarts
            self._machine.report_mismatch("the robot restarted (rt/lowstate tick went back)")
        state = self._port.sport_state()
        if state is None:
            self._machine.supervise()
        else:
            self._machine.supervise(state.fsm_id, state.age_s)
        self._lowstate_demand.update()
