"""Pad, launch and proof of flight (docs/DESIGN.md D1, D13): the findings of the pad-safety review,
each reproduced, and the pad scenarios that must never fire.

Pad scenarios: pressure offsets of 20 to 60 m of both signs, as steps and as ramps rising over
0.05 to 5 s, held from 0.5 s to for ever, on barometer-only and two-sensor boards, with and without
shoves of 1 to 4 g lasting 50 to 300 ms. Every rule and timer is on (ALL_ON).
"""

import copy
from pathlib import Path

import numpy as np
import pytest

from shared.config import load_config
from shared.detector import HAVE_ACCEL, HAVE_BARO, HAVE_BOTH
from shared.flight import (
    BOOST,
    EV_APOGEE,
    EV_BACKUP_DROGUE,
    EV_BACKUP_MAIN,
    EV_DROGUE,
    EV_LAUNCH,
    EV_MAIN,
    EV_MODE,
    PAD,
    FlightComputer,
)
from shared.health import HEALTH_ACCEL_IMPLAUSIBLE
from tests.shared.test_arbitration import MACH14_ROCKET
from tests.support.fault_flight import MACH_ROCKET
from tests.support.fault_flight import fly as fault_flight
from tests.support.fault_flight import run as fault_run
from tools.synthetic_flight import make_flight

G = 9807
ALL_ON = {"backup_drogue_s": 20, "apogee_delay_s": 1, "apogee_lockout_s": 0, "main_guard_s": 1,
          "backup_drogue_delay_s": 1, "backup_main_m": 200}
ALTOS = Path(__file__).resolve().parents[1] / "data" / "flights" / "altos"
FIRING = EV_APOGEE | EV_DROGUE | EV_MAIN | EV_BACKUP_DROGUE | EV_BACKUP_MAIN


def run(dts, alts, accs, have, ground_alt_mm=None, prefix=0, **config):
    """Step a FlightComputer over the arrays; returns (fc, [(index, events)], pyro-on indices).

    ``prefix``: the first ``prefix`` samples are common to many scenarios (a grid's quiet pad before
    its disturbance): the computer's state after them, and their events and pyro indices, are
    computed once per identical prefix (the same samples, byte for byte, and the same
    configuration) and copied for each scenario; the result is the one a run from the first sample
    gives."""
    have = np.broadcast_to(have, len(dts))
    fc, events, pyro = _after_prefix(dts, alts, accs, have, ground_alt_mm, prefix, config)
    for i in range(prefix, len(dts)):
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), int(have[i]))
        if fc.events:
            events.append((i, fc.events))
        if fc.pyro_drogue or fc.pyro_main or fc.pyro_backup_drogue or fc.pyro_backup_main:
            pyro.append(i)
    return fc, events, pyro


_PREFIXES = {}  # (prefix samples, configuration) -> (computer after them, events, pyro indices)


def _after_prefix(dts, alts, accs, have, ground_alt_mm, prefix, config):
    if not prefix:
        return FlightComputer(load_config(config), ground_alt_mm=ground_alt_mm), [], []
    cols = [np.ascontiguousarray(a[:prefix], dtype=np.int64) for a in (dts, alts, accs, have)]
    key = (tuple(c.tobytes() for c in cols), ground_alt_mm, repr(sorted(config.items())))
    if key not in _PREFIXES:
        fc, events, pyro = run(dts[:prefix], alts[:prefix], accs[:prefix], have[:prefix], ground_alt_mm,
                               **config)
        _PREFIXES[key] = (fc, events, pyro)
    fc, events, pyro = _PREFIXES[key]
    return copy.deepcopy(fc), list(events), list(pyro)


def first(events, bit):
    return next((i for i, e in events if e & bit), None)


def pad(seconds, rate=50, seed=0, alt0_mm=300000):
    """A quiet pad: barometer noise 1 m, accelerometer noise 0.3 m/s^2."""
    rng = np.random.default_rng(seed)
    n = int(seconds * rate)
    alts = alt0_mm + rng.normal(0, 1000, n)
    accs = G + rng.normal(0, 300, n)
    return np.full(n, 1000000 // rate), alts.astype(np.int64), accs.astype(np.int64)


def flight(rate=100, seed=1, **kw):
    dts, alts, accs, truth, apogee = make_flight(rate_hz=rate, seed=seed, **kw)
    return np.array(dts), np.array(alts), np.array(accs) + G, np.array(truth), apogee


def offset_profile(n, rate, start, offset_mm, rise_s, hold_s):
    """A pressure disturbance in mm of altitude: a ramp to ``offset_mm`` over ``rise_s`` (0: a step)
    from sample ``start``, held ``hold_s`` (None: for ever), then gone."""
    t = (np.arange(n) - start) / rate
    if rise_s:
        shape = np.clip(t / rise_s, 0, 1)
    else:
        shape = (t >= 0).astype(float)
    if hold_s is not None:
        shape[t >= rise_s + hold_s] = 0
    return (shape * offset_mm).astype(np.int64)


def assert_never_fires(dts, alts, accs, sensors, prefix=0):
    for rule in ("velocity", "seed"):
        have = HAVE_BARO if sensors == "baro" else HAVE_BOTH
        fc, events, pyro = run(dts, alts, accs, have, prefix=prefix, sensors=sensors, apogee_rule=rule,
                               **ALL_ON)
        assert not [e for _, e in events if e & FIRING] and not pyro, (sensors, rule, events)


# -- finding 1: barometer-only boards fired on a pressure offset between the proof climb (30 m) and
# the pad re-base threshold (50 m) ---------------------------------------------------------------

@pytest.mark.parametrize("offset_m,hold_s", [(40, 2), (45, 2), (35, 5), (-40, 3), (-45, 3)])
def test_barometer_only_offset_between_proof_and_rebase_never_fires(offset_m, hold_s):
    dts, alts, accs = pad(60, seed=21)
    alts += offset_profile(len(dts), 50, 1000, offset_m * 1000, 0, hold_s)
    assert_never_fires(dts, alts, accs, "baro")


def test_altos_non_flight_without_its_accelerometer_fires_nothing():
    from desktop.io.flightcsv import read_flight_csv
    from desktop.review.replay import config_for, replay

    log = read_flight_csv(ALTOS / "2012-08-31-serial-334-flight-003.csv")
    log.accel_mps2 = None  # the same board as a barometer-only one
    for rule in ("velocity", "seed"):
        res = replay(log, config_for(log, overrides={"sensors": "baro", "apogee_rule": rule, **ALL_ON}))
        firing = ("apogee", "drogue", "main", "backup_drogue", "backup_main")
        assert not [e for e in res.events if e.event in firing], res.events


# -- finding 2: a shove plus a pressure offset proved flight on two-sensor boards; the coast clamp
# alone then satisfied the deceleration gate -----------------------------------------------------

@pytest.mark.parametrize("offset_m", [35, 42, 49])
def test_shove_with_pressure_offset_never_fires(offset_m):
    dts, alts, accs = pad(60, seed=22)
    accs[1000:1010] += int(2.5 * G)  # 2.5 g for 0.2 s: a shove on the rail
    alts += offset_profile(len(dts), 50, 1000, offset_m * 1000, 0.5, None)  # and it stays
    assert_never_fires(dts, alts, accs, "both")


def test_a_knock_a_pressure_step_taken_back_and_a_climbing_pressure_never_fire():
    """The proof counts both climbs from where the barometer came back into use (D13). A knock
    above proof_speed_mps (20 g for 0.16 s, and the rocket dropped back 0.3 s later) launches the
    board; its 80 m pressure step is left out and taken back; then the pressure climbs 60 m over
    4 s (the av-bay being sealed) with the board at rest: that climb is not the accelerometer's,
    and nothing fires."""
    dts, alts, accs = pad(60, seed=41)
    knock = 1000
    accs[knock:knock + 8] += 20 * G
    accs[knock + 15:knock + 23] -= 20 * G
    alts += offset_profile(len(dts), 50, knock, 80000, 0, None)
    alts += offset_profile(len(dts), 50, knock + 100, 60000, 4, None)
    _, events, _ = run(dts, alts, accs, HAVE_BOTH, sensors="both", **ALL_ON)
    modes = [i for i, e in events if e & EV_MODE]
    assert first(events, EV_LAUNCH) == knock + 4 and len(modes) == 2 and modes[1] < knock + 100
    assert_never_fires(dts, alts, accs, "both")


def test_apogee_gate_uses_the_measured_acceleration_not_the_coast_clamp():
    # a motor that chuffs (5 g for 0.4 s: the accelerometer's proof speed) while the av-bay seals
    # (+45 m that stays): proven, but the rocket stands on the pad reading +1 g. The boost timeout
    # moves to coast; the coast clamp (-0.5 g) must not pass for a deceleration
    dts, alts, accs = pad(60, seed=23)
    accs[1000:1020] += 5 * G
    alts += offset_profile(len(dts), 50, 1000, 45000, 0.5, None)
    for rule in ("velocity", "seed"):
        fc, events, pyro = run(dts, alts, accs, HAVE_BOTH, apogee_rule=rule)
        assert first(events, EV_APOGEE) is None and not pyro, events


@pytest.mark.parametrize("sensors", ["both", "baro"])
def test_apogee_gate_needs_a_coasts_averaged_deceleration(sensors):
    # the gate itself, on the sample before a clean flight's apogee: it passes at a coast's
    # deceleration and holds below coast_decel_mps2 (a user's 9 m/s^2; the default equals the
    # filter's coast clamp, so in a flight only a boost's lagging average reaches it) and beyond
    # 10 g (a filter swinging from a large error). No flight of the benchmarks isolates the gate:
    # on two-sensor boards the accelerometer's own coast is the measured check, without one the
    # 2 g of D16 rule 12 is tighter
    from shared.flight import _apogee_enabled

    dts, alts, accs, truth, apogee = flight(after_apogee_s=5)
    have = HAVE_BARO if sensors == "baro" else HAVE_BOTH
    fc = FlightComputer(load_config({"sensors": sensors, "coast_decel_mps2": 9}))
    for i in range(apogee):
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), have)
    cfg = fc.cfg
    assert fc.drogue_fired_ms < 0 and _apogee_enabled(fc, cfg, fc.now_ms)
    for decel_mmps2, passes in [(8500, False), (9500, True), (25000, sensors == "both"), (99000, False)]:
        fc.acc_avg_q4 = -decel_mmps2 << 4
        assert bool(_apogee_enabled(fc, cfg, fc.now_ms)) == passes, decel_mmps2


# -- finding 3: one bad barometer reading on the launch sample became the ground -----------------

@pytest.mark.parametrize("glitch_m", [60, -80, 300])
def test_bad_barometer_reading_on_the_launch_sample_is_not_the_ground(glitch_m):
    dts, alts, accs, truth, apogee = flight(after_apogee_s=200, alt_noise_mm=800)
    launch = None
    fc = FlightComputer(load_config())
    for i in range(len(dts)):  # find the launch sample, then put the glitch on it
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), HAVE_BOTH)
        if fc.events & EV_LAUNCH:
            launch = i
            break
    alts = alts.copy()
    alts[launch] += glitch_m * 1000
    fc, events, _ = run(dts, alts, accs, HAVE_BOTH)
    assert first(events, EV_LAUNCH) == launch
    assert abs(fc.ground_alt_mm - 300000) < 2000
    main = first(events, EV_MAIN)
    assert main is not None and abs(truth[main] - 300000 - 250000) <= 10000


# -- finding 4: out-of-range pressure in boost ------------------------------------------------------

@pytest.mark.parametrize("at", [250, 390, 397])  # boost: launch at 200, burnout at 400
@pytest.mark.parametrize("bad_alt_mm", [31054580, -698316, 9000000])  # pressure 0, 130 kPa, 9 km
def test_out_of_range_barometer_in_boost_is_not_used(bad_alt_mm, at):
    dts, alts, accs, truth, apogee = flight(after_apogee_s=20)
    alts = alts.copy()
    alts[at:at + 3] = bad_alt_mm  # three samples
    fc, events, _ = run(dts, alts, accs, HAVE_BOTH)
    assert abs(first(events, EV_DROGUE) - apogee) <= 30


# -- finding 5: the barometer fails before the proof climb -----------------------------------------

@pytest.mark.parametrize("lost_at", [150, 205, 230])  # on the pad, at launch, before 30 m
def test_barometer_lost_before_proof_falls_back_to_the_accelerometer(lost_at):
    dts, alts, accs, truth, apogee = flight(after_apogee_s=20)
    have = np.full(len(dts), HAVE_BOTH)
    have[lost_at:] = HAVE_ACCEL
    # the backup timer as docs/CONFIG.md tells users: nominal apogee (22.4 s after launch) + 3 s
    fc, events, _ = run(dts, alts, accs, have, backup_drogue_s=25)
    drogue, launch = first(events, EV_DROGUE), first(events, EV_LAUNCH)
    # the accelerometer-only apogee (docs/DESIGN.md D16): never early, late by at most its error
    # budget, or the backup timer first
    assert drogue is not None and apogee - 50 <= drogue <= launch + 2500 + 1


def test_accelerometer_lost_before_proof_falls_back_to_the_barometer():
    dts, alts, accs, truth, apogee = flight(after_apogee_s=20)
    have = np.full(len(dts), HAVE_BOTH)
    have[210:] = HAVE_BARO  # the accelerometer dies 0.1 s after launch
    fc, events, _ = run(dts, alts, accs, have)
    drogue = first(events, EV_DROGUE)
    assert drogue is not None and abs(drogue - apogee) <= 30


# -- finding 6: accelerometer-only boards open the main on a timer ---------------------------------

def test_accelerometer_only_main_on_the_timer_after_the_drogue():
    dts, alts, accs, truth, apogee = flight(after_apogee_s=60)
    # the drogue by the accelerometer-only apogee or the backup timer (nominal apogee + 3 s)
    fc, events, _ = run(dts, alts, accs, HAVE_ACCEL, sensors="accel", main_delay_s=12,
                        backup_drogue_s=25)
    drogue, main = first(events, EV_DROGUE), first(events, EV_MAIN)
    assert drogue is not None and main - drogue == 1200


# -- finding 7: low thrust-to-weight ----------------------------------------------------------------

@pytest.mark.parametrize("sensors", ["both", "baro"])
def test_thrust_to_weight_2_9_launches_and_fires_at_apogee(sensors):
    # 1.9 g kinematic (below launch_accel_mps2 = 20) for 3.77 s: apogee 384 m above the pad
    dts, alts, accs, truth, apogee = flight(boost_mmps2=18633, burn_ms=3770, after_apogee_s=60)
    assert 380000 < truth[apogee] - 300000 < 390000
    have = HAVE_BARO if sensors == "baro" else HAVE_BOTH
    fc, events, _ = run(dts, alts, accs, have, sensors=sensors)
    assert first(events, EV_LAUNCH) is not None and first(events, EV_LAUNCH) < 200 + 300
    assert abs(first(events, EV_DROGUE) - apogee) <= 30
    main = first(events, EV_MAIN)
    assert main is not None and abs(truth[main] - 300000 - 250000) <= 10000


# -- the main by altitude only after a proven maximum above it -------------------------------------

def test_under_performing_flight_opens_the_main_after_the_guard():
    # apogee 290 m: below main_deploy_m + main_margin_m, so the main follows the drogue after
    # main_guard_s rather than when the filter says 250 m (it must not land on its drogue)
    dts, alts, accs, truth, apogee = flight(boost_mmps2=30000, burn_ms=2180, after_apogee_s=60)
    assert 280000 < truth[apogee] - 300000 < 300000
    fc, events, _ = run(dts, alts, accs, HAVE_BOTH, main_guard_s=1)
    drogue, main = first(events, EV_DROGUE), first(events, EV_MAIN)
    assert main - drogue == 100


# -- the pad scenarios -----------------------------------------------------------------------------

SHOVES = [None, (1, 0.05), (2.5, 0.2), (4, 0.3), (4, 0.05), (1, 0.3)]  # (g, s) on the rail


PAD_START = 600  # the grids' disturbances start at sample 600: the samples before are the same pad


def _scenario(offset_m, rise_s, hold_s, shove, seed):
    dts, alts, accs = pad(40, seed=seed)
    start = PAD_START
    alts += offset_profile(len(dts), 50, start, offset_m * 1000, rise_s, hold_s)
    if shove is not None:
        g, s = shove
        accs[start:start + max(1, int(s * 50))] += int(g * G)
    return dts, alts, accs


FAST_GRID = [(o, r, h, s) for o in (20, -35, 45, 60, -60) for r in (0, 0.05, 1, 5) for h in (0.5, 3, None)
             for s in (None, (4, 0.3))]


@pytest.mark.parametrize("offset_m,rise_s,hold_s,shove", FAST_GRID[::4])
@pytest.mark.parametrize("sensors", ["baro", "both"])
def test_pad_offsets_steps_ramps_and_shoves_never_fire(sensors, offset_m, rise_s, hold_s, shove):
    assert_never_fires(*_scenario(offset_m, rise_s, hold_s, shove, seed=30), sensors, prefix=PAD_START)


@pytest.mark.slow
@pytest.mark.parametrize("sensors", ["baro", "both"])
@pytest.mark.parametrize("offset_m", [20, 30, 40, 50, 60, -20, -30, -40, -50, -60])
def test_pad_scenario_grid_never_fires(sensors, offset_m):
    for rise_s in (0, 0.05, 0.2, 1, 2.5, 5):
        for hold_s in (0.5, 1, 2, 5, None):
            for shove in SHOVES:
                dts, alts, accs = _scenario(offset_m, rise_s, hold_s, shove, seed=31)
                have = HAVE_BARO if sensors == "baro" else HAVE_BOTH
                fc, events, pyro = run(dts, alts, accs, have, prefix=PAD_START, sensors=sensors, **ALL_ON)
                assert not [e for _, e in events if e & FIRING] and not pyro, (
                    rise_s, hold_s, shove, events)


@pytest.mark.parametrize("sensors", ["both", "baro"])
def test_a_pad_offset_that_launched_returns_to_the_pad_and_a_real_flight_still_flies(sensors):
    # +45 m in 1 s that stays (the av-bay sealed while the rocket stood): on a barometer-only board
    # it looks like a launch by height and speed, but it proves nothing; the board returns to pad
    # mode (at rest, though not near the old pad level) and the real flight 30 s later fires at
    # apogee
    dts, alts, accs = pad(40, seed=33)
    alts += offset_profile(len(dts), 50, 300, 45000, 1, None)
    dts2, alts2, accs2, truth, apogee = flight(rate=50, seed=34, after_apogee_s=30)
    alts2 = alts2 - alts2[0] + alts[-1]
    fc = FlightComputer(load_config({"sensors": sensors}))
    have = HAVE_BARO if sensors == "baro" else HAVE_BOTH
    states, drogue = [], None
    for arrays in ((dts, alts, accs), (dts2, alts2, accs2)):
        for i in range(len(arrays[0])):
            fc.step(int(arrays[0][i]), int(arrays[1][i]), int(arrays[2][i]), have)
            states.append(fc.state)
            if fc.events & EV_DROGUE and arrays[0] is dts2:
                drogue = i
    assert states[len(dts) - 1] == PAD
    assert drogue is not None and abs(drogue - apogee) <= 15
    assert BOOST in states[len(dts):]


# -- one test per safety rule that the tests above do not already isolate (tools/mutate.py) -----

def test_main_needs_proof_of_flight():
    # a resume record that says "drogue fired" but not "proven" (a corrupted record): no main
    from shared.flight import STATE_RECORD_SIZE

    dts, alts, accs, truth, apogee = flight(after_apogee_s=120)
    fc = FlightComputer(load_config())
    record = bytearray(STATE_RECORD_SIZE)
    for i in range(len(dts)):
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), HAVE_BOTH)
        if fc.events & EV_DROGUE:
            fc.launched = fc.flight_proven = False  # the corruption
            fc.save_state(record)
            break
    fc = FlightComputer(load_config())
    assert fc.restore_state(record) and not fc.flight_proven
    events = []
    for j in range(i + 1, len(dts)):
        fc.step(int(dts[j]), int(alts[j]), int(accs[j]), HAVE_BOTH)
        events.append(fc.events)
    assert not any(e & EV_MAIN for e in events) and not fc.pyro_main


def test_barometer_only_slow_climb_never_proves():
    # the barometer alone climbs 130 m at 8.7 m/s (the filter overshoots to 12 m/s, below
    # proof_speed_mps) and stays: it launches by height, but a climb slower than any rocket's
    # proves nothing, even past a proof climb lowered to 60 m
    dts, alts, accs = pad(60, seed=40)
    alts += offset_profile(len(dts), 50, 500, 130000, 15, None)
    fc, events, pyro = run(dts, alts, accs, HAVE_BARO, sensors="baro", proof_baro_climb_m=60, **ALL_ON)
    assert first(events, EV_LAUNCH) is not None
    assert not fc.flight_proven and not pyro and first(events, FIRING) is None


def test_apogee_needs_proof_of_flight():
    # a barometer-only flight to 80 m (below proof_baro_climb_m) proves nothing: no apogee at all
    dts, alts, accs, truth, apogee = flight(boost_mmps2=30000, burn_ms=1150, after_apogee_s=30)
    assert 70000 < truth[apogee] - 300000 < 90000
    fc, events, pyro = run(dts, alts, accs, HAVE_BARO, sensors="baro")
    assert first(events, EV_LAUNCH) is not None and first(events, EV_APOGEE) is None and not pyro


@pytest.mark.parametrize("sensors,rest_g", [("baro", 0), ("both", 0), ("both", -1)])
def test_no_apogee_on_the_ground_after_a_lockout_that_outlasted_the_flight(sensors, rest_g):
    # a weak motor: 150 m instead of the simulation's flight, and the Mach time lockout set from
    # that simulation (15 s) outlasts it. The rocket falls ballistically, hits the ground at
    # 55 m/s 11.7 s after launch and lies there (on its side, or nose down in the dirt). In coast
    # the filter's acceleration is clamped at -0.5 g (no upward push), so the deceleration gate
    # passes a rocket at rest: only the altitude above proof_climb_m keeps the drogue from firing
    # on the ground when the lockout ends (the backup timer, off by default, would fire regardless)
    dts, alts, accs, truth, apogee = flight(boost_mmps2=50000, burn_ms=1000, descent_mps=1000,
                                            after_apogee_s=8)
    hit = apogee + int(np.argmax(truth[apogee:] <= 300000))
    rng = np.random.default_rng(5)
    rest = 3000  # 30 s on the ground
    dts = np.concatenate([dts[:hit], np.full(rest, 10000)])
    alts = np.concatenate([alts[:hit], 300000 + rng.normal(0, 1000, rest).astype(np.int64)])
    accs = np.concatenate([accs[:hit], rest_g * G + rng.normal(0, 300, rest).astype(np.int64)])
    have = HAVE_BARO if sensors == "baro" else HAVE_BOTH
    fc, events, pyro = run(dts, alts, accs, have, sensors=sensors, mach_lockout_s=15)
    assert first(events, EV_LAUNCH) is not None and fc.flight_proven
    assert first(events, EV_APOGEE) is None and not pyro


def test_main_only_while_descending():
    # the backup timer fires the drogue in the climb (at proof, 160 m): after the guard time the
    # rocket is still below main_deploy_m + main_margin_m, but climbing: the main waits for the
    # descent and then for its altitude
    dts, alts, accs, truth, apogee = flight(after_apogee_s=200)
    fc, events, _ = run(dts, alts, accs, HAVE_BOTH, backup_drogue_s=1.5, main_guard_s=1, main_deploy_m=500)
    drogue, main = first(events, EV_DROGUE), first(events, EV_MAIN)
    assert drogue < apogee and main > apogee
    assert abs(truth[main] - 300000 - 500000) <= 10000


def test_erratic_barometer_refuses_a_launch_by_height():
    # three pressure jumps of 80 m within a second on a barometer-only board, then its reading
    # climbs at 25 m/s to 100 m (what a launch by height reads): no launch while it is erratic
    dts, alts, accs = pad(30, seed=41)
    alts[1000:1003] += 80000
    alts[1006:1009] += 80000
    alts[1010:] += np.minimum(np.arange(len(alts) - 1010) * 500, 100000)
    fc = FlightComputer(load_config({"sensors": "baro"}))
    erratic = 0
    for i in range(len(dts)):
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), HAVE_BARO)
        erratic += bool(fc.errors & 8)
        assert not (fc.events & EV_LAUNCH and fc.errors & 8), i
    assert erratic


@pytest.mark.parametrize("spike_mm,burst,every,seconds", [
    (80000, 2, 4, 0.1), (-80000, 2, 5, 0.3), (80000, 3, 6, 1.0)])
def test_a_barometer_erratic_at_ignition_does_not_cancel_the_flight(spike_mm, burst, every, seconds):
    # the barometer jumping by 80 m for a few readings in every few from ignition on (the motor's
    # shock and pressure wave): until launch_accel_time_s has passed the board is on the pad, and
    # there three steps within a second make the barometer erratic. Its verdict refuses only its
    # own account of a launch: the accelerometer measures the boost, the flight is proven and the
    # drogue fires at apogee. Before, the board refused the launch and fired nothing at all
    dts, alts, accs, truth, apogee = flight(after_apogee_s=20)
    ignition = 200  # make_flight's 2 s of pad at 100 Hz
    alts = alts.copy()
    for start in range(ignition, ignition + int(seconds * 100), every):
        alts[start:start + burst] += spike_mm
    fc, events, _ = run(dts, alts, accs, HAVE_BOTH)
    assert fc.errors & 8  # it was erratic (and the flight log says so)
    assert abs(first(events, EV_LAUNCH) - ignition) <= 20
    assert abs(first(events, EV_DROGUE) - apogee) <= 30


@pytest.mark.parametrize("chance", [0.01, 0.05])
def test_single_barometer_glitches_are_not_pressure_steps(chance):
    # a barometer-only board whose barometer reads one reading in a hundred (or twenty) 100 m
    # off, pad included. Each such reading is a jump from the filter; taken as a pressure step
    # it re-based the pad, and its return re-based it again, three within a second made the
    # barometer erratic, which refuses the launch by height: the only launch such a board has,
    # and it fired nothing at all (both rates). A jump is a step only when the next reading
    # stays with it; a single reading off is a glitch, not used
    dts, alts, accs, truth, apogee = flight(pad_s=30, after_apogee_s=200)
    rng = np.random.default_rng(5)
    glitched = rng.random(len(alts)) < chance
    alts = alts.copy()
    alts[glitched] += rng.choice([-100000, 100000], glitched.sum())
    fc, events, _ = run(dts, alts, accs, HAVE_BARO, sensors="baro", main_deploy_m=500)
    assert not fc.errors & 8  # never erratic
    assert abs(first(events, EV_LAUNCH) - 3000) <= 100  # 30 s of pad at 100 Hz; by height
    assert abs(first(events, EV_DROGUE) - apogee) <= 30
    assert abs(truth[first(events, EV_MAIN)] - 300000 - 500000) <= 20000


@pytest.mark.parametrize("rocket, rate_hz, launch_height_m", [
    (MACH_ROCKET, 10, 20), (MACH14_ROCKET, 100, 100), (MACH_ROCKET, 100, 100)],
    ids=["mach2.4-10Hz", "mach1.65-launch-at-100m", "mach2.4-launch-at-100m"])
def test_a_fast_climb_on_the_barometer_alone_is_not_a_pressure_step(rocket, rate_hz, launch_height_m):
    # a barometer-only board launches by height. A boost that outruns the pad's filter (58 g read
    # at 10 Hz, or a launch height set at 100 m) put the reading 50 m from the filter before the
    # launch: a pressure step, the pad re-based (ground, filter at rest) again and again, and the
    # board launched 10 to 18 s after ignition, in the coast, its ground 2.6 to 5.4 km up: the
    # main fired at 2.9 to 5.7 km instead of 300 m
    fl = fault_flight(rocket, rate_hz=rate_hz, after_apogee_s=400)
    out = fault_run(fl, "baro", backup_drogue_s=round(fl.apogee_s + 3), main_deploy_m=300,
                    launch_height_m=launch_height_m)
    launch_s = next(t for t, ev, _mode, _flags in out.events if ev & EV_LAUNCH)
    assert 0 < launch_s < 1.2
    assert abs(out.fc.ground_alt_mm - fl.alt_mm[0]) < 1000
    assert abs(out.main_true_m - 300) < 20


@pytest.mark.parametrize("offset_m, rise_s, hold_s",
                         [(200, 0.2, None), (150, 0.2, None), (-200, 1, 3), (-200, 2, 3), (-200, 5, 3)])
def test_large_pad_pressure_ramps_on_the_barometer_alone_fire_nothing(offset_m, rise_s, hold_s):
    # beyond the 60 m disturbances the pad scenarios draw: what a first climb rule (a jump toward
    # which the filter moves) fired the drogue on: +200 m within 0.2 s (a climb at 100 g from rest
    # reaches 50 m in 0.3 s), and -200 m ramps whose filter rang and read the step back (200 m in
    # one reading) as a climb. The kept rule asks for a filter that accelerates upward at 0.5 to
    # 100 g (without that, +150 m within 0.2 s fired: 765 g from rest) and a reading within 1 km/s
    # of the last
    dts, alts, accs = pad(60, seed=7)
    alts = alts + offset_profile(len(dts), 50, 1000, offset_m * 1000, rise_s, hold_s)
    _fc, _events, pyro = run(dts, alts, accs, HAVE_BARO, sensors="baro")
    assert not pyro


@pytest.mark.parametrize("seed", [2, 3, 4])
def test_pressure_steps_on_the_pad_leave_the_orientation_check_right(seed):
    # the barometer 100 m off for two readings, one time in a hundred, from the pad on: each
    # excursion is two pressure steps (onto it and back), and each step re-bases the pad. The
    # re-base emptied the previous block's counts but not its sums, and the orientation check at
    # the block's end divided the stale sum by the new count: "not upright", launch refused, and
    # the board fired nothing at all (7 of 12 draws of a 30 s pad, these three among them)
    dts, alts, accs, truth, apogee = flight(pad_s=30, after_apogee_s=200)
    rng = np.random.default_rng(seed)
    alts = alts.copy()
    for start in np.flatnonzero(rng.random(len(alts)) < 0.01):
        alts[start:start + 2] += rng.choice([-100000, 100000])
    fc, events, _ = run(dts, alts, accs, HAVE_BOTH, main_deploy_m=500)
    assert not fc.errors & 1  # ERR_ORIENTATION
    assert abs(first(events, EV_LAUNCH) - 3000) <= 20  # 30 s of pad at 100 Hz
    assert abs(first(events, EV_DROGUE) - apogee) <= 30
    assert abs(truth[first(events, EV_MAIN)] - 300000 - 500000) <= 20000


@pytest.mark.parametrize("boost_mmps2, burn_ms, zeros_s", [
    (100000, 2000, None), (100000, 2000, 1.0), (6900, 6000, None)], ids=["10g", "10g-for-1s", "slow-0.7g"])
def test_zeros_from_ignition_leave_the_barometer_to_launch_and_prove(boost_mmps2, burn_ms, zeros_s):
    # the accelerometer's bus fails at ignition and reads 0 (zero bytes; for good, or for 1 s):
    # no boost, and the launch by height waited for an accelerometer that never pushed, so the
    # board stayed on the pad through the whole flight and fired nothing (14 of the fault
    # benchmark's 1,200 accel_zeroed runs with both sensors). Upright on the pad an accelerometer
    # reads 1 g: one value near zero held accel_stuck_s is retired for the flight (D16 rule 14),
    # and the barometer alone launches and proves it. The slow boost launches by height 2.4 s
    # after ignition: by then the pad's orientation check has averaged the zeros, and would
    # refuse the launch if it still judged the retired part
    dts, alts, accs, truth, apogee = flight(boost_mmps2=boost_mmps2, burn_ms=burn_ms, after_apogee_s=20)
    ignition = 200  # make_flight's 2 s of pad at 100 Hz
    accs = accs.copy()
    accs[ignition + 3:None if zeros_s is None else ignition + 3 + int(zeros_s * 100)] = 0
    fc, events, _ = run(dts, alts, accs, HAVE_BOTH)
    assert fc.health.flags & HEALTH_ACCEL_IMPLAUSIBLE
    assert first(events, EV_LAUNCH) is not None
    assert abs(first(events, EV_DROGUE) - apogee) <= 30


def test_an_accelerometer_reading_zeros_on_the_pad_fires_nothing_on_a_pressure_disturbance():
    # the bus fails on the pad, the board upright: the accelerometer is retired and the board
    # waits for a launch as a barometer-only one, whose proof (100 m held 1 s) no pad pressure
    # disturbance passes: 60 m offsets of either sign, as steps and as ramps over 2 s, held
    for offset_mm in (60000, -60000):
        for rise_s in (0, 2.0):
            dts, alts, accs = pad(30, rate=100)
            accs[300:] = 0
            alts = alts + offset_profile(len(dts), 100, 1000, offset_mm, rise_s, None).astype(np.int64)
            fc, events, pyro = run(dts, alts, accs, HAVE_BOTH, **ALL_ON)
            assert fc.health.flags & HEALTH_ACCEL_IMPLAUSIBLE
            assert not pyro and not any(e & FIRING for _, e in events)


def test_an_accelerometer_reading_zeros_from_power_on_refuses_the_launch():
    # a part that reads 0 from the first sample was never seen upright: the orientation check
    # refuses the launch (as for a board lying down), and the board fires nothing, even carried
    # through a climb of a flight's shape. Retired before that check (within accel_stuck_s of
    # power-on), it would have launched and fired on the barometer alone
    dts, alts, accs, truth, apogee = flight(after_apogee_s=20)
    fc, events, pyro = run(dts, alts, np.zeros_like(accs), HAVE_BOTH, **ALL_ON)
    assert fc.errors & 1  # ERR_ORIENTATION
    assert first(events, EV_LAUNCH) is None
    assert not pyro and not any(e & FIRING for _, e in events)


@pytest.mark.parametrize("start_s, zeros_s", [(0.02, 0.5), (0.5, 0.9), (1.2, 0.6)])
def test_a_boost_the_accelerometer_partly_missed_is_proven_by_the_barometer(start_s, zeros_s):
    # the accelerometer's bus reads zeros for half a second to a second of a 2 s, 10 g boost,
    # then recovers: its integrated speed and height miss that thrust (50 to 90 m/s), and its
    # height never again agrees with the barometer's (10 m + 25 %), so the flight, climbing to
    # 2 km, was never proven and nothing fired (6 of the fault benchmark's 1,200 accel_zeroed runs
    # with both sensors). The barometer-only board's own account (100 m held 1 s at 15 m/s), with
    # the accelerometer's boost, proves it: the drogue at apogee
    dts, alts, accs, truth, apogee = flight(after_apogee_s=20)
    ignition = 200  # make_flight's 2 s of pad at 100 Hz
    accs = accs.copy()
    start = ignition + int(start_s * 100)
    accs[start:start + int(zeros_s * 100)] = 0
    fc, events, _ = run(dts, alts, accs, HAVE_BOTH)
    assert fc.flight_proven
    assert abs(first(events, EV_DROGUE) - apogee) <= 30


@pytest.mark.parametrize("boost_mmps2,burn_ms,range_g", [(196000, 1000, 16), (150000, 2000, 8)])
def test_clipped_accelerometer_is_not_used(boost_mmps2, burn_ms, range_g):
    # a part whose full scale is below the boost: its readings at full scale under-read. With the
    # barometer, the flight is still proven (the integrated height is then only a lower bound) and
    # fires at apogee; on an accelerometer-only board, never early (believing the clipped boost
    # put apogee seconds early)
    dts, alts, accs, truth, apogee = flight(boost_mmps2=boost_mmps2, burn_ms=burn_ms, after_apogee_s=20)
    limit = int(range_g * G * 0.98)
    accs = np.clip(accs, -limit - 10, limit + 10)
    fc, events, _ = run(dts, alts, accs, HAVE_BOTH, accel_range_g=range_g)
    assert fc.errors & 2
    assert abs(first(events, EV_DROGUE) - apogee) <= 30
    fc, events, _ = run(dts, alts, accs, HAVE_ACCEL, accel_range_g=range_g, sensors="accel")
    drogue = first(events, EV_DROGUE)
    assert drogue is None or drogue >= apogee - 60


def test_resume_settles_before_apogee_after_an_overestimated_reset():
    # the record saved 3 s before apogee (+30 m/s), the reset assumed to have cost 3 s when it cost
    # nothing: predicted across the gap, the filter's speed is about 0. It must re-learn it from the
    # barometer (the settle period) before any apogee decision, not fire 3 s early
    from shared.flight import STATE_RECORD_SIZE

    dts, alts, accs, truth, apogee = flight(after_apogee_s=20)
    fc = FlightComputer(load_config())
    record = bytearray(STATE_RECORD_SIZE)
    for i in range(apogee - 300):
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), HAVE_BOTH)
    fc.save_state(record)
    fc = FlightComputer(load_config())
    assert fc.restore_state(record, 3000)
    drogue = None
    for j in range(apogee - 300, len(dts)):
        fc.step(int(dts[j]), int(alts[j]), int(accs[j]), HAVE_BOTH)
        if fc.events & EV_DROGUE:
            drogue = j
            break
    assert drogue is not None and abs(drogue - apogee) <= 50


def test_out_of_range_barometer_on_the_pad_is_not_a_pressure_step():
    # a BMP280 returning pressure 0 (31 km after the altitude table) three times in the last second
    # on the pad: not readings, so neither pressure steps nor an erratic barometer (which would
    # refuse the launch that follows)
    dts, alts, accs, truth, apogee = flight(pad_s=3, after_apogee_s=20)
    alts = alts.copy()
    alts[[200, 230, 260]] = 31054580
    fc, events, _ = run(dts, alts, accs, HAVE_BOTH)
    assert not fc.errors & 12  # ERR_PAD_BARO_STEP, ERR_BARO_ERRATIC
    assert abs(first(events, EV_LAUNCH) - 300) <= 20
    assert abs(first(events, EV_DROGUE) - apogee) <= 30


@pytest.mark.parametrize("rule", ["velocity", "seed"])
def test_barometer_transient_in_coast_does_not_fire_early(rule):
    # 3 s before apogee the barometer reads 100 m low for 0.4 s (a pressure transient at the port):
    # outside the coast gate, not used; apogee is found on time
    dts, alts, accs, truth, apogee = flight(after_apogee_s=20)
    alts = alts.copy()
    alts[apogee - 300:apogee - 260] -= 100000
    fc, events, _ = run(dts, alts, accs, HAVE_BOTH, apogee_rule=rule)
    assert abs(first(events, EV_DROGUE) - apogee) <= 30
