"""The deploy state machine on synthetic flights and on the pad scenarios that must never fire.

Every pad scenario runs with every rule and timer enabled (docs/DESIGN.md D1), in each sensor
mode: barometer + accelerometer, barometer only, accelerometer only.
"""

import numpy as np
import pytest

from shared.config import load_config
from shared.detector import HAVE_ACCEL, HAVE_BARO, HAVE_BOTH
from shared.flight import (
    COAST,
    DROGUE,
    ERR_ORIENTATION,
    EV_APOGEE,
    EV_BACKUP_DROGUE,
    EV_BACKUP_MAIN,
    EV_DROGUE,
    EV_LANDED,
    EV_LAUNCH,
    EV_MAIN,
    FAST,
    LANDED,
    PAD,
    FlightComputer,
)
from tools.synthetic_flight import make_flight

G = 9807
FIRING = EV_APOGEE | EV_DROGUE | EV_MAIN | EV_BACKUP_DROGUE | EV_BACKUP_MAIN
ALL_ON = {"backup_drogue_s": 20, "apogee_delay_s": 1, "apogee_lockout_s": 0, "main_guard_s": 1,
          "backup_drogue_delay_s": 1, "backup_main_m": 200}


def test_the_folded_copies_of_other_modules_constants_agree():
    # shared/flight.py and shared/health.py fold their own _NAME copies of other modules' NAME
    # (on MicroPython an imported constant is a global lookup): each copy must equal its original
    import importlib
    import re
    from pathlib import Path

    shared = Path(__file__).resolve().parents[2] / "shared"
    modules = {path.stem: importlib.import_module("shared." + path.stem) for path in shared.glob("*.py")}
    copies = 0
    for stem, module in modules.items():
        for name in re.findall(r"^_([A-Z][A-Z0-9_]*) = const\(", (shared / (stem + ".py")).read_text(), re.M):
            originals = [other for other_stem, other in modules.items()
                         if other_stem != stem and isinstance(getattr(other, name, None), int)]
            for other in originals:
                assert getattr(module, "_" + name) == getattr(other, name), (stem, name, other.__name__)
                copies += 1
    # flight: the two masks, three models, two health masks; health: the masks; the detector:
    # the measurement limit; the arbitration: g
    assert copies >= 11
    from shared.physics import G_MMPS2

    assert modules["flight"]._NOT_DRAG_MMPS2 == -G_MMPS2 // 2
    # the change test's speed in coast is the track's own limit: every track is tested
    assert modules["flight"]._ANY_SPEED_MMPS == modules["arbitration"]._VEL_LIMIT_MMPS


def run(dts, alts, accs, have, **config):
    """Step a FlightComputer over integer arrays; returns (fc, events list, pyro-on samples)."""
    fc = FlightComputer(load_config(config))
    events, pyro = [], []
    for i in range(len(dts)):
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), int(have[i]))
        if fc.events:
            events.append((i, fc.events))
        if fc.pyro_drogue or fc.pyro_main or fc.pyro_backup_drogue or fc.pyro_backup_main:
            pyro.append(i)
    return fc, events, pyro


def pad(seconds, rate=50, seed=0, alt0_mm=300000, drift_mm=0):
    """A quiet pad: barometer noise 1 m, accelerometer noise 0.3 m/s^2, slow weather drift."""
    rng = np.random.default_rng(seed)
    n = int(seconds * rate)
    dts = np.full(n, 1000000 // rate)
    alts = alt0_mm + np.linspace(0, drift_mm, n) + rng.normal(0, 1000, n)
    accs = G + rng.normal(0, 300, n)
    return dts, alts.astype(np.int64), accs.astype(np.int64), np.full(n, HAVE_BOTH)


MODES = [("both", HAVE_BOTH), ("baro", HAVE_BARO), ("accel", HAVE_ACCEL)]


def _modes_and_rules():
    for sensors, _ in MODES:
        for rule in ("velocity", "seed"):
            if sensors == "accel" and rule == "seed":
                continue
            yield sensors, rule


def assert_never_fires(dts, alts, accs, have):
    for sensors, rule in _modes_and_rules():
        fc, events, pyro = run(dts, alts, accs, have, sensors=sensors, apogee_rule=rule, **ALL_ON)
        fired = [e for _, e in events if e & FIRING]
        assert not fired and not pyro, (sensors, rule, events)
        assert fc.state in (PAD, COAST, DROGUE) or fc.state < DROGUE


@pytest.mark.slow  # 30 minutes of pad samples
def test_long_pad_with_weather_drift_never_fires():
    # 30 minutes at 20 Hz; the pressure drifts by 30 m of altitude (a front passing)
    dts, alts, accs, have = pad(1800, rate=20, seed=1, drift_mm=30000)
    assert_never_fires(dts, alts, accs, have)
    fc, _, _ = run(dts, alts, accs, have)
    assert abs(fc.ground_alt_mm - (300000 + 30000)) < 1500  # ground reference follows the weather


@pytest.mark.parametrize("knock_g", [5, 10, 20])
def test_knocks_never_fire(knock_g):
    dts, alts, accs, have = pad(120, seed=2)
    for start in range(500, len(dts) - 100, 400):  # a 50 ms knock every 8 s, with a pressure blip
        accs[start:start + 3] += knock_g * G
        alts[start:start + 2] += 20000
    assert_never_fires(dts, alts, accs, have)


@pytest.mark.parametrize("step_pa", [-2000, 2000])
def test_pressure_steps_never_fire(step_pa):
    dts, alts, accs, have = pad(120, seed=3)
    step_mm = -step_pa * 84  # ~8.4 m per hPa near sea level
    alts[3000:] += step_mm
    alts[4500:4600] -= step_mm  # and a transient back
    assert_never_fires(dts, alts, accs, have)


def test_knock_with_pressure_step_never_fires():
    # the AltOS failure: a knock on the pad plus a pressure transient gave "apogee" at 47 m
    dts, alts, accs, have = pad(120, seed=4)
    accs[2000:2008] += 15 * G  # 160 ms of 15 g: long enough to count as a boost
    alts[2000:] += 60000  # and the barometer jumps 60 m and stays
    alts[2200:] -= 0
    accs[2010:] = 0  # then the board lies on its side: the axis reads 0 g, like free fall
    assert_never_fires(dts, alts, accs, have)


def test_stuck_and_garbage_sensors_never_fire():
    dts, alts, accs, have = pad(60, seed=5)
    stuck_accs = accs.copy()
    stuck_accs[1000:] = accs[1000]  # frozen at its last reading
    assert_never_fires(dts, alts, stuck_accs, have)
    stuck_accs[1000:] = 6 * G  # stuck at 6 g: looks like a sustained boost; the barometer vetoes it
    for sensors in ("both", "baro"):
        _, events, pyro = run(dts, alts, stuck_accs, have, sensors=sensors, **ALL_ON)
        assert not pyro and not [e for _, e in events if e & FIRING]
    stuck_alts = alts.copy()
    stuck_alts[1000:] = alts[1000]
    assert_never_fires(dts, stuck_alts, accs, have)
    rng = np.random.default_rng(6)
    garbage_alts = rng.integers(-1000000, 9000000, len(dts))
    garbage_accs = rng.integers(-200 * G, 200 * G, len(dts))
    assert_never_fires(dts, garbage_alts, garbage_accs, have)
    dropout = have.copy()
    dropout[1000:2000] = 0  # no readings at all for 20 s
    assert_never_fires(dts, alts, accs, dropout)


def test_handling_and_carrying_up_a_hill_never_fire():
    dts, alts, accs, have = pad(300, seed=7)
    alts += np.linspace(0, 40000, len(dts)).astype(np.int64)  # walked 40 m uphill in 5 minutes
    rng = np.random.default_rng(8)
    accs += (rng.normal(0, 0.5 * G, len(dts))).astype(np.int64)  # walking bumps
    accs[5000:5025] += G // 2  # lifted onto the rail: 0.5 g for 0.5 s
    assert_never_fires(dts, alts, accs, have)


@pytest.mark.parametrize("rest_g", [-1, 0, 2])
def test_board_not_upright_or_wrong_range_refuses_launch(rest_g):
    # upside down (-1 g), lying (0 g), or a wrong range setting (2 g at rest): a whole flight
    # follows 2 s of pad; the board never launches, never fires
    # (the check judges readings on the pad: it flags the board within its first 2 s)
    dts, alts, accs, truth, _ = _flight(rate=50, seed=3)
    accs = accs + (rest_g - 1) * G
    fc, events, pyro = run(dts[:100], alts[:100], accs[:100], np.full(100, HAVE_BOTH))
    assert fc.errors & ERR_ORIENTATION
    fc, events, pyro = run(dts, alts, accs, np.full(len(dts), HAVE_BOTH))
    assert not pyro and not events


def _flight(rate=100, seed=1, **kw):
    dts, alts, accs, truth, apogee = make_flight(rate_hz=rate, seed=seed, **kw)
    accs = np.array(accs) + G  # make_flight gives kinematic acceleration; the board reads specific force
    return np.array(dts), np.array(alts), accs, np.array(truth), apogee


@pytest.mark.parametrize("sensors,rule", list(_modes_and_rules()))
def test_synthetic_flight_drogue_at_apogee_main_at_altitude(sensors, rule):
    have = dict(MODES)[sensors]
    dts, alts, accs, truth, apogee = _flight(after_apogee_s=200, alt_noise_mm=800, acc_noise_mmps2=200)
    # an accelerometer-only board mounted on axis: a 5 degree, 0.2 m/s^2 error budget
    budget = {"accel_tilt_max_deg": 5, "accel_bias_max_mps2": 0.2} if sensors == "accel" else {}
    fc, events, pyro = run(dts, alts, accs, np.full(len(dts), have), sensors=sensors, apogee_rule=rule,
                           **budget)
    by_bit = {}
    for i, e in events:
        for bit in (EV_LAUNCH, EV_APOGEE, EV_DROGUE, EV_MAIN, EV_LANDED):
            if e & bit:
                by_bit.setdefault(bit, i)
    launch_i = 200  # make_flight: 2 s pad at 100 Hz
    # the accelerometer sees the boost in 0.1 s; the barometer alone needs the proof climb (30 m)
    assert launch_i <= by_bit[EV_LAUNCH] <= launch_i + (100 if sensors == "baro" else 20)
    if sensors == "accel":
        # accelerometer only: apogee when the highest velocity its error budget allows reaches 0
        # (docs/DESIGN.md, "Sensor arbitration"): never early, late by at most margin / g
        late_budget = fc.arb.margin_mmps * 100 // G + 10  # samples at 100 Hz
        assert 0 <= by_bit[EV_DROGUE] - apogee <= late_budget, (by_bit[EV_DROGUE], apogee, late_budget)
    else:
        assert abs(by_bit[EV_DROGUE] - apogee) <= 30, (by_bit[EV_DROGUE], apogee)  # 0.3 s
    if sensors != "accel":
        main_truth_mm = truth[by_bit[EV_MAIN]] - 300000
        assert abs(main_truth_mm - 250000) <= 10000  # within 10 m of the configured altitude
        assert by_bit.get(EV_LANDED) is None or fc.state == LANDED
    assert min(pyro) >= by_bit[EV_DROGUE]  # nothing is on before the drogue decision


def test_pulses_are_exactly_the_configured_length_and_fire_once():
    dts, alts, accs, truth, apogee = _flight(after_apogee_s=200)
    fc = FlightComputer(load_config({"pulse_ms": 300}))
    drogue_on, main_on = [], []
    for i in range(len(dts)):
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), HAVE_BOTH)
        if fc.pyro_drogue:
            drogue_on.append(i)
        if fc.pyro_main:
            main_on.append(i)
    for on in (drogue_on, main_on):
        assert len(on) == 30 and on == list(range(on[0], on[0] + 30))  # 300 ms at 100 Hz, once
    assert main_on[0] - drogue_on[0] >= 200  # main guard (2 s default)


@pytest.mark.parametrize("rule", ["velocity", "seed"])
def test_apogee_delay_and_no_fire_through_mach(rule):
    # 100 g for 3.5 s: 3.4 km/s is beyond the Mach lockout; the barometer lies by a transonic
    # error (the seed rule's "altitude fell twice" sees it); no apogee while fast, drogue 2 s
    # after apogee
    # (an accelerometer with noise: a reading held identical above 1 g is a frozen part, and the
    # barometer alone would then decide)
    dts, alts, accs, truth, apogee = _flight(boost_mmps2=90000, burn_ms=4000, after_apogee_s=5,
                                             ground_mm=0, alt_noise_mm=1000, acc_noise_mmps2=200)
    speed = np.concatenate([[0], np.diff(truth) * 100 / 1000])  # m/s
    transonic = (speed > 300) & (speed < 420)
    alts = alts - (transonic * 150000).astype(np.int64)  # 150 m low while transonic
    fc = FlightComputer(load_config({"apogee_delay_s": 2, "apogee_rule": rule}))
    fast_seen = False
    for i in range(len(dts)):
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), HAVE_BOTH)
        fast_seen |= fc.state == FAST
        if fc.events & EV_APOGEE:
            assert abs(i - apogee) <= 40 and speed[i] < 50
        if fc.events & EV_DROGUE:
            assert abs(i - apogee - 200) <= 40
    assert fast_seen and fc.drogue_fired_ms > 0


def test_accelerometer_glitch_in_coast_does_not_fire_early():
    dts, alts, accs, truth, apogee = _flight(after_apogee_s=5)
    burnout = 200 + 200
    accs[burnout + 300:burnout + 305] = -50 * G  # a shock: -50 g for 50 ms
    accs[burnout + 600:burnout + 602] = 80 * G
    fc, events, pyro = run(dts, alts, accs, np.full(len(dts), HAVE_BOTH))
    drogue = [i for i, e in events if e & EV_DROGUE]
    assert drogue and abs(drogue[0] - apogee) <= 30


def test_barometer_dies_in_coast_backup_timer_fires():
    dts, alts, accs, truth, apogee = _flight(after_apogee_s=20)
    have = np.full(len(dts), HAVE_BOTH)
    have[600:] = HAVE_ACCEL  # barometer dead 2 s after burnout
    fc, events, pyro = run(dts, alts, accs, have, backup_drogue_s=26)
    drogue = [i for i, e in events if e & EV_DROGUE]
    launch = [i for i, e in events if e & EV_LAUNCH][0]
    assert drogue and drogue[0] >= apogee  # never early: accelerometer-only apogee or the timer
    assert drogue[0] <= launch + 2600 + 1


@pytest.mark.parametrize("reset_at", [300, 1500, 2300, 2440, 3000])  # boost .. descent
def test_resume_after_reset_in_flight(reset_at):
    from shared.flight import STATE_RECORD_SIZE

    dts, alts, accs, truth, apogee = _flight(after_apogee_s=200)
    fc = FlightComputer(load_config())
    record = bytearray(STATE_RECORD_SIZE)
    fired = {"drogue": [], "main": []}
    outage = range(reset_at, reset_at + 100)  # a brown-out: 1 s without the board
    for i in range(len(dts)):
        if i in outage:
            continue
        if i == outage.stop:  # a new FlightComputer resumes from the saved record
            fc = FlightComputer(load_config())
            assert fc.restore_state(record)
        fc.step(int(dts[i]), int(alts[i]), int(accs[i]), HAVE_BOTH)
        if fc.events or (fc.state > PAD and i % 10 == 0):  # the device's saving policy
            fc.save_state(record)
        if fc.events & EV_DROGUE:
            fired["drogue"].append(i)
        if fc.events & EV_MAIN:
            fired["main"].append(i)
    assert len(fired["drogue"]) == 1 and len(fired["main"]) == 1  # once each, never again
    if reset_at + 100 < apogee - 100:  # back well before apogee: on time
        assert abs(fired["drogue"][0] - apogee) <= 30
    elif reset_at < apogee:  # back near apogee: late by at most the outage and the settling
        assert apogee - 30 <= fired["drogue"][0] <= apogee + 200
    assert abs(truth[fired["main"][0]] - 300000 - 250000) <= 10000


def test_restore_rejects_a_blank_or_pad_record():
    from shared.flight import STATE_RECORD_SIZE

    fc = FlightComputer(load_config())
    assert not fc.restore_state(bytearray(STATE_RECORD_SIZE))
    fresh = FlightComputer(load_config())
    record = bytearray(STATE_RECORD_SIZE)
    fresh.save_state(record)  # still on the pad: nothing to resume, the board calibrates anew
    assert not fc.restore_state(record) and fc.state == PAD


def test_false_launch_returns_to_pad_and_a_real_flight_still_flies():
    from shared.flight import BOOST, ERR_FALSE_LAUNCH

    dts, alts, accs, _ = pad(40, seed=11)
    accs[500:520] += 3 * G  # a 0.4 s push of 3 g on the rail: counts as a boost, nothing climbs
    dts2, alts2, accs2, truth, apogee = _flight(rate=50, seed=12, after_apogee_s=60)
    alts2 = alts2 - alts2[0] + alts[-1]
    fc = FlightComputer(load_config({"backup_drogue_s": 40}))  # timed from the real launch
    states, drogue = [], None
    for arrays in ((dts, alts, accs), (dts2, alts2, accs2)):
        for i in range(len(arrays[0])):
            fc.step(int(arrays[0][i]), int(arrays[1][i]), int(arrays[2][i]), HAVE_BOTH)
            states.append(fc.state)
            if fc.events & EV_DROGUE and arrays[0] is dts2:
                drogue = i
    assert BOOST in states[:len(dts)] and states[len(dts) - 1] == PAD and fc.errors & ERR_FALSE_LAUNCH
    assert drogue is not None and abs(drogue - apogee) <= 15  # 0.3 s at 50 Hz


@pytest.mark.parametrize("first", [HAVE_ACCEL, HAVE_BARO])
def test_pad_calibration_with_the_sensors_on_alternate_samples(first):
    # barometer and accelerometer on alternate samples, either one first: the ground reference is
    # the barometer's average and the 1 g reference the accelerometer's, neither diluted by the
    # samples without a reading, and the first reading is no "pressure step"
    dts, alts, accs, _ = pad(6, rate=100, seed=3)
    accs = accs + 400  # an accelerometer reading 0.4 m/s^2 high on the pad
    other = HAVE_BARO if first == HAVE_ACCEL else HAVE_ACCEL
    have = np.where(np.arange(len(dts)) % 2 == 0, first, other)
    fc, events, pyro = run(dts, np.where(have == HAVE_BARO, alts, 0), np.where(have == HAVE_ACCEL, accs, 0),
                           have, **ALL_ON)
    assert fc.errors == 0 and not events and not pyro
    assert abs(fc.ground_alt_mm - 300000) <= 300  # 1 m noise averaged over a block
    assert abs(fc.one_g_mmps2 - (G + 400)) <= 60


def test_boost_time_counts_the_accelerometer_intervals():
    # a 0.1 s boost threshold: readings every 20 ms on alternate 10 ms samples launch at the same
    # time as readings every 20 ms on 20 ms samples (5 boosting readings), not at 10 of them
    def launch_time_ms(step_ms, every):
        dts, alts, accs, _ = pad(3, rate=1000 // step_ms, seed=1)
        n_boost = int(0.3 * 1000 / step_ms)
        dts = np.concatenate([dts, np.full(n_boost, step_ms * 1000)])
        alts = np.concatenate([alts, np.full(n_boost, alts[-1])])
        accs = np.concatenate([accs, np.full(n_boost, G + 60000)])
        have = np.full(len(dts), HAVE_BOTH)
        if every == 2:
            have = np.where(np.arange(len(dts)) % 2 == 0, HAVE_BARO, HAVE_ACCEL)
        _, events, _ = run(dts, alts, accs, have, **ALL_ON)
        i = next(i for i, e in events if e & EV_LAUNCH)
        return int(np.sum(dts[1:i + 1]) // 1000) - 3000
    merged = launch_time_ms(20, 1)
    assert merged == 80  # the 5th reading of the boost: 4 intervals + the first one's
    assert abs(launch_time_ms(10, 2) - merged) <= 10


def test_no_main_single_deployment_lands_under_the_drogue():
    # main_deploy_m = 0: a rocket with one parachute; the main never fires, landing is detected
    dts, alts, accs, truth, apogee = _flight(after_apogee_s=200, alt_noise_mm=800, acc_noise_mmps2=200)
    ground = apogee + int(np.argmax(truth[apogee:] <= truth[0]))  # make_flight falls on through it
    rest = np.random.default_rng(2).normal(0, 800, 2000).astype(np.int64)  # 20 s on the ground
    dts = np.concatenate([dts[:ground], np.full(2000, dts[1])])
    alts = np.concatenate([alts[:ground], truth[0] + rest])
    accs = np.concatenate([accs[:ground], np.full(2000, G)])
    fc, events, pyro = run(dts, alts, accs, np.full(len(dts), HAVE_BOTH), main_deploy_m=0)
    bits = 0
    for _, e in events:
        bits |= e
    assert bits & EV_DROGUE and not bits & EV_MAIN and not fc.pyro_main
    assert fc.main_fired_ms < 0
    assert bits & EV_LANDED and fc.state == LANDED


def test_accelerometer_integrals_count_its_own_intervals():
    # the accelerometer's account of the boost (proof of flight) from readings on alternate 10 ms
    # samples equals the one from readings on every 20 ms sample: each reading stands for its own
    # 20 ms interval, not for the 10 ms since the barometer's sample before it
    boost_mmps2 = 5 * G  # 0.4 s of 5 g kinematic: 19.6 m/s, 3.9 m
    def integrals(step_ms, every):
        dts, alts, accs, _ = pad(3, rate=1000 // step_ms, seed=1)
        n_boost = 400 // step_ms
        dts = np.concatenate([dts, np.full(n_boost, step_ms * 1000)])
        alts = np.concatenate([alts, np.full(n_boost, alts[-1])])
        accs = np.concatenate([accs, np.full(n_boost, G + boost_mmps2)])
        have = np.full(len(dts), HAVE_BOTH)
        if every == 2:
            have = np.where(np.arange(len(dts)) % 2 == 0, HAVE_BARO, HAVE_ACCEL)
        fc, _, _ = run(dts, alts, accs, have)
        return fc.acc_dv_mmps, fc.acc_h_mm
    dv, h = integrals(20, 1)
    assert abs(dv - boost_mmps2 * 0.4) <= boost_mmps2 * 0.02  # within one reading's 20 ms
    dv2, h2 = integrals(10, 2)
    assert abs(dv2 - dv) <= boost_mmps2 * 0.02 and abs(h2 - h) <= 500


def test_per_sample_objects_have_no_special_accessors():
    # a class with a property, a descriptor or __setattr__ makes MicroPython look every store to
    # its instances' attributes up in the class first (py/objtype.c): three convenience properties
    # on FlightComputer cost its step 23k of 139k instructions on a Cortex-M0 (shared/attrs.py)
    fc = FlightComputer(load_config())
    for obj in (fc, fc.cfg, fc.det, fc.kf, fc.health, fc.arb, fc.pad, fc.det.rule):
        for cls in type(obj).__mro__[:-1]:
            for name, value in vars(cls).items():
                assert name not in ("__setattr__", "__delattr__"), (cls, name)
                if name in ("__dict__", "__weakref__"):
                    continue  # CPython's own (MicroPython has neither)
                assert not isinstance(value, property), (cls, name)
                assert not hasattr(type(value), "__set__") and not hasattr(type(value), "__delete__"), (
                    cls, name)
