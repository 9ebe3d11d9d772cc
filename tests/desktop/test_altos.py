"""AltOS's published algorithm (desktop/study/altos.py) against independent expectations: the gains
AltOS's generator publishes, the decisions the AltOS boards logged on their own flights, the
reference apogees of the FIRM flights, and AltOS's known pad-anomaly hazard."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from desktop.io.flightcsv import read_flight_csv
from desktop.sim.trajectory import drag_free_vertical
from desktop.study.altos import AltosSettings, altos_gains, run_altos, run_altos_log
from shared.physics import G0_MPS2

DATA = Path(__file__).resolve().parent.parent / "data" / "flights"
REFERENCE = json.loads((DATA / "altos" / "reference.json").read_text())["flights"]


@pytest.mark.parametrize("dt, kind, published", [
    # SI gains of AltOS's 100 Hz and 10 Hz builds (rows h, v, a; columns baro, accel)
    (0.01, "both", [[0.0081273, 8.964e-4], [0.0033206, 0.0094928], [9.96e-5, 0.0951244]]),
    (0.01, "baro", [[0.0294315], [0.0439599], [0.0328391]]),
    (0.01, "accel", [[0.0019636], [0.0097562], [0.0487656]]),
    (0.1, "both", [[0.077975, 0.0253968], [0.0319869, 0.0832237], [0.0028219, 0.26999]]),
    (0.1, "baro", [[0.183475], [0.185737], [0.0952496]]),
    (1.0, "baro", [[0.7994], [0.356718], [0.149295]]),
])
def test_gains_match_the_published_altos_gains(dt, kind, published):
    assert altos_gains(dt, kind) == pytest.approx(np.array(published), rel=2e-4)


@pytest.mark.slow
def test_drag_free_flight_apogee_within_a_tenth_of_a_second():
    # ideal sensors at 100 Hz, 1 s on the pad (held at the first sample), 1.8 km drag-free flight
    traj = drag_free_vertical(thrust_n=200.0, burn_time_s=2.0, dry_mass_kg=2.0)
    t = np.concatenate([np.arange(-1.0, 0.0, 0.01), traj.time_s[::10]])
    pad = t < 0
    p = np.concatenate([np.full(pad.sum(), traj.pressure_pa[0]), traj.pressure_pa[::10]])
    f = np.concatenate([np.full(pad.sum(), G0_MPS2), traj.accel_mps2[::10]])
    res = run_altos(t, p, f, AltosSettings())
    assert abs(res.time("drogue") - traj.apogee_time_s) < 0.1
    # burnout when the filtered acceleration falls below -2.5 m/s^2: after the thrust ends, soon
    assert 0.0 <= res.time("burnout") - traj.burnout_time_s <= 0.3


CLEAN = sorted(name for name, ref in REFERENCE.items() if ref["clean"])


@pytest.fixture(scope="module")
def altos_on_logs():
    return {name: run_altos_log(read_flight_csv(DATA / "altos" / name)) for name in REFERENCE}


@pytest.mark.slow
def test_decides_where_the_altos_boards_decided(altos_on_logs):
    # The boards logged their state change up to 0.1 s late and ran 2012 firmware (fast state at
    # 200 m/s, accelerometer zero from the pad), so single flights may differ; most must agree.
    diff = np.array([altos_on_logs[n].time("drogue") - REFERENCE[n]["board_logged_s"] for n in CLEAN])
    assert np.all(np.isfinite(diff))
    assert np.sum(np.abs(diff) <= 0.35) >= 12, diff
    assert np.all(np.abs(diff) <= 1.2), diff
    err = np.array([altos_on_logs[n].time("drogue") - REFERENCE[n]["apogee_time_s"] for n in CLEAN])
    assert np.mean(np.abs(err)) < 0.35  # AltOS's published figure on real flights: 0.34 s


@pytest.mark.slow
def test_main_fires_at_its_altitude_on_the_altos_logs(altos_on_logs):
    for name in CLEAN:
        log = read_flight_csv(DATA / "altos" / name)
        main_s = altos_on_logs[name].time("main")
        if not math.isfinite(main_s):
            assert name == "2012-09-29-serial-341-flight-005.csv"  # the log ends before the main
            continue
        # the board's own main at the same altitude (250 m): the logged state changes there
        board_main = log.time_s[np.flatnonzero(log.extra["altos_state"] == "main")[0]]
        assert abs(main_s - board_main) < 1.0, name


@pytest.mark.slow
def test_pad_anomaly_fools_altos(altos_on_logs):
    # 334-003 is not a flight: a knock and a pressure transient. Under AltOS's current rules it
    # reaches "apogee" about 2.5 s in (no minimum altitude, no proof of flight): the known hazard.
    assert altos_on_logs["2012-08-31-serial-334-flight-003.csv"].time("drogue") < 3.0


@pytest.mark.slow
@pytest.mark.parametrize("name", ["firm-jackpot-1.csv", "firm-jackpot-3.csv", "firm-jackpot-4.csv"])
def test_firm_flights_within_0_4_s_of_reference_apogee(name):
    log = read_flight_csv(DATA / "firm" / name)
    res = run_altos_log(log)
    assert abs(res.time("drogue") - log.metadata_float("reference_apogee_time_s")) < 0.4
