"""The integer filter, its driver and the decision rules, on CPython, against independent
expectations: exact arithmetic, a float64 reference, and analytic flights."""

import random

import numpy as np
import pytest

from shared import gains_table
from shared.apogee import SeedRule, VelocityRule
from shared.detector import HAVE_ACCEL, HAVE_BARO, HAVE_BOTH, Detector
from shared.kalman import _SMALL_INNOV, ALT_LIMIT_Q4, RATE_LIMIT_Q4, Kalman, _add, _add2, _mul_gain
from tests.support.float_kalman import run_float
from tools.bench_step import run_flight
from tools.synthetic_flight import make_flight

SMALL_INT = 2**30


def test_mul_gain_is_the_rounded_product_and_stays_in_31_bits():
    rng = random.Random(3)
    cases = [(2**28 - 1, 2**14 - 1, 28), (-(2**28) + 1, 2**14 - 1, 28), (2**28 - 1, -(2**14) + 1, 14)]
    cases += [(rng.randrange(-(2**28) + 1, 2**28), rng.randrange(-(2**14) + 1, 2**14), rng.randrange(14, 29))
              for _ in range(20000)]
    for e, m, s in cases:
        assert _mul_gain(e, m, s) == (e * m + (1 << (s - 1))) >> s  # exact round half up
        # every intermediate, as computed inside _mul_gain
        p = (e >> 14) * m
        low = (e & 0x3FFF) * m + (1 << (s - 1))
        total = p + (low >> 14)
        assert abs(p) < SMALL_INT and abs(low) < SMALL_INT and abs(total) < SMALL_INT


@pytest.mark.parametrize("e", [0, 1, -1, 777, -777, _SMALL_INNOV - 1, -_SMALL_INNOV + 1, _SMALL_INNOV,
                               -_SMALL_INNOV, 2**27 - 1, -(2**27) + 1])
def test_corrections_take_the_rounded_products_of_every_gain(e):
    # small innovations take the product unsplit (shared/kalman.py, _SMALL_INNOV), the rest split:
    # both exactly _mul_gain's, for every gain of every table, its intermediates inside 31 bits
    other = 5000 if abs(e) < _SMALL_INNOV else -(2**20)
    # an unsplit product and its rounding, |m| < 2**14 and s <= 28 (tools/gen_gains.py)
    assert (_SMALL_INNOV - 1) * (2**14 - 1) + 2**27 < SMALL_INT
    for row in gains_table.PROJECT + gains_table.PROJECT_LOW_NOISE:
        for i in (1, 25, 41):
            kf = Kalman()
            _add2(kf, e, other, row, row, i)
            assert (kf.alt_q4, kf.vel_q4, kf.acc_q4) == tuple(
                _mul_gain(e, row[i + k], row[i + k + 1]) + _mul_gain(other, row[i + k + 2], row[i + k + 3])
                for k in (0, 4, 8))
        for i, stride in ((13, 2), (19, 2), (1, 4), (3, 4)):
            kf = Kalman()
            _add(kf, e, row, i, stride)
            assert (kf.alt_q4, kf.vel_q4, kf.acc_q4) == tuple(
                _mul_gain(e, row[i + k * stride], row[i + k * stride + 1]) for k in (0, 1, 2))


@pytest.mark.parametrize("dt_us,prev_hz,rate,steps", [
    (10000, 100, 100, 1), (10400, 100, 100, 1), (9600, 100, 100, 1), (20000, 100, 50, 1),
    (50000, 20, 20, 1), (47000, 20, 20, 1), (100000, 100, 10, 1), (5000, 100, 200, 1),
    (60000, 100, 100, 6), (120000, 100, 100, 12), (130000, 100, 100, 13), (1000000, 10, 10, 10),
    (150000, 20, 20, 3),
    # sooner than a period: whole periods of the fastest rate, the rest carried (1 ms: none yet)
    (1000, 100, 100, 0), (8000, 100, 100, 2),
])
def test_period_selection_steps_across_gaps_at_the_rate_in_use(dt_us, prev_hz, rate, steps):
    det = Detector(gains_table.PROJECT, VelocityRule())
    det.start(0, 0)
    det.step(1000000 // prev_hz, 0, 0, HAVE_BOTH, False)
    assert det.row[0] == prev_hz
    det.step(dt_us, 0, 0, HAVE_BOTH, False)
    assert (det.row[0], det.predict_steps) == (rate, steps)


@pytest.mark.parametrize("table_name", ["PROJECT", "SEED"])
def test_a_row_is_kept_exactly_while_the_period_selects_it(table_name):
    # the step skips the table search while a jittered period stays in the selected row's
    # window: every period selects, by that search, the row whose window holds it, and regular
    # exactly when one does (every window end and its neighbours, and a spread of periods)
    det = Detector(getattr(gains_table, table_name), VelocityRule())
    windows = list(zip(det.table, det.row_lo_us, det.row_hi_us, strict=True))
    edges = [x + d for _, lo, hi in windows for x in (lo, hi) for d in (-1, 0, 1)]
    for dt_us in edges + list(range(1, 130000, 97)):
        det.forget_period()
        det.row = None
        det._set_period(dt_us)
        holding = [row for row, lo, hi in windows if lo <= dt_us <= hi]
        assert det.regular == bool(holding), dt_us
        if holding:
            assert holding == [det.row], dt_us
            assert det.period_lo_us <= dt_us <= det.period_hi_us


def test_predict_is_exact_constant_acceleration_kinematics():
    kf = Kalman()
    kf.reset(1000, 50000, -9807)  # 1 m, 50 m/s, -g
    row = next(r for r in gains_table.PROJECT if r[0] == 100)
    for _ in range(100):
        kf.predict(row)
    # after 1 s: h = 1 + 50 - 9.807/2 m, v = 50 - 9.807 m/s (rounding: < 1 mm, < 1 mm/s)
    assert kf.alt_q4 / 16 == pytest.approx(1000 + 50000 - 9807 / 2, abs=1.0)
    assert kf.vel_q4 / 16 == pytest.approx(50000 - 9807, abs=1.0)


@pytest.mark.parametrize("table_name,rate", [("project", 100), ("project", 20), ("seed", 20)])
def test_integer_filter_matches_float64_reference(table_name, rate):
    table = gains_table.SEED if table_name == "seed" else gains_table.PROJECT
    dts, alts, accs, _, _ = make_flight(rate_hz=rate, seed=7)
    _, states = run_flight(table_name, "velocity", (dts, alts, accs), len(dts), False)
    got = np.array(states, dtype=float).reshape(-1, 3)[1:] / 16
    ref = run_float(table, dts, alts, accs)[1:]
    err = np.abs(got - ref).max(axis=0)
    # Tolerance: every product and prediction is rounded to the nearest 1/16 mm unit, so errors
    # are unbiased, +-1/32 mm per operation; the slowest loop (velocity from altitude,
    # K ~ 0.003 per sample at 100 Hz) sums them over ~1/K samples like a random walk. Measured
    # about 1 mm, 1 mm/s; asserted: 3 mm, 5 mm/s, 5 mm/s^2, far below the sensors' resolution.
    assert err[0] < 3 and err[1] < 5 and err[2] < 5, err


def test_filter_tracks_noiseless_analytic_flight():
    dts, alts, accs, truth, apogee = make_flight(alt_noise_mm=0, acc_noise_mmps2=0)
    det = Detector(gains_table.PROJECT, VelocityRule())
    det.start(alts[0], accs[0])
    fired = None
    err_m = []
    for i in range(1, len(dts)):
        if det.step(dts[i], alts[i], accs[i], HAVE_BOTH, i > 500) and fired is None:
            fired = i
        err_m.append(abs(det.kf.alt_q4 / 16 - truth[i]) / 1000)
    # lags by ~2 m at the 10 g steps of ignition and burnout (sigma_accel = 2 m/s^2), then
    # converges: exact to the centimetre around apogee, and fires on the apogee sample
    assert max(err_m) < 3.0
    assert max(err_m[apogee - 200:apogee + 200]) < 0.01
    assert abs(fired - apogee) <= 1


@pytest.mark.parametrize("rule", [SeedRule, VelocityRule])
def test_rules_never_fire_while_locked_out(rule):
    dts, alts, accs, _, _ = make_flight(seed=2)
    det = Detector(gains_table.PROJECT, rule())
    det.start(alts[0], accs[0])
    assert not any(det.step(dts[i], alts[i], accs[i], HAVE_BOTH, False) for i in range(1, len(dts)))


@pytest.mark.parametrize("rule", [SeedRule, VelocityRule])
def test_rule_fires_once_near_apogee(rule):
    dts, alts, accs, _, apogee = make_flight(seed=4)
    det = Detector(gains_table.PROJECT, rule())
    det.start(alts[0], accs[0])
    fired = [i for i in range(1, len(dts)) if det.step(dts[i], alts[i], accs[i], HAVE_BOTH, i > 600)]
    assert len(fired) == 1
    assert abs(fired[0] - apogee) <= 30  # 0.3 s at 100 Hz with 1.5 m baro noise


class _State:
    def __init__(self, alt_q4, vel_q4, acc_q4):
        self.alt_q4, self.vel_q4, self.acc_q4 = alt_q4, vel_q4, acc_q4


def test_seed_rule_needs_two_consecutive_falls():
    rule = SeedRule()
    seq = [0, 5, 10, 9, 11, 10, 9]
    fired = [rule.update(_State(h, 0, 0), 20, True) for h in seq]
    assert fired == [False] * 6 + [True]


def test_velocity_rule_fires_within_half_a_period_of_the_crossing():
    # a = -g; at 20 Hz half a period of deceleration is 9.807 * 0.025 = 0.245 m/s
    g_q4 = 9807 * 16
    assert not VelocityRule().update(_State(0, 300 * 16, -g_q4), 20, True)
    assert VelocityRule().update(_State(0, 200 * 16, -g_q4), 20, True)
    assert VelocityRule().update(_State(0, 0, -g_q4), 20, True)
    assert not VelocityRule().update(_State(0, 200 * 16, -g_q4), 20, False)


def test_dropout_is_predicted_across_and_single_sensor_samples_correct():
    det = Detector(gains_table.PROJECT, VelocityRule())
    det.start(0, 0)
    det.step(10000, 0, 0, HAVE_BOTH, False)  # establishes 100 Hz
    det.kf.reset(0, 100000, 0)  # 100 m/s
    det.step(10000 * 6, 0, 0, 0, False)  # 60 ms gap, no reading: prediction only
    assert det.predict_steps == 6 and det.row[0] == 100
    assert det.kf.alt_q4 == 6000 * 16  # 100 m/s for 60 ms exactly, no correction
    det.step(10000, 6000, 0, HAVE_BARO, False)
    assert 6000 * 16 < det.kf.alt_q4 < 7000 * 16  # predicted 7 m, measured 6 m: pulled part way
    det.step(10000, 0, 0, HAVE_ACCEL, False)
    assert det.predict_steps == 1 and det.row[0] == 100


def test_state_is_clamped_under_absurd_inputs():
    det = Detector(gains_table.PROJECT, VelocityRule())
    det.start(0, 0)
    for i in range(2000):
        big = (1 << 40) if i % 2 else -(1 << 40)
        det.step(10000, big, big, HAVE_BOTH, True)
        kf = det.kf
        assert abs(kf.alt_q4) <= ALT_LIMIT_Q4
        assert abs(kf.vel_q4) <= RATE_LIMIT_Q4 and abs(kf.acc_q4) <= RATE_LIMIT_Q4


def test_samples_sooner_than_a_period_keep_the_filter_on_time():
    # each sensor read in turn, 2 ms apart, every 10 ms: the samples come 2 ms and 8 ms apart.
    # The filter predicts whole 5 ms steps and carries the rest: after 100 ms it has predicted
    # 100 ms (within half a step), not one 10 ms period per sample (200 ms)
    det = Detector(gains_table.PROJECT, VelocityRule())
    det.start(0, 0)
    det.step(10000, 0, 0, HAVE_BOTH, False)
    det.kf.reset(0, 100000, 0)  # 100 m/s, no reading after
    for i in range(20):
        det.step(2000 if i % 2 == 0 else 8000, 0, 0, 0, False)
    assert abs(det.kf.alt_q4 / 16 - 10000) <= 250  # 100 m/s x 100 ms = 10 m, +-2.5 ms


def test_readings_on_alternate_samples_correct_like_samples_with_both():
    # the barometer and the accelerometer on alternate 10 ms samples against both every 20 ms
    # (the accelerometer reading moved 10 ms earlier): each reading takes its column of the 50 Hz
    # gains, so the two filters agree near apogee (they differ by up to 2 m in the boost, where
    # 10 ms of a 10 g acceleration is 1 m/s)
    dts, alts, accs, _truth, apogee = make_flight(rate_hz=100, seed=5)
    alt_det = Detector(gains_table.PROJECT, VelocityRule())
    both_det = Detector(gains_table.PROJECT, VelocityRule())
    alt_det.start(alts[0], 0)
    both_det.start(alts[0], 0)
    diff = []
    for i in range(2, len(dts) - 1, 2):
        alt_det.step(dts[i], alts[i], 0, HAVE_BARO, False)
        alt_det.step(dts[i + 1], 0, accs[i + 1], HAVE_ACCEL, False)
        both_det.step(dts[i] + dts[i + 1], alts[i], accs[i + 1], HAVE_BOTH, False)
        if abs(i - apogee) <= 200:
            diff.append((abs(alt_det.kf.alt_q4 - both_det.kf.alt_q4) / 16000,
                         abs(alt_det.kf.vel_q4 - both_det.kf.vel_q4) / 16000))
    worst_m, worst_mps = np.max(diff, axis=0)
    assert worst_m < 0.25 and worst_mps < 0.15  # measured 0.20 m, 0.10 m/s


def _run_of_outliers(step_rate_mmps, lie_mm):
    """A filter tracking a climb at 50 m/s (both sensors, 100 Hz, 50 m gate) whose barometer
    reads ``lie_mm(t_s)`` off from 1 s on: (altitude error mm, velocity error mm/s) per sample."""
    det = Detector(gains_table.PROJECT, VelocityRule())
    det.start(0)
    det.kf.reset(0, 50000, 0)
    det.gate_alt_mm = 50000
    det.step_rate_mmps = step_rate_mmps
    errors = []
    for i in range(1, 501):
        t_s = i / 100
        true_mm = 50 * i * 10
        lie = lie_mm(t_s) if t_s >= 1.0 else 0
        det.step(10000, true_mm + lie, 0, HAVE_BOTH, False)
        errors.append(((det.kf.alt_q4 >> 4) - true_mm - lie, (det.kf.vel_q4 >> 4) - 50000))
    return errors


def test_a_steady_barometric_step_moves_the_altitude_not_the_velocity():
    # -100 m held: rejected for a second (the filter predicts meanwhile), then re-synchronised.
    # The step moves the altitude state at once; the velocity never moves by more than noise-free
    # rounding. Left to the gains (the rule off), the same step swings the velocity by tens of m/s.
    stepped = _run_of_outliers(20000, lambda t_s: -100000)
    at_resync = stepped[200]  # the 201st sample (t = 2.01 s): the first one used again
    assert abs(at_resync[0]) < 1000
    assert max(abs(v) for _, v in stepped) < 100
    absorbed = _run_of_outliers(0, lambda t_s: -100000)
    assert min(v for _, v in absorbed) < -20000


def test_a_moving_innovation_is_left_to_the_gains():
    # the barometer runs away at 60 m/s (a filter that drifted, or a lie that still moves): not a
    # step, so the re-synchronisation leaves the state to the linear filter, exactly as without
    # the rule
    def ramp(t_s):
        return -int(60000 * (t_s - 1.0)) - 50000
    assert _run_of_outliers(20000, ramp) == _run_of_outliers(0, ramp)
