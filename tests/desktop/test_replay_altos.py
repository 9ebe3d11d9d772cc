"""Replays of the 16 real AltOS flights through the exact board code (tests/data/flights/altos/,
GPL-2.0-or-later data; reference apogees in its README, a non-causal fit of the whole record)."""

import json
from pathlib import Path

import numpy as np
import pytest

from desktop.io.flightcsv import read_flight_csv
from desktop.review.replay import config_for, replay

DATA = Path(__file__).parents[1] / "data" / "flights" / "altos"
REFERENCE = json.loads((DATA / "reference.json").read_text())["flights"]


@pytest.fixture(scope="module")
def results():
    out = {}
    for name in sorted(REFERENCE):
        log = read_flight_csv(DATA / name)
        out[name] = (log, replay(log, config_for(log)))
    return out


def test_non_flight_never_fires(results):
    name = next(n for n, r in REFERENCE.items() if r["non_flight"])
    _, res = results[name]
    assert not res.pyro_drogue.any() and not res.pyro_main.any()
    assert not [e for e in res.events if e.event in ("apogee", "drogue", "main")]


def test_clean_flights_drogue_near_reference_apogee(results):
    errors = []
    for name, ref in REFERENCE.items():
        if not ref["clean"]:
            continue
        _, res = results[name]
        drogue = res.first("drogue")
        assert drogue is not None, name
        errors.append(drogue.time_s - ref["apogee_time_s"])
    assert min(errors) >= -0.3  # none more than 0.3 s early
    errors = np.abs(errors)
    assert len(errors) == 14
    # Measured: mean 0.120 s, max 0.26 s (issue goal: mean <= 0.15 s, max <= 0.30 s; the boards'
    # own decisions: mean 0.18 s, max 0.54 s). docs/BENCHMARKS.md has the per-flight table.
    assert errors.max() <= 0.30
    assert errors.mean() <= 0.15


def test_anomalous_flight_within_its_window(results):
    """319-005 tumbles near its burnout (a barometric apogee of 155 m at 2.65 s): the axial
    accelerometer's track is not the vertical motion. Measured +0.90 s (+0.76 s before D16 rule
    22 held the filter, falling faster than that track, for 0.14 s more)."""
    name = "2012-05-28-serial-319-flight-005.csv"
    _, res = results[name]
    err = res.first("drogue").time_s - REFERENCE[name]["apogee_time_s"]
    assert -0.2 <= err <= 1.0


def test_no_firing_before_burnout_and_main_at_configured_altitude(results):
    for name, (_log, res) in results.items():
        burnout = res.first("burnout")
        for ev in ("apogee", "drogue", "main"):
            e = res.first(ev)
            if e is not None:
                assert burnout is not None and e.index > burnout.index, (name, ev)
        main = res.first("main")
        if main is not None and REFERENCE[name]["apogee_altitude_m_agl"] and \
                REFERENCE[name]["apogee_altitude_m_agl"] > 260:
            # the barometric record at the main instant (median of the last three readings: the
            # board's own main charge, fired at the same 250 m, spikes the reading at that sample)
            baro_m = float(np.median(res.raw_agl_m[main.index - 2:main.index + 1]))
            assert abs(baro_m - 250) <= 10, (name, baro_m)


def test_no_real_flight_reads_as_a_noisy_accelerometer(results):
    # D16 rule 15 retires an accelerometer whose coast readings jump by 4 g on average: these
    # flights' coasts, judged from 0.5 s after burnout, jump by at most 2.5 g (319-005, tumbling)
    for name, (_log, res) in results.items():
        assert not [e for e in res.events if e.event == "health" and "accel noisy" in e.detail], name


def test_replay_is_deterministic(results):
    name = "2012-09-29-serial-341-flight-005.csv"
    log, res = results[name]
    again = replay(log, config_for(log))
    assert [(e.event, e.index) for e in again.events] == [(e.event, e.index) for e in res.events]
    assert np.array_equal(again.agl_m, res.agl_m)


def test_the_flights_as_barometer_only_boards():
    """The same records with the accelerometer's column ignored ("sensors": "baro"): the
    barometer-only rules (D16 rules 5, 10, 11, 12, 20) on real parts, quantised and lagging. Every
    flight gets a drogue (the non-flight none), none more than 0.3 s before the reference apogee;
    the clean ones within 0.3 s after it but 336-005, 4.0 s late: the board that flew it fired its
    drogue at 18.39 s, whose blast reads -155 m/s on the barometer at 18.49 s, just before the
    barometer-only filter's zero crossing, which then waits baro_settle_s after being off the
    barometer (a record whose own charges fired is no test of the rest; the anomalous 319-005, a
    tumble, 4.5 s late). Measured: 882-001 0.24 s early, the other clean ones 0.14 s
    early to 0.16 s late. A change that stopped rule 10's learning after every failing window left
    319-005 without a drogue and 336-005 27 s late, with every other test passing."""
    late_s = {"2012-09-03-serial-336-flight-005.csv": 4.1, "2012-05-28-serial-319-flight-005.csv": 4.6}
    for name, ref in sorted(REFERENCE.items()):
        log = read_flight_csv(DATA / name)
        res = replay(log, config_for(log, overrides={"sensors": "baro"}))
        drogue = res.first("drogue")
        if ref["non_flight"]:
            assert drogue is None, name
            continue
        assert drogue is not None, name
        err = drogue.time_s - ref["apogee_time_s"]
        assert -0.3 <= err <= late_s.get(name, 0.3), (name, err)
