"""Backup charges (docs/CONFIG.md, "Backup charges"): a second drogue channel that fires
``backup_drogue_delay_s`` after the drogue, a second main channel that fires at ``backup_main_m``
(without a usable barometer: ``backup_main_delay_s`` after the main). Each obeys the primaries'
proof of flight, fires only after its primary fired (never on the pad, in the ascent or landed),
at most once (also across a reset), with its own pulse; both are off by default and then change
nothing.

The synthetic flights (tools/synthetic_flight.py) are exact kinematics at 100 Hz, the pad 300 m
above the datum, a descent of 20 m/s; the corrupted resume records are the way the state machine
can be put in a state its own rules never reach (the proof and primary checks of each backup are
defence in depth: tools/mutate.py removes each in turn)."""

import copy
from pathlib import Path

import numpy as np
import pytest

from shared.config import load_config
from shared.detector import HAVE_ACCEL, HAVE_BARO, HAVE_BOTH
from shared.flight import (
    EV_BACKUP_DROGUE,
    EV_BACKUP_MAIN,
    EV_DROGUE,
    EV_MAIN,
    LANDED,
    STATE_RECORD_SIZE,
    FlightComputer,
)
from tests.shared.test_pad_launch_proof import FAST_GRID, PAD_START, _scenario, flight

BACKUPS = {"backup_drogue_delay_s": 1.5, "backup_main_m": 150}
BITS = {"drogue": EV_DROGUE, "main": EV_MAIN, "backup_drogue": EV_BACKUP_DROGUE,
        "backup_main": EV_BACKUP_MAIN}
OUTPUTS = {"drogue": "pyro_drogue", "main": "pyro_main", "backup_drogue": "pyro_backup_drogue",
           "backup_main": "pyro_backup_main"}
GROUND_MM = 300000  # make_flight's pad
DATA = Path(__file__).resolve().parents[1] / "data" / "flights"


def fly(dts, alts, accs, have, fc=None, start=0, **config):
    """Step ``fc`` (a new FlightComputer with ``config`` when None) over samples ``start``..;
    returns (fc, {channel: [samples it fired]}, {channel: [samples its output was on]})."""
    if fc is None:
        fc = FlightComputer(load_config(config))
    fired = {name: [] for name in BITS}
    on = {name: [] for name in BITS}
    have = np.broadcast_to(have, len(dts))
    for i in range(start, len(dts)):
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), int(have[i]))
        for name in BITS:
            if fc.events & BITS[name]:
                fired[name].append(i)
            if getattr(fc, OUTPUTS[name]):
                on[name].append(i)
    return fc, fired, on


_PREFIXES = {}  # (prefix samples, configuration) -> fly()'s result over them


def fly_after_prefix(dts, alts, accs, have, prefix, **config):
    """fly() from the first sample, with the first ``prefix`` samples (a grid's quiet pad before
    its disturbance) flown once per identical prefix (the same samples, byte for byte, and the same
    configuration): the computer after them is deep-copied and flies on from there; the firing and
    output lists are the prefix's followed by the rest's, as one fly() from sample 0 gives them."""
    have = np.broadcast_to(have, len(dts))
    cols = [np.ascontiguousarray(a[:prefix], dtype=np.int64) for a in (dts, alts, accs, have)]
    key = (tuple(c.tobytes() for c in cols), repr(sorted(config.items())))
    if key not in _PREFIXES:
        _PREFIXES[key] = fly(dts[:prefix], alts[:prefix], accs[:prefix], have[:prefix], **config)
    fc0, fired0, on0 = _PREFIXES[key]
    fc, fired, on = fly(dts, alts, accs, have, fc=copy.deepcopy(fc0), start=prefix)
    return fc, {k: fired0[k] + fired[k] for k in fired}, {k: on0[k] + on[k] for k in on}


def corrupted(dts, alts, accs, at_bit, corrupt, **config):
    """Fly to the sample of ``at_bit``, apply ``corrupt(fc)``, save the resume record there and
    resume a new FlightComputer from it; returns (fc, next sample). The record's check is valid:
    this is the state a bug (or a corrupted record that passes its check) would leave."""
    fc = FlightComputer(load_config(config))
    record = bytearray(STATE_RECORD_SIZE)
    for i in range(len(dts)):
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), HAVE_BOTH)
        if fc.events & at_bit:
            corrupt(fc)
            fc.save_state(record)
            break
    fc = FlightComputer(load_config(config))
    assert fc.restore_state(record)
    return fc, i + 1


# -- on time, once, each its own pulse ------------------------------------------------------------

@pytest.mark.parametrize("sensors,have", [("both", HAVE_BOTH), ("baro", HAVE_BARO)])
def test_backups_fire_after_their_primaries_on_a_synthetic_flight(sensors, have):
    dts, alts, accs, truth, apogee = flight(after_apogee_s=200)
    fc, fired, on = fly(dts, alts, accs, have, sensors=sensors, pulse_ms=300, **BACKUPS)
    for name in BITS:  # each once, its own pulse: 300 ms at 100 Hz from the sample it fired
        assert len(fired[name]) == 1, (name, fired)
        assert on[name] == list(range(fired[name][0], fired[name][0] + 30)), name
    assert fired["backup_drogue"][0] - fired["drogue"][0] == 150  # backup_drogue_delay_s
    assert abs(truth[fired["backup_main"][0]] - GROUND_MM - 150000) <= 10000  # within 10 m
    assert fired["backup_main"][0] - fired["main"][0] >= 100  # backup_main_delay_s (1 s)


def test_backup_main_without_a_barometer_fires_its_delay_after_the_main():
    # accelerometer only: the main on main_delay_s after the drogue (docs/CONFIG.md), the backup
    # main backup_main_delay_s after the main (its altitude is unknown)
    dts, alts, accs, truth, apogee = flight(after_apogee_s=60)
    fc, fired, _ = fly(dts, alts, accs, HAVE_ACCEL, sensors="accel", main_delay_s=12, backup_drogue_s=25,
                       backup_main_delay_s=3, **BACKUPS)
    assert len(fired["main"]) == 1 and fired["main"][0] - fired["drogue"][0] == 1200
    assert fired["backup_main"] == [fired["main"][0] + 300]


def test_backup_main_waits_for_the_main_and_its_delay_on_a_low_flight():
    # apogee about 140 m, below main_deploy_m (250) and backup_main_m (200): the main follows the
    # drogue after main_guard_s, the backup main backup_main_delay_s after the main, never before it
    dts, alts, accs, truth, apogee = flight(boost_mmps2=30000, burn_ms=1500, after_apogee_s=30)
    assert 120000 < truth[apogee] - GROUND_MM < 160000
    fc, fired, _ = fly(dts, alts, accs, HAVE_BOTH, main_guard_s=1, backup_main_m=200, backup_main_delay_s=2)
    assert fired["main"][0] - fired["drogue"][0] == 100
    assert fired["backup_main"] == [fired["main"][0] + 200]


def test_backups_on_a_real_flight_replay():
    # a TeleMetrum flight to 731 m (tests/data/flights/altos, GPL-2.0-or-later data)
    from desktop.io.flightcsv import read_flight_csv
    from desktop.review.replay import config_for, replay

    log = read_flight_csv(DATA / "altos" / "2012-04-07-serial-892-flight-002.csv")
    res = replay(log, config_for(log, overrides=BACKUPS))
    events = {e.event: [x for x in res.events if x.event == e.event] for e in res.events}
    for name in BITS:
        assert len(events[name]) == 1, (name, res.events)
    drogue, backup_drogue = events["drogue"][0], events["backup_drogue"][0]
    assert 1.5 <= backup_drogue.time_s - drogue.time_s <= 1.5 + 0.011  # a sample at 100 Hz
    main, backup_main = events["main"][0], events["backup_main"][0]
    assert backup_main.time_s - main.time_s >= 1.0
    assert 140 <= backup_main.altitude_m <= 150  # the filtered altitude crossing 150 m
    assert res.pyro_backup_drogue.sum() == res.pyro_backup_main.sum() == res.pyro_drogue.sum()


# -- off by default: nothing changes --------------------------------------------------------------

def _trace(fc, dts, alts, accs, have):
    out = []
    for i in range(len(dts)):
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), int(have[i]))
        out.append((fc.state, fc.events & ~(EV_BACKUP_DROGUE | EV_BACKUP_MAIN), fc.pyro_drogue,
                    fc.pyro_main, fc.kf.alt_q4, fc.kf.vel_q4, fc.kf.acc_q4))
    return out


@pytest.mark.parametrize("name", ["altos/2012-04-07-serial-892-flight-002.csv",
                                  "altos/2012-08-31-serial-334-flight-003.csv",
                                  "firm/firm-jackpot-1.csv"])
def test_backups_change_nothing_else_and_are_off_by_default(name):
    # a flight, the AltOS non-flight, a FIRM flight: with the backups on, every state, primary
    # event, primary output and filter value is what it is with them off (the default); off, no
    # backup event or output ever appears
    from desktop.io.flightcsv import read_flight_csv
    from desktop.review.replay import config_for, ground_alt_mm, readings

    log = read_flight_csv(DATA / name)
    dts, alts, accs, have = readings(log)
    off = FlightComputer(config_for(log), ground_alt_mm=ground_alt_mm(log))
    on = FlightComputer(config_for(log, overrides=BACKUPS), ground_alt_mm=ground_alt_mm(log))
    assert _trace(off, dts, alts, accs, have) == _trace(on, dts, alts, accs, have)
    assert off.backup_drogue_fired_ms < 0 and off.backup_main_fired_ms < 0
    assert load_config().backup_drogue_delay_ms == 0 and load_config().backup_main_mm == 0


# -- never on the pad, in the ascent, without proof, without the primary, or twice -------------

@pytest.mark.parametrize("offset_m,rise_s,hold_s,shove", FAST_GRID[1::4])
@pytest.mark.parametrize("sensors", ["baro", "both"])
def test_pad_scenarios_with_backups_never_fire(sensors, offset_m, rise_s, hold_s, shove):
    dts, alts, accs = _scenario(offset_m, rise_s, hold_s, shove, seed=40)
    have = HAVE_BARO if sensors == "baro" else HAVE_BOTH
    for rule in ("velocity", "seed"):
        fc, fired, on = fly_after_prefix(dts, alts, accs, have, PAD_START, sensors=sensors, apogee_rule=rule,
                                         backup_drogue_s=20, apogee_delay_s=1, main_guard_s=1, **BACKUPS)
        assert not any(fired.values()) and not any(on.values()), (rule, fired)


@pytest.mark.parametrize("event, channel, after_apogee_s", [
    (EV_DROGUE, "backup_drogue", 60), (EV_MAIN, "backup_main", 200),
], ids=["drogue", "main"])
def test_backup_needs_proof_of_flight(event, channel, after_apogee_s):
    dts, alts, accs, truth, apogee = flight(after_apogee_s=after_apogee_s)

    def unproven(fc):
        fc.launched = fc.flight_proven = False

    # the same resume without the corruption fires the backup: the test can fail
    fc, j = corrupted(dts, alts, accs, event, lambda fc: None, **BACKUPS)
    assert fly(dts, alts, accs, HAVE_BOTH, fc=fc, start=j)[1][channel]
    fc, j = corrupted(dts, alts, accs, event, unproven, **BACKUPS)
    assert not fc.flight_proven
    _, fired, on = fly(dts, alts, accs, HAVE_BOTH, fc=fc, start=j)
    assert not fired[channel] and not on[channel]


def test_backup_drogue_only_after_the_drogue_fired():
    # a record in the drogue state without "drogue fired": no backup drogue (it has no primary to
    # back up; the main still follows its own rule)
    dts, alts, accs, truth, apogee = flight(after_apogee_s=60)

    def not_fired(fc):
        fc.drogue_fired_ms = fc.drogue_due_ms = -1

    fc, j = corrupted(dts, alts, accs, EV_DROGUE, not_fired, **BACKUPS)
    assert fc.drogue_fired_ms < 0 and fc.flight_proven
    _, fired, _ = fly(dts, alts, accs, HAVE_BOTH, fc=fc, start=j)
    assert not fired["backup_drogue"]


def test_backups_never_in_the_ascent():
    # a record in coast that says the drogue fired: the ascent fires nothing more (the drogue's
    # rule wants it unfired, the backups run in the drogue and main states only)
    from shared.flight import EV_BURNOUT

    dts, alts, accs, truth, apogee = flight(after_apogee_s=60)

    def drogue_fired(fc):
        fc.drogue_fired_ms = fc.now_ms

    fc, j = corrupted(dts, alts, accs, EV_BURNOUT, drogue_fired, **BACKUPS)
    assert fc.flight_proven and fc.drogue_fired_ms >= 0
    _, fired, on = fly(dts, alts, accs, HAVE_BOTH, fc=fc, start=j)
    assert not any(fired.values()) and not any(on.values()), fired


@pytest.mark.parametrize("after", ["backup_drogue", "backup_main"])
@pytest.mark.parametrize("outage_s", [0.01, 1.0])
def test_each_backup_fires_once_across_a_reset(after, outage_s):
    # a reset on the sample after a backup fired (its pulse still on): the resumed flight
    # computer knows it fired (the resume record) and never fires it again
    dts, alts, accs, truth, apogee = flight(after_apogee_s=200)
    fc = FlightComputer(load_config(BACKUPS))
    record = bytearray(STATE_RECORD_SIZE)
    fired = {name: [] for name in BITS}
    reset_at = None
    outage = int(outage_s * 100)
    for i in range(len(dts)):
        if reset_at is not None and reset_at <= i < reset_at + outage:
            continue
        if reset_at is not None and i == reset_at + outage:
            fc = FlightComputer(load_config(BACKUPS))
            assert fc.restore_state(record, gap_ms=1000)
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), HAVE_BOTH)
        if fc.events or i % 10 == 0:  # the device's saving policy (device/flightloop.py)
            fc.save_state(record)
        for name in BITS:
            if fc.events & BITS[name]:
                fired[name].append(i)
        if fc.events & BITS[after] and reset_at is None:
            reset_at = i + 1
    for name in BITS:
        assert len(fired[name]) == 1, (name, fired)


def test_no_backup_fires_once_landed():
    # a flight that lands before its backup main is due: nothing fires on the ground
    # (main at 250 m about 100 s after apogee, on the ground 12 s later, landed 10 s after that;
    # the backup main would be due 60 s after the main, at 0 m)
    dts, alts, accs, truth, apogee = flight(after_apogee_s=200)
    landing = int(np.argmax((truth <= GROUND_MM) & (np.arange(len(truth)) > apogee)))
    alts = alts.copy()
    rng = np.random.default_rng(41)
    alts[landing:] = GROUND_MM + rng.normal(0, 800, len(alts) - landing)  # on the ground
    fc, fired, on = fly(dts, alts, accs, HAVE_BOTH, backup_main_m=10, backup_main_delay_s=60)
    assert fc.state == LANDED
    assert fired["main"] and not fired["backup_main"] and not on["backup_main"]
