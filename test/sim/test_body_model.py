"""The body models without MuJoCo: motor temperatures, the battery, and injected readings laid over them."""

from __future__ import annotations

import json

import numpy as np
import pytest

from g1_mode_manager.protocol.motors import EFFORT_LIMIT_NM, NUM_JOINTS
from g1_mode_manager.protocol.remote import decode_remote
from g1_sim.bridge.body_report import body_report
from g1_sim.bridge.faults import parse_faults
from g1_sim.firmware.state import BodySnapshot, tilt_rad
from g1_sim.physics.battery import Battery
from g1_sim.physics.thermal import AMBIENT_C, CONTINUOUS_FRACTION, MotorThermal

LIMIT = np.array(EFFORT_LIMIT_NM)
DT = 0.02


def heat(thermal: MotorThermal, tau: np.ndarray, seconds: float) -> None:
    loss = thermal.copper_loss_w(tau)
    for _ in range(round(seconds / DT)):
        thermal.update(loss, DT)


def test_at_rest_the_motors_stay_at_ambient() -> None:
    thermal = MotorThermal(LIMIT)
    heat(thermal, np.zeros(NUM_JOINTS), 60.0)
    assert np.all(thermal.winding == AMBIENT_C) and np.all(thermal.casing == AMBIENT_C)


def test_load_heats_the_winding_first_and_the_casing_lags() -> None:
    thermal = MotorThermal(LIMIT)
    heat(thermal, 0.5 * CONTINUOUS_FRACTION * LIMIT, 60.0)  # half the continuous torque: a quarter of its loss
    rise_w, rise_c = thermal.winding - AMBIENT_C, thermal.casing - AMBIENT_C
    assert np.all(rise_w > 5.0) and np.all(rise_c > 0.5) and np.all(rise_c < 0.5 * rise_w)
    # the same fraction of each motor's rating heats every motor alike (size-scaled model)
    assert np.allclose(thermal.winding, thermal.winding[0]) and np.allclose(thermal.casing, thermal.casing[0])


def test_continuous_torque_settles_just_under_the_limits_and_takes_minutes() -> None:
    thermal = MotorThermal(LIMIT)
    heat(thermal, CONTINUOUS_FRACTION * LIMIT, 60.0)
    assert thermal.winding.max() < 80.0  # time constants of tens of seconds to minutes, not seconds
    heat(thermal, CONTINUOUS_FRACTION * LIMIT, 3600.0)
    assert thermal.winding == pytest.approx(np.full(NUM_JOINTS, 115.0), abs=0.5)  # < 120 C winding limit
    assert thermal.casing == pytest.approx(np.full(NUM_JOINTS, 79.0), abs=0.5)  # < 85 C casing limit


def test_loss_grows_with_torque_squared() -> None:
    thermal = MotorThermal(LIMIT)
    tau = 0.1 * LIMIT
    assert thermal.copper_loss_w(2 * tau) == pytest.approx(4 * thermal.copper_loss_w(tau))


def test_battery_drains_with_the_power_drawn() -> None:
    idle, busy = Battery(90.0), Battery(90.0)
    for _ in range(3000):  # 60 s
        idle.drain(0.0, DT)
        busy.drain(300.0, DT)
    assert 89.6 < idle.soc < 90.0  # 100 W idle: about 0.35 % a minute of 9 Ah x 54 V
    assert busy.soc < idle.soc - 0.5
    r = busy.reading()
    assert r.current_a < 0 and 45.0 < r.pack_v < 55.0 and r.cell_v == pytest.approx(r.pack_v / 13)
    with pytest.raises(ValueError):
        Battery(101.0)


def _snapshot(keys: frozenset[str] = frozenset()) -> BodySnapshot:
    return BodySnapshot(casing_c=np.full(NUM_JOINTS, 30.2), winding_c=np.full(NUM_JOINTS, 40.6),
                        battery=Battery(90.0).reading(), remote_keys=keys)


def test_body_report_lays_injections_over_the_model() -> None:
    plain = body_report(_snapshot(), parse_faults(""))
    assert plain.temperature.dtype == np.int16 and plain.temperature.shape == (NUM_JOINTS, 2)
    assert np.all(plain.temperature == [30, 41])  # [casing, winding], rounded
    assert plain.battery.soc == 90.0 and decode_remote(plain.remote).keys == frozenset()

    faults = parse_faults(json.dumps({"motor_temperature": {"3": [90, 130]}, "battery_soc": 15}))
    report = body_report(_snapshot(frozenset({"L2", "B"})), faults)
    assert list(report.temperature[3]) == [90, 130] and list(report.temperature[4]) == [30, 41]
    assert (report.hottest_casing_c, report.hottest_winding_c) == (90.0, 130.0)
    assert report.battery.soc == 15 and report.battery.pack_v < plain.battery.pack_v  # voltage follows the soc
    remote = decode_remote(report.remote)
    assert remote.keys == {"L2", "B"} and remote.l2 == 1.0


def test_tilt_is_the_angle_of_the_body_z_axis_from_vertical() -> None:
    assert tilt_rad(np.array([1.0, 0.0, 0.0, 0.0])) == 0.0
    half = 0.6 / 2
    assert tilt_rad(np.array([np.cos(half), np.sin(half), 0.0, 0.0])) == pytest.approx(0.6)  # roll 0.6
    assert tilt_rad(np.array([np.cos(half), 0.0, 0.0, np.sin(half)])) == 0.0  # yaw is not tilt
