"""What the robot reports about its body once the injected readings are laid over the simulated ones.

Tests make a supervisor's conditions true by injection (``motor_temperature``, ``battery_soc`` in the
faults): the override replaces what the body model says in everything the robot publishes, and in the
record and status a test judges by, so all of them agree on what the robot claimed and when.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from g1_mode_manager.protocol.motors import CASING_TEMPERATURE_INDEX, WINDING_TEMPERATURE_INDEX
from g1_mode_manager.protocol.remote import RemoteState, encode_remote
from g1_sim.bridge.faults import FaultConfig
from g1_sim.firmware.state import BodySnapshot
from g1_sim.physics.battery import BatteryReading, reading_at


@dataclass(frozen=True)
class BodyReport:
    """Immutable, so the sim thread can hand it to readers without a lock."""

    temperature: np.ndarray  # 29 x [casing, winding], int16 deg C: MotorState_.temperature
    hottest_winding_c: float
    hottest_casing_c: float
    battery: BatteryReading
    remote_keys: frozenset[str]
    remote: bytes  # LowState_.wireless_remote


def body_report(body: BodySnapshot, config: FaultConfig) -> BodyReport:
    """The body as published: ``body`` with the configuration's overrides applied."""
    casing, winding = body.casing_c, body.winding_c
    if config.motor_temperature:
        casing, winding = casing.copy(), winding.copy()
        for i, (c, w) in config.motor_temperature.items():
            casing[i], winding[i] = c, w
    temperature = np.empty((casing.size, 2), dtype=np.int16)
    temperature[:, CASING_TEMPERATURE_INDEX] = np.rint(casing)
    temperature[:, WINDING_TEMPERATURE_INDEX] = np.rint(winding)
    battery = body.battery
    if config.battery_soc is not None:
        battery = reading_at(config.battery_soc, battery.power_w)
    keys = body.remote_keys
    remote = RemoteState(keys, l2=1.0 if "L2" in keys else 0.0)  # the trigger pressed fully with its key
    return BodyReport(temperature=temperature, hottest_winding_c=float(winding.max()),
                      hottest_casing_c=float(casing.max()), battery=battery, remote_keys=keys,
                      remote=encode_remote(remote))
