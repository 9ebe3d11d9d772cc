"""Monte-Carlo over a rocket design (desktop/study/rocket_*.py, ``montecarlo --rocket``): the
draws, determinism by seed and worker count, every method in the table and the JSON, each method's
numbers against a direct call, the CLI and the figures. A few RocketPy flights per rocket."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from desktop.cli import main
from desktop.io.flightcsv import read_flight_csv
from desktop.io.rocket_file import load_rocket
from desktop.sim.sensor_models import write_record
from desktop.study import baselines
from desktop.study.metrics import METRIC_KEYS, metrics
from desktop.study.rocket_comparison import baseline_inputs, hold_missing
from desktop.study.rocket_dispersions import DEFAULT_DISPERSIONS, apply_draw, draw_flight
from desktop.study.rocket_flight import (
    METHODS,
    evaluate_flight,
    flight_computer_config,
    record_log,
    settings_for,
    simulate_flight,
)
from desktop.study.rocket_plots import write_plots
from desktop.study.rocket_report import format_markdown
from desktop.study.rocket_results import json_ready
from desktop.study.rocket_study import run_rocket_study

pytestmark = [pytest.mark.slow,
              pytest.mark.filterwarnings("ignore::UserWarning", "ignore::DeprecationWarning")]

ROOT = Path(__file__).resolve().parents[2]
ROCKETS = ROOT / "examples" / "rockets"
C6 = ROCKETS / "c6_model.toml"
SEED = 11


@pytest.fixture(scope="module")
def c6_settings():
    return settings_for(C6, SEED)


@pytest.fixture(scope="module")
def c6_serial(c6_settings):
    return run_rocket_study(c6_settings, 3, workers=1)


@pytest.fixture(scope="module")
def c6_parallel(c6_settings):
    return run_rocket_study(c6_settings, 3, workers=2)


def _without_timing(flights):
    # NaN (no main on the C6) compared as None
    return json_ready([{k: v for k, v in f.items() if k != "timing_s"} for f in flights])


def test_draws_are_seeded_bounded_and_independent_of_the_batch():
    spec = load_rocket(ROCKETS / "k400_dual_deploy.toml")
    d = DEFAULT_DISPERSIONS
    draws = [draw_flight(spec, 3, i) for i in range(300)]
    assert draw_flight(spec, 3, 17) == draws[17]
    assert draw_flight(spec, 4, 17) != draws[17]
    for name, half in (("impulse_scale", d.impulse), ("burn_time_scale", d.burn_time), ("cd_scale", d.cd),
                       ("dry_mass_scale", d.dry_mass)):
        x = np.array([getattr(w, name) for w in draws])
        assert np.all(np.abs(x - 1) <= half) and np.ptp(x) > 1.5 * half, name
    wind = np.array([w.wind_speed_mps for w in draws])
    assert wind.min() >= 0 and wind.max() <= d.max_wind_mps and wind.max() > 0.9 * d.max_wind_mps
    incl = np.array([w.inclination_deg for w in draws])
    assert np.all(np.abs(incl - spec.inclination_deg) <= d.inclination_deg + 1e-12) and incl.max() <= 90
    for name in ("wind_from_deg", "heading_deg"):
        x = np.array([getattr(w, name) for w in draws])
        assert x.min() >= 0 and x.max() < 360 and np.ptp(x) > 300
    # the dispersed rocket: impulse and burn time as drawn, drag scaled point by point
    w = draws[5]
    flown = apply_draw(spec, w, 250.0)
    impulse = spec.motor.total_impulse_ns * w.impulse_scale
    assert flown.motor.total_impulse_ns == pytest.approx(impulse, rel=1e-9)
    assert flown.motor.burn_time_s == pytest.approx(spec.motor.burn_time_s * w.burn_time_scale, rel=1e-12)
    assert [c for _m, c in flown.cd_table] == pytest.approx([c * w.cd_scale for _m, c in spec.cd_table])
    assert flown.dry_mass_kg == pytest.approx(spec.dry_mass_kg * w.dry_mass_scale)
    assert flown.main.deploy_altitude_m == 250.0 and flown.main.cd_s_m2 == spec.main.cd_s_m2


def test_same_results_whatever_the_worker_count(c6_serial, c6_parallel, c6_settings):
    assert c6_parallel.speed["workers"] == 2 and c6_serial.speed["workers"] == 1
    assert _without_timing(c6_serial.flights) == _without_timing(c6_parallel.flights)
    assert c6_serial.table == c6_parallel.table
    assert json_ready(c6_serial.fc_summary) == json_ready(c6_parallel.fc_summary)
    # and flight 2 alone is the same flight as flight 2 of the batch
    alone = evaluate_flight(c6_settings, 2)
    assert _without_timing([alone]) == _without_timing(c6_serial.flights[2:3])
    # another seed, other flights
    other = evaluate_flight(settings_for(C6, SEED + 1), 2)
    assert other["draw"] != alone["draw"]


def test_table_rows_are_the_metrics_of_the_flights(c6_serial):
    res = c6_serial
    assert list(res.table) == list(METHODS)
    apo = np.array([f["true_apogee_s"] for f in res.flights])
    for m in METHODS:
        d = np.array([f["detections"][m] for f in res.flights])
        v = np.array([f["true_velocity_at_detection"][m] for f in res.flights])
        assert res.table[m] == metrics(d, apo, v)
        assert set(res.table[m]) == set(METRIC_KEYS)


def test_each_method_equals_a_direct_call(c6_settings, c6_serial, tmp_path):
    """Flight 1 again, through the public pieces: the flight CSV on disk, ``replay`` and the
    baselines' own functions."""
    from desktop.review.replay import config_for, replay

    got = c6_serial.flights[1]
    _draw, traj, record = simulate_flight(c6_settings, 1)
    path = tmp_path / "flight1.csv"
    write_record(path, record)
    log = read_flight_csv(path)
    # the in-memory log is the CSV round trip
    mem = record_log(record)
    np.testing.assert_array_equal(mem.time_us, log.time_us)
    np.testing.assert_array_equal(mem.time_s, log.time_s)
    np.testing.assert_array_equal(mem.pressure_pa, log.pressure_pa)
    np.testing.assert_array_equal(mem.accel_mps2, log.accel_mps2)
    assert log.metadata["main_deploy_m"] == "none" and log.main_deploy_m() == 0.0  # the C6: no main
    # the flight computer: python -m desktop replay's code on the written file
    res = replay(log, config_for(log))
    assert got["detections"]["flight-computer"] == res.first("drogue").time_s
    assert res.first("main") is None and math.isnan(got["flight_computer"]["main_s"])
    assert got["true_apogee_s"] == traj.apogee_time_s
    # the comparison methods: the baselines' functions on the same record
    t, alt, acc = baseline_inputs(log)
    t2, alt2, acc2 = baseline_inputs(log, res)
    np.testing.assert_array_equal(alt, alt2)
    np.testing.assert_array_equal(acc, acc2)
    assert not np.isnan(alt).any() and not np.isnan(acc).any()
    A, V = alt[None, :], acc[None, :]
    direct = {
        "seed-kalman/seed": baselines.METHODS["seed-kalman/seed"](t, A, V)[0],
        "butterworth/seed": baselines.METHODS["butterworth/seed"](t, A, V)[0],
        "boxcar/seed": baselines.detect_seed_rule(
            t, baselines.boxcar(A, window=int(round(2.0 / baselines.sample_period_s(t)))),
            baselines.armed_mask(t, V))[0],
    }
    for name, d in direct.items():
        g = got["detections"][name]
        assert g == d or (math.isnan(d) and math.isnan(g)), (name, g, d)
    for name, d in got["detections"].items():
        if math.isfinite(d):
            assert got["true_velocity_at_detection"][name] == np.interp(d, traj.time_s, traj.velocity_mps)


def test_hold_fills_missing_readings():
    x = np.array([np.nan, 2.0, np.nan, np.nan, 5.0, np.nan])
    np.testing.assert_array_equal(hold_missing(x), [2.0, 2.0, 2.0, 2.0, 5.0, 5.0])


@pytest.mark.parametrize("name", ["j360_sport", "k400_dual_deploy", "k1000_min_dia", "m1670_3km"])
def test_every_example_rocket_runs(name):
    res = run_rocket_study(settings_for(ROCKETS / f"{name}.toml", 1), 2, workers=2)
    # the rocket's own deployment plan (m1670: main at 400 m), never a default
    assert res.settings.main_deploy_m == load_rocket(ROCKETS / f"{name}.toml").main.deploy_altitude_m
    fc = res.table["flight-computer"]
    assert fc["n_no_detection"] == 0 and fc["n_early_1s"] == 0
    assert fc["max_abs_error_s"] < 0.5
    s = res.fc_summary
    assert s["n_fired_before_burnout"] == 0 and s["n_pyro_before_launch"] == 0 and s["n_main"] == 2
    assert s["main_altitude_error_max_abs_m"] < 15
    for f in res.flights:
        assert f["flight_computer"]["burnout_s"] > 0
    if name == "k1000_min_dia":
        assert min(f["max_mach"] for f in res.flights) > 1.3


def test_cli_table_json_and_errors(capsys, tmp_path):
    argv = ["montecarlo", "--rocket", str(C6), "--flights", "2", "--seed", str(SEED), "--workers", "1"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    for m in METHODS:
        assert any(line.startswith(m + " ") for line in out.splitlines()), m
    assert "mean|err| s" in out and "early>1s" in out and "fired before burnout" in out
    assert "flights/minute" in out
    assert main(argv + ["--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data["methods"]) == set(METHODS)
    for m in METHODS:
        assert set(data["methods"][m]) == set(METRIC_KEYS)
    assert data["flight_computer"]["n_flights"] == 2 and data["parameters"]["main_deploy_m"] == 0.0
    assert data["flight_computer"]["n_main"] == 0 and "no main planned" in out
    assert data["parameters"]["dispersions"]["cd"] == 0.10 and len(data["flights"]) == 2
    assert data["speed"]["workers"] == 1 and data["speed"]["flights_per_minute"] > 0
    # the same two flights as the study's first two
    study = run_rocket_study(settings_for(C6, SEED), 2, workers=1)
    assert data["methods"]["flight-computer"]["mean_abs_error_s"] == pytest.approx(
        study.table["flight-computer"]["mean_abs_error_s"], abs=0)
    # export of one flight
    path = tmp_path / "f1.csv"
    assert main(argv + ["--export-csv", str(path), "--flight", "1"]) == 0
    log = read_flight_csv(path)
    cd_scale = study.flights[1]["draw"]["cd_scale"]
    assert log.metadata_float("draw_cd_scale") == pytest.approx(cd_scale, abs=1e-6)
    capsys.readouterr()
    # errors: one line, status 2
    for bad, fragment in (
        (["montecarlo", "--workers", "2"], "needs --rocket"),
        (["montecarlo", "--config", "c.json"], "needs --rocket"),
        (["montecarlo", "--rocket", str(C6), "--main-altitude", "5"], "main_deploy_m = 5"),
        (["montecarlo", "--rocket", str(C6), "--config", str(tmp_path / "none.json")],
         "configuration file not found"),
        (["montecarlo", "--rocket", str(C6), "--params", "paper"], "--params"),
        (["montecarlo", "--rocket", str(tmp_path / "none.toml")], "not found"),
        (["montecarlo", "--rocket", str(C6), "--sensors", "bmp999+x"], "unknown sensor profile"),
    ):
        assert main(bad) == 2, bad
        err = capsys.readouterr().err.strip()
        assert fragment in err and "\n" not in err, err


def test_plots_are_written_and_markdown_table_has_every_method(c6_serial, tmp_path):
    paths = write_plots(c6_serial, tmp_path)
    assert [p.name for p in paths] == ["c6_model_error_histograms.png", "c6_model_example_flight.png",
                                       "c6_model_fc_error_vs_draws.png"]
    for p in paths:
        assert p.stat().st_size > 20000
    md = format_markdown(c6_serial)
    assert md.count("\n") == len(METHODS) + 1 and "**flight-computer**" in md


def test_deployment_plan_the_rocket_the_configuration_and_the_flag(tmp_path):
    m1670 = ROCKETS / "m1670_3km.toml"
    assert settings_for(m1670, 1).main_deploy_m == 400.0  # the rocket file's [main]
    assert settings_for(C6, 1).main_deploy_m == 0.0  # no [main]: no main
    s = settings_for(m1670, 1, config_values={"main_deploy_m": 300, "apogee_delay_s": 1})
    assert s.main_deploy_m == 300.0 and dict(s.config) == {"apogee_delay_s": 1}
    flag_wins = settings_for(m1670, 1, main_deploy_m=350, config_values={"main_deploy_m": 300})
    assert flag_wins.main_deploy_m == 350
    # no main: the simulated rocket flies without it, the record says "none", the computer fires none
    spec = load_rocket(m1670)
    draw = draw_flight(spec, 1, 0)
    assert apply_draw(spec, draw, 0.0).main is None
    assert apply_draw(spec, draw, 300.0).main.deploy_altitude_m == 300.0
    # the configuration reaches the flight computer, the plan comes from the record's metadata
    record_meta = {"main_deploy_m": "none"}
    log = read_flight_csv(_tiny_csv(tmp_path, record_meta))
    cfg = flight_computer_config(log, s)
    assert cfg.values["apogee_delay_s"] == 1 and cfg.values["main_deploy_m"] == 0


def _tiny_csv(tmp_path, metadata):
    from desktop.io.flightcsv import write_flight_csv

    path = tmp_path / "tiny.csv"
    write_flight_csv(path, {"time_s": [0.0, 0.01], "pressure_pa": [100000.0, 100000.0],
                            "accel_mps2": [9.8, 9.8]}, metadata=metadata)
    return path
