"""``python -m desktop montecarlo`` (desktop/study/montecarlo_cli.py, the seed paper's study in
seed_study.py): the table, JSON, plots, CSV export, the deprecated ``--params seed``."""

import json
import sys
import types

import numpy as np
import pytest

from desktop.cli import main
from desktop.sim import seed_model as sm
from desktop.study import baselines
from desktop.study import seed_study as mc
from desktop.study.metrics import METRIC_KEYS, metrics

N, SEED = 20, 5


def _fake_detect_module(monkeypatch):
    """A stand-in desktop.study.detect with the lead's interface, so the test covers the integration."""
    calls = []

    def fake(time_s, altitude_m, accel_mps2):
        calls.append(altitude_m.shape)
        return baselines.METHODS["boxcar/seed"](time_s, altitude_m, accel_mps2) + 0.5

    mod = types.ModuleType("desktop.study.detect")
    mod.METHODS = {"fake-integer": fake}
    monkeypatch.setitem(sys.modules, "desktop.study.detect", mod)
    # ``import desktop.study.detect as d`` reads the package attribute once the real module was imported
    import desktop.study

    monkeypatch.setattr(desktop.study, "detect", mod, raising=False)
    return calls


def test_table_is_printed(capsys, monkeypatch):
    _fake_detect_module(monkeypatch)
    assert main(["montecarlo", "--flights", str(N), "--seed", str(SEED)]) == 0
    out = capsys.readouterr().out
    assert f"{N} flights, seed {SEED}" in out
    for name in list(baselines.METHODS) + ["fake-integer"]:
        assert any(line.startswith(name + " ") for line in out.splitlines()), name
    assert "mean|err| s" in out and "early>1s" in out


def test_json_has_every_method_and_equals_direct_calls(capsys, monkeypatch):
    calls = _fake_detect_module(monkeypatch)
    assert main(["montecarlo", "--flights", str(N), "--seed", str(SEED), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["seed"] == SEED and data["parameters"]["flights"] == N
    assert data["parameters"]["pad_s"] == 2.0
    assert set(data["methods"]) == set(baselines.METHODS) | {"fake-integer"}
    assert calls, "desktop.study.detect.METHODS was not run"
    # every method's row equals the metrics of a direct call on the same flights
    fl = sm.simulate_monte_carlo(N, SEED, pad_s=2.0)
    for name, fn in mc.all_methods().items():
        d = fn(fl.time_s, fl.altitude_m, fl.accel_mps2)
        expect = metrics(d, fl.true_apogee_time_s, fl.true_velocity_at(d))
        got = data["methods"][name]
        assert set(got) == set(METRIC_KEYS)
        for key in METRIC_KEYS:
            assert got[key] == pytest.approx(expect[key], rel=1e-12, abs=1e-12), (name, key)


def test_study_detections_equal_direct_calls_in_any_chunking():
    res = mc.run_study(N, SEED, methods=dict(baselines.METHODS), chunk=7)
    fl = sm.simulate_monte_carlo(N, SEED, pad_s=2.0)
    np.testing.assert_array_equal(res.true_apogee_s, fl.true_apogee_time_s)
    for name, fn in baselines.METHODS.items():
        d = fn(fl.time_s, fl.altitude_m, fl.accel_mps2)
        np.testing.assert_array_equal(res.detections[name], d, err_msg=name)
        np.testing.assert_array_equal(res.velocities[name], fl.true_velocity_at(d), err_msg=name)


def test_metrics_by_hand():
    m = metrics(np.array([1.0, 2.5, np.nan, 4.0]), np.array([2.0, 2.0, 3.0, 3.0]),
                   np.array([9.81, -4.905, np.nan, -9.81]))
    assert m["mean_abs_error_s"] == pytest.approx((1 + 0.5 + 1) / 3)
    assert m["mean_error_s"] == pytest.approx((-1 + 0.5 + 1) / 3)
    assert m["median_abs_error_s"] == 1.0 and m["max_abs_error_s"] == 1.0
    assert m["mean_abs_velocity_mps"] == pytest.approx((9.81 + 4.905 + 9.81) / 3)
    assert m["n_early_1s"] == 0 and m["n_no_detection"] == 1
    m = metrics(np.array([0.5]), np.array([2.0]), np.array([15.0]))
    assert m["n_early_1s"] == 1


@pytest.mark.slow  # matplotlib figures
def test_plots_are_written(tmp_path, capsys):
    assert main(["montecarlo", "--flights", "12", "--seed", "2", "--no-detect", "--plots",
                 str(tmp_path)]) == 0
    names = {"fig5_1_kalman_vs_boxcar.png", "fig5_2_abs_error.png", "fig2_2_boxcar.png",
             "fig2_3_butterworth.png", "fig2_4_elliptic.png", "error_histograms.png"}
    assert {p.name for p in tmp_path.iterdir()} == names
    for name in names:
        data = (tmp_path / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10000, name


def test_export_csv_writes_the_simulated_flight_and_the_paper_flight(tmp_path, capsys):
    flightcsv = pytest.importorskip("desktop.io.flightcsv")
    path = tmp_path / "f3.csv"
    assert main(["montecarlo", "--seed", "4", "--export-csv", str(path), "--flight", "3"]) == 0
    log = flightcsv.read_flight_csv(path)
    fl = sm.simulate(4, [3], pad_s=2.0)
    assert log.columns == ["time_s", "altitude_m", "accel_mps2", "true_altitude_m", "true_velocity_mps"]
    np.testing.assert_allclose(log.altitude_m, fl.altitude_m[0])
    kin = (log.accel_mps2 - 9.81) / 3
    np.testing.assert_allclose(kin, np.round(kin), atol=1e-4)
    assert log.metadata_float("true_apogee_time_s") == pytest.approx(fl.true_apogee_time_s[0])
    assert log.metadata_float("true_apogee_m") == pytest.approx(fl.true_apogee_m[0])
    assert log.metadata_float("flight_index") == 3 and log.metadata_float("seed") == 4
    assert log.metadata_float("a_peak_mps2") == pytest.approx(fl.params.a_peak_mps2[0])
    # the paper's exact default flight: no pad, 15 s
    path = tmp_path / "paper.csv"
    assert main(["montecarlo", "--params", "paper", "--seed", "1", "--export-csv", str(path)]) == 0
    log = flightcsv.read_flight_csv(path)
    assert len(log) == 300 and log.time_s[0] == 0.0
    assert log.metadata_float("true_apogee_time_s") == pytest.approx(6.9235, abs=1e-4)
    assert log.metadata["params"] == "paper"
    capsys.readouterr()
    # its former name still works, with a one-line note on stderr, and writes the same flight
    old = tmp_path / "seed.csv"
    assert main(["montecarlo", "--params", "seed", "--seed", "1", "--export-csv", str(old)]) == 0
    assert capsys.readouterr().err == "note: --params seed is deprecated, use --params paper\n"
    assert old.read_bytes() == path.read_bytes()
