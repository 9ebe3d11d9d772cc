"""Truth trajectories: RocketPy flights against the analytic drag-free solution, the sign convention of
the axial specific force, events, the example rockets, and the `simulate` command.

One RocketPy flight per scenario, shared through module-scoped fixtures (the import costs ~1 s).
"""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from desktop.cli import main as run_cli
from desktop.io.flightcsv import read_flight_csv
from desktop.io.rocket_file import load_rocket
from desktop.sim.trajectory import (
    G0,
    TrajectoryError,
    drag_free_vertical,
    isa_altitude,
    isa_pressure,
    isa_speed_of_sound,
    isa_temperature,
    simulate_rocket,
    timings,
)

pytestmark = pytest.mark.slow  # RocketPy flights

ROOT = Path(__file__).resolve().parents[2]
ROCKETS = ROOT / "examples" / "rockets"

THRUST_N, BURN_S, PROP_KG, MOTOR_DRY_KG, ROCKET_DRY_KG = 300.0, 2.0, 0.3, 0.5, 2.0

ZERO_DRAG_TOML = """\
name = "zero drag"

[motor]
file = "const.eng"

[body]
radius_m = 0.04
length_m = 1.2
dry_mass_kg = {dry}
cg_from_nose_m = {cg}

[drag]
cd = 0.0

[nose]
length_m = 0.2
kind = "ogive"

[fins]
count = 4
root_chord_m = 0.15
tip_chord_m = 0.08
span_m = 0.1

[launch]
rail_length_m = 1.0
inclination_deg = 90

[site]
elevation_m = 0

[drogue]
cd_s_m2 = 0.5
lag_s = 0.0

[main]
cd_s_m2 = 1.0
deploy_altitude_m = 2300
"""


def zero_drag_files(directory, cg=0.5):
    (directory / "const.eng").write_text(
        "; constant thrust, for the drag-free test\n"
        f"CONST 54 300 0 {PROP_KG} {PROP_KG + MOTOR_DRY_KG} TEST\n"
        f"0.0 {THRUST_N}\n{BURN_S} {THRUST_N}\n{BURN_S + 0.001} 0.0\n",
        encoding="utf-8",
    )
    path = directory / "zero_drag.toml"
    path.write_text(ZERO_DRAG_TOML.format(dry=ROCKET_DRY_KG, cg=cg), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def zero_drag(tmp_path_factory):
    d = tmp_path_factory.mktemp("zero_drag")
    return simulate_rocket(load_rocket(zero_drag_files(d)), after_main_s=1.0)


@pytest.fixture(scope="module")
def j360():
    return simulate_rocket(load_rocket(ROCKETS / "j360_sport.toml"), after_main_s=4.0)


# --------------------------------------------------------------------------------------------------
# Standard atmosphere


def test_isa_matches_standard_atmosphere_reference_values():
    assert isa_pressure(0.0) == pytest.approx(101325.0)
    assert isa_temperature(0.0) == pytest.approx(288.15)
    assert isa_pressure(11000.0 * 6356766 / (6356766 - 11000.0)) == pytest.approx(22632.04, rel=1e-6)
    assert isa_speed_of_sound(0.0) == pytest.approx(340.294, abs=1e-3)
    h = np.array([-300.0, 0.0, 150.0, 3000.0, 12000.0, 15000.0])
    assert np.allclose(isa_altitude(isa_pressure(h)), h, atol=1e-6)
    # the troposphere formula the boards use, 44330.77 (1 - (p/p0)^0.190263), on geopotential height
    p = isa_pressure(1000.0)
    hg = 44330.77 * (1 - (p / 101325.0) ** 0.190263)
    assert hg == pytest.approx(1000.0 * 6356766 / (6356766 + 1000.0), abs=0.05)


# --------------------------------------------------------------------------------------------------
# Analytic drag-free flight


def test_drag_free_analytic_is_self_consistent():
    tr = drag_free_vertical(thrust_n=THRUST_N, burn_time_s=BURN_S, dry_mass_kg=2.5, propellant_kg=PROP_KG)
    t, z, v = tr.time_s, tr.altitude_m, tr.velocity_mps
    # central differences: 1e-6 m/s except at the burnout corner (jump in a times dt/4)
    assert np.max(np.abs(np.gradient(z, t)[1:-1] - v[1:-1])) < 0.05
    burn = (t > 0.01) & (t < BURN_S - 0.01)
    acc = np.gradient(v, t)
    assert np.allclose(acc[burn] + G0, tr.accel_mps2[burn], atol=1e-3)
    assert tr.accel_mps2[0] == pytest.approx(THRUST_N / 2.8)
    assert np.all(tr.accel_mps2[t > BURN_S] == 0.0)
    i = int(np.argmax(z))
    assert t[i] == pytest.approx(tr.apogee_time_s, abs=tr.dt_s)
    assert z[i] == pytest.approx(tr.apogee_m, abs=1e-4)
    # constant mass: v_burnout = (T/m - g) tb
    tc = drag_free_vertical(thrust_n=100, burn_time_s=1, dry_mass_kg=2, propellant_kg=0)
    vb = (100 / 2 - G0) * 1
    assert tc.apogee_m == pytest.approx(0.5 * vb * 1 + vb**2 / (2 * G0))


def test_rocketpy_zero_drag_matches_analytic(zero_drag):
    ref = drag_free_vertical(thrust_n=THRUST_N, burn_time_s=BURN_S + 0.0005,
                             dry_mass_kg=ROCKET_DRY_KG + MOTOR_DRY_KG, propellant_kg=PROP_KG)
    tr = zero_drag
    assert tr.apogee_m == pytest.approx(ref.apogee_m, rel=2e-3)
    assert tr.apogee_time_s == pytest.approx(ref.apogee_time_s, abs=0.03)
    n = min(len(tr.time_s), len(ref.time_s))
    up = tr.time_s[:n] < ref.apogee_time_s
    assert np.max(np.abs(tr.altitude_m[:n][up] - ref.altitude_m[:n][up])) < 0.002 * ref.apogee_m
    assert np.max(np.abs(tr.velocity_mps[:n][up] - ref.velocity_mps[:n][up])) < 0.5
    burn = (tr.time_s > 0.01) & (tr.time_s < BURN_S - 0.01)
    expect = np.interp(tr.time_s[burn], ref.time_s, ref.accel_mps2)
    assert np.allclose(tr.accel_mps2[burn], expect, rtol=5e-3)
    coast = (tr.time_s > BURN_S + 0.05) & (tr.time_s < tr.apogee_time_s - 0.05)
    assert np.max(np.abs(tr.accel_mps2[coast])) < 0.05  # drag-free coast reads ~0
    assert tr.accel_mps2[0] == pytest.approx(THRUST_N / (ROCKET_DRY_KG + MOTOR_DRY_KG + PROP_KG), rel=1e-3)


# --------------------------------------------------------------------------------------------------
# Sign convention and events on a realistic flight


def test_specific_force_sign_convention(j360):
    tr = j360
    spec = load_rocket(ROCKETS / "j360_sport.toml")
    g_axial = G0 * math.sin(math.radians(spec.inclination_deg))
    t, f = tr.time_s, tr.accel_mps2
    # +g (along the inclined rail) at rest, before the thrust exceeds the weight
    assert f[0] == pytest.approx(g_axial, abs=1e-6)
    assert tr.pad_accel_mps2 == pytest.approx(g_axial)
    # positive during the burn, about T/m minus drag
    burn = (t > 0.1) & (tr.thrust_n > 100.0)
    assert np.all(f[burn] > 0)
    assert np.all(f[burn] <= tr.thrust_n[burn] / tr.mass_kg[burn] + 1e-9)
    # negative in coast: about -D/m with D = rho v^2 S cd / 2
    i = int(np.searchsorted(t, tr.burnout_time_s + 1.0))
    rho = isa_pressure(spec.elevation_m + tr.altitude_m[i]) / (287.05287 * isa_temperature(
        spec.elevation_m + tr.altitude_m[i]))
    speed = tr.mach[i] * isa_speed_of_sound(spec.elevation_m + tr.altitude_m[i])
    cd = np.interp(tr.mach[i], [p[0] for p in spec.cd_table], [p[1] for p in spec.cd_table])
    drag_per_mass = 0.5 * rho * speed**2 * math.pi * spec.radius_m**2 * cd / tr.mass_kg[i]
    assert f[i] < 0
    assert -f[i] == pytest.approx(drag_per_mass, rel=0.05)
    # near apogee the drag vanishes
    j = int(np.searchsorted(t, tr.apogee_time_s))
    assert abs(f[j]) < 0.5
    # steady descent under the drogue reads about +g (body axis vertical under a parachute)
    k = int(np.searchsorted(t, tr.drogue_time_s + 30.0))
    assert f[k] == pytest.approx(G0, abs=0.3)


def test_events_and_consistency(j360):
    tr = j360
    e = tr.events
    assert 0 < e["rail_exit"] < tr.burnout_time_s < tr.apogee_time_s <= tr.drogue_time_s < tr.main_time_s
    assert 0 <= e["drogue_trigger"] - tr.apogee_time_s < 0.06  # 20 Hz trigger sampling
    assert tr.drogue_time_s == pytest.approx(e["drogue_trigger"] + 1.0)  # + lag: opens
    i = int(np.searchsorted(tr.time_s, e["main_trigger"]))
    assert tr.altitude_m[i] == pytest.approx(200.0, abs=3.0)
    assert tr.end_time_s == pytest.approx(tr.main_time_s + 4.0, abs=0.002)
    assert tr.apogee_m == pytest.approx(np.max(tr.altitude_m), abs=0.01)
    assert tr.dt_s == pytest.approx(0.001)
    assert np.max(np.abs(np.gradient(tr.altitude_m, tr.time_s) - tr.velocity_mps)) < 0.5
    assert np.allclose(tr.pressure_pa, isa_pressure(tr.site_altitude_m + tr.altitude_m))
    assert tr.ground_pressure_pa == pytest.approx(isa_pressure(150.0))
    t = timings()
    assert t["flights"] >= 1 and t["flight_s"] > 0


@pytest.mark.parametrize("name,lo,hi,check", [
    ("c6_model", 250, 450, "clips16g"),
    ("k400_dual_deploy", 1200, 2300, None),
    ("k1000_min_dia", 3000, 5500, "mach1.2"),
    ("m1670_3km", 2600, 3400, None),
    pytest.param("m1670_min_dia", 7000, 10000, "mach2", marks=pytest.mark.slow),
])
def test_example_rockets_reach_their_expected_apogee_and_mach(name, lo, hi, check):
    tr = simulate_rocket(load_rocket(ROCKETS / f"{name}.toml"), after_main_s=1.0)
    assert lo < tr.apogee_m < hi, tr.summary()
    if check == "clips16g":
        assert np.max(tr.accel_mps2) > 16 * G0
    if check == "mach1.2":
        assert tr.max_mach > 1.2
    if check == "mach2":
        assert tr.max_mach > 2.0


def test_unstable_rocket_is_rejected(tmp_path):
    path = zero_drag_files(tmp_path, cg=1.15)
    with pytest.raises(TrajectoryError, match="unstable: static margin"):
        simulate_rocket(load_rocket(path))


def test_three_dof_without_a_drogue_is_refused():
    # RocketPy's point mass falling nose-down from apogee turns its weathercocking model stiff: the
    # J360 without its drogue ran for more than 10 minutes (6 DOF: 2 s)
    spec = dataclasses.replace(load_rocket(ROCKETS / "j360_sport.toml"), drogue=None)
    with pytest.raises(TrajectoryError, match=r"3 DOF needs a \[drogue\]"):
        simulate_rocket(spec, dof=3)


@pytest.mark.filterwarnings("ignore:The Sensor class")
def test_part_profiles_configure_rocketpy_sensors():
    from rocketpy.sensors import Accelerometer, Barometer

    from desktop.sim.sensor_models import ACCEL_PARTS, BARO_PARTS

    for part in BARO_PARTS.values():
        Barometer(**part.rocketpy_kwargs())
    for part in ACCEL_PARTS.values():
        Accelerometer(**part.rocketpy_kwargs())


# --------------------------------------------------------------------------------------------------
# The command


def test_simulate_command_writes_the_record_its_metadata_and_plot(tmp_path, capsys):
    out = tmp_path / "f.csv"
    png = tmp_path / "f.png"
    rc = run_cli(["simulate", str(ROCKETS / "c6_model.toml"), "--out", str(out), "--seed", "4",
                  "--rate-hz", "50", "--pad-s", "5", "--plot", str(png)])
    assert rc == 0
    assert "no main" in capsys.readouterr().out
    log = read_flight_csv(out)
    assert log.metadata["main_deploy_m"] == "none"  # the C6 has no [main]: the plan says so
    assert log.metadata["sensor_profile"] == "bmp390+mpu6050"  # from the TOML's [board]
    assert log.metadata["seed"] == "4"
    assert log.time_s[0] >= -5.0 and np.median(np.diff(log.time_s)) == pytest.approx(0.02, abs=1e-3)
    assert np.nanmax(log.accel_mps2) == pytest.approx(32767 / 2048 * G0, abs=0.01)  # clipped at 16 g
    assert png.stat().st_size > 10000
    # the replay flies the plan: one parachute, no main event
    from desktop.review.replay import config_for, replay

    res = replay(log, config_for(log))
    assert res.first("drogue") is not None and res.first("main") is None and not res.pyro_main.any()


@pytest.mark.slow
def test_simulate_then_replay_opens_the_main_where_the_rocket_says(tmp_path, capsys):
    # examples/rockets/m1670_3km.toml: main at 400 m. RocketPy opens it there, the record says so,
    # and the replay fires it there (not at the configuration's default 250 m)
    from desktop.review.replay import config_for, replay

    out = tmp_path / "m1670.csv"
    assert run_cli(["simulate", str(ROCKETS / "m1670_3km.toml"), "--out", str(out), "--seed", "2",
                    "--pad-s", "5", "--after-main-s", "5"]) == 0
    assert "main planned at 400 m AGL" in capsys.readouterr().out
    log = read_flight_csv(out)
    assert log.main_deploy_m() == 400.0
    res = replay(log, config_for(log))
    main_ev = res.first("main")
    assert main_ev is not None and abs(log.extra["true_altitude_m"][main_ev.index] - 400) <= 10
    # RocketPy's own main: its trigger at 400 m, opening the parachute's lag later
    trigger_s = float(log.metadata["true_main_time_s"]) - load_rocket(ROCKETS / "m1670_3km.toml").main.lag_s
    assert abs(np.interp(trigger_s, log.time_s, log.extra["true_altitude_m"]) - 400) <= 10


@pytest.mark.parametrize("argv,fragment", [
    (["{rocket}"], "--out FLIGHT.csv is required"),
    (["--out", "x.csv"], "give either ROCKET.toml or --openrocket"),
    (["{rocket}", "--openrocket", "e.csv", "--out", "x.csv"], "give either"),
    (["{rocket}", "--out", "x.csv", "--sensors", "bmp999+adxl375"],
     "unknown sensor profile 'bmp999+adxl375'"),
    (["{rocket}", "--out", "x.csv", "--rate-hz", "500"], "allowed 20 to 100 Hz"),
    (["{rocket}", "--out", "x.csv", "--pad-s", "-1"], "allowed 0 to 600 s"),
    (["{rocket}", "--out", "x.csv", "--site-altitude", "100"], "--site-altitude applies to --openrocket"),
    (["{bad}", "--out", "x.csv"], "[body] dry_mass_kg = -2 is out of range"),
    (["{missing}", "--out", "x.csv"], "rocket file not found"),
    (["{rocket}", "--benchmark", "0"], "positive counts"),
])
def test_simulate_errors_are_one_line(tmp_path, capsys, argv, fragment):
    bad = tmp_path / "bad.toml"
    bad.write_text((ROCKETS / "c6_model.toml").read_text().replace("dry_mass_kg = 0.040", "dry_mass_kg = -2")
                   .replace("../motors/", str(ROOT / "examples" / "motors") + "/"), encoding="utf-8")
    subst = {"{rocket}": str(ROCKETS / "c6_model.toml"), "{bad}": str(bad),
             "{missing}": str(tmp_path / "no.toml")}
    argv = [subst.get(a, a) for a in argv]
    argv = [a if a != "x.csv" else str(tmp_path / "x.csv") for a in argv]
    rc = run_cli(["simulate", *argv])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and err.startswith("error: ")
    assert fragment in err
    assert not (tmp_path / "x.csv").exists()


def test_simulate_list_sensors(capsys):
    assert run_cli(["simulate", "--list-sensors"]) == 0
    out = capsys.readouterr().out
    for name in ("bmp388", "bmp390", "ms5611", "adxl375", "mpu6050", "lsm6dso"):
        assert name in out


def test_three_dof_mode():
    spec = load_rocket(ROCKETS / "c6_model.toml")
    tr = simulate_rocket(spec, dof=3)
    assert 300 < tr.apogee_m < 450
    assert tr.accel_mps2[0] == pytest.approx(G0 * math.sin(math.radians(spec.inclination_deg)))
    assert np.max(tr.accel_mps2) > 16 * G0
    assert "landing" in tr.events
