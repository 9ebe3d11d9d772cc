"""The flight computer inside RocketPy, closed loop (desktop/sim/rocketpy_trigger.py): one step per
sensor timestamp, the accelerometer's sign convention, the parachute triggered at the board's
decision, and the closed-loop decisions equal to an open-loop replay of what the board saw."""

import math
from pathlib import Path

import numpy as np
import pytest

from desktop.io.flightcsv import read_flight_csv
from desktop.io.rocket_file import load_rocket
from desktop.review.replay import replay
from desktop.sim.rocketpy_trigger import (
    G0,
    FlightComputerTrigger,
    axis_vertical_component,
    board_sensors,
    config_for_profile,
    fly_closed_loop,
    rocketpy_gravity_sign,
)

pytestmark = [pytest.mark.slow,
              pytest.mark.filterwarnings("ignore::UserWarning", "ignore::DeprecationWarning")]

ROOT = Path(__file__).resolve().parents[2]
ROCKETS = ROOT / "examples" / "rockets"


def _timestamps(sensor):
    return [round(row[0] * 1e6) for row in sensor.measured_data]


@pytest.fixture(scope="module")
def j360():
    """A whole J360 flight, RocketPy's default (fast) time_overshoot=True, the file's board."""
    return fly_closed_loop(ROCKETS / "j360_sport.toml", seed=3, time_overshoot=True)


@pytest.fixture(scope="module")
def c6_exact():
    """The C6 to 20 s with time_overshoot=False: RocketPy stops at every sample."""
    return fly_closed_loop(ROCKETS / "c6_model.toml", seed=4, max_time=20.0, time_overshoot=False)


@pytest.mark.parametrize("name", ["j360", "c6_exact"])
def test_one_step_per_sensor_timestamp(name, request):
    run = request.getfixturevalue(name)
    trig = run.trigger
    stamps = set(_timestamps(run.barometer)) | set(_timestamps(run.accelerometer))
    assert trig.steps == len(stamps)
    assert len(trig.rows_time_us) == trig.steps + trig.pad_samples
    flight_rows = trig.rows_time_us[trig.pad_samples:]
    assert flight_rows == sorted(stamps)
    # RocketPy calls each parachute's trigger separately in one time step: more calls than steps
    assert trig.calls > trig.steps / 2
    # repeated timestamps (RocketPy re-measures at a phase change) are skipped, not stepped twice
    n_readings = len(run.barometer.measured_data) + len(run.accelerometer.measured_data)
    assert 2 * (trig.steps + trig.duplicates) == n_readings
    # the pad: pad_s of the first readings before ignition
    pad = np.array(trig.rows_time_us[:trig.pad_samples])
    assert pad[-1] < 0 and np.all(np.diff(pad) == trig.pad_period_us)
    assert trig.pad_samples == round(5.0 * run.barometer.sampling_rate)
    if name == "c6_exact":
        assert trig.duplicates >= 1  # the drogue's phase change repeats a timestamp


def test_rocketpy_accelerometer_sign_convention():
    """Pinned: RocketPy 1.13 reads -g (about -9.7 on a rail) at rest with consider_gravity=True;
    a real accelerometer, and our convention, read +g nose up."""
    assert rocketpy_gravity_sign() == -1
    spec = load_rocket(ROCKETS / "j360_sport.toml")  # rail at 86 degrees
    run = fly_closed_loop(spec, profile="ideal", rate_hz=100, max_time=30.0, time_overshoot=True)
    first = run.accelerometer.measured_data[0]
    assert first[0] == 0.0
    assert first[3] == pytest.approx(-G0 * math.sin(math.radians(86)), abs=0.01)  # -9.78
    # converted: +g sin(inclination), the pad value, as the board's accelerometer reads it
    assert run.trigger.rows_accel_mm[0] == pytest.approx(1000 * G0 * math.sin(math.radians(86)), abs=10)
    # in flight the converted reading is the axial specific force of the open-loop trajectory:
    # +T/m in the boost, -D/m in coast (RocketPy's raw reading is 2 g sin(pitch) lower)
    from desktop.sim.trajectory import simulate_rocket

    traj = simulate_rocket(spec)
    cols = run.trigger.columns()
    t, a = cols["time_s"], cols["accel_mps2"]
    raw = {round(row[0], 6): row[3] for row in run.accelerometer.measured_data}
    for ts in (0.5, 1.0, 2.0, 3.0, 8.0, 12.0):
        k = int(np.argmin(np.abs(t - ts)))
        assert t[k] == pytest.approx(ts)
        expect = traj.accel_mps2[int(round(ts * 1000))]
        assert a[k] == pytest.approx(expect, abs=0.05), ts
        # the difference is 2 g times the vertical component of the axis (near 1 in the boost)
        zb = (a[k] - raw[round(ts, 6)]) / (2 * G0)
        assert (0.97 if ts <= 1.0 else 0.5) < zb <= 1.0, ts


def test_conversion_for_each_rocketpy_convention(monkeypatch):
    import desktop.sim.rocketpy_trigger as rt

    baro, accel = board_sensors("ideal", 100, seed=0)
    level = [0.0] * 6 + [1.0, 0.0, 0.0, 0.0] + [0.0] * 3  # nose up
    half = math.radians(30) / 2  # axis tilted 30 degrees from vertical
    tilted = [0.0] * 6 + [math.cos(half), math.sin(half), 0.0, 0.0] + [0.0] * 3
    assert axis_vertical_component(level) == 1.0
    assert axis_vertical_component(tilted) == pytest.approx(math.cos(math.radians(30)))
    trig = FlightComputerTrigger(baro, accel)
    assert trig.gravity_factor == 2  # RocketPy 1.13
    assert trig.specific_force_mps2(-G0, level) == pytest.approx(G0)
    assert trig.specific_force_mps2(-2 * G0 * math.cos(math.radians(30)), tilted) == pytest.approx(0.0)
    monkeypatch.setattr(rt, "_GRAVITY_SIGN", 1)  # a RocketPy with the sign fixed (PR #1175)
    fixed = FlightComputerTrigger(baro, accel)
    assert fixed.gravity_factor == 0 and fixed.specific_force_mps2(G0, level) == G0
    accel.consider_gravity = False
    plain = FlightComputerTrigger(baro, accel)
    assert plain.gravity_factor == 1
    assert plain.specific_force_mps2(0.0, tilted) == pytest.approx(G0 * math.cos(math.radians(30)))
    assert FlightComputerTrigger(baro, None).config.has_accel is False
    with pytest.raises(ValueError, match="z axis"):
        from rocketpy.sensors import Accelerometer

        FlightComputerTrigger(baro, Accelerometer(sampling_rate=100, orientation=(0, 90, 0)))


def test_config_follows_the_parts():
    baro, accel = board_sensors("ms5611+adxl375", 100, seed=0)
    trig = FlightComputerTrigger(baro, accel, config={"main_deploy_m": 300})
    assert trig.config.values["accel_range_g"] == 200.0 and trig.config.values["main_deploy_m"] == 300
    assert config_for_profile("bmp390+mpu6050").values["accel_range_g"] == 16.0
    assert baro.sampling_rate == 100 and accel.sampling_rate == 100
    # per-reading noise equals the part's RMS at the board rate
    assert baro.noise_density * math.sqrt(100) == pytest.approx(1.2)
    # the barometer's noise class, as sensor_models declares its records
    assert trig.config.values["baro_noise"] == "low"
    assert config_for_profile("ms5611+adxl375").values["baro_noise"] == "low"
    assert FlightComputerTrigger(baro, accel, config={"baro_noise": "standard"}).config.values[
        "baro_noise"] == "standard"


@pytest.mark.parametrize("name", ["j360", "c6_exact"])
def test_closed_loop_equals_open_loop_replay(name, request, tmp_path):
    run = request.getfixturevalue(name)
    trig = run.trigger
    path = tmp_path / "closed_loop.csv"
    trig.write_csv(path)
    log = read_flight_csv(path)
    assert len(log) == len(trig.rows_time_us)
    res = replay(log, trig.config)
    closed = [(e.event, e.time_s, e.index) for e in trig.events]
    opened = [(e.event, e.time_s, e.index) for e in res.events]
    assert closed == opened
    assert trig.first("drogue") is not None
    period = 1.0 / run.barometer.sampling_rate
    t_decision = trig.drogue_time_s
    t_rocketpy = run.rocketpy_event_s("drogue")
    # the open-loop replay's drogue is the closed loop's, to within one sample (here: exactly)
    assert abs(res.first("drogue").time_s - t_decision) <= period
    apogee = run.flight.apogee_time
    assert abs(t_decision - apogee) < 0.15
    if name == "c6_exact":
        # RocketPy measured the sensors, then asked the trigger, at the same time node
        assert t_rocketpy == pytest.approx(t_decision, abs=1e-9)
    else:
        # default time_overshoot: the next trigger call after the decision, before the next reading
        later = [t / 1e6 for t in _timestamps(run.barometer) if t / 1e6 > t_decision + 1e-9]
        assert t_decision < t_rocketpy <= later[0] + 1e-9
        assert trig.main_time_s is not None
        t_main = run.rocketpy_event_s("main")
        assert trig.main_time_s < t_main <= trig.main_time_s + 0.05
        # the main fires at the configured altitude (200 m in j360_sport.toml), truth within 10 m
        assert abs(float(run.flight.z(t_main)) - run.spec.elevation_m - 200.0) < 10.0
    # a late drogue changes the descent: RocketPy opened the drogue lag_s after the decision
    assert run.flight.parachute_events[0][1].name == "drogue"


def test_one_trigger_per_flight(j360):
    baro = j360.barometer
    saved = baro.measured_data
    try:
        baro.measured_data = []
        with pytest.raises(RuntimeError, match="one trigger per flight"):
            j360.trigger.drogue(0, 0, [0.0] * 13, [])
    finally:
        baro.measured_data = saved
