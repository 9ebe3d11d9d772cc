"""The seed study's comparison detectors (desktop/study/baselines.py)."""

import numpy as np
import pytest

from desktop.sim import seed_model as sm
from desktop.study import baselines as bl

# Design note 7: the seed's gain recursion at T = 0.05, computed with numpy from its listing.
K_FIXTURE = np.array([
    [0.0329735204, 1.4504801e-06],
    [0.0193120142, 5.98274301e-05],
    [4.86e-11, 0.998802871],
])


def test_seed_gain_recursion_reproduces_fixture():
    K = bl.seed_kalman_gain()
    np.testing.assert_allclose(K, K_FIXTURE, rtol=0, atol=1e-9)


@pytest.fixture(scope="module")
def flights():
    return sm.simulate_monte_carlo(6, seed=21, pad_s=1.0)


def _perturb_after(x, k, rng):
    y = x.copy()
    y[:, k + 1:] += rng.normal(0, 50, size=y[:, k + 1:].shape)
    return y


def test_filters_are_causal(flights):
    rng = np.random.default_rng(0)
    alt = flights.altitude_m
    acc = flights.accel_mps2 - 9.81
    fs = 1 / bl.sample_period_s(flights.time_s)
    filters = {
        "boxcar": lambda a, c: bl.boxcar(a),
        "boxcar3": lambda a, c: bl.boxcar(a, 3),
        "butterworth": lambda a, c: bl.butterworth(a, fs),
        "elliptic": lambda a, c: bl.elliptic(a, fs),
        "kalman_s": lambda a, c: bl.seed_kalman(a, c)[0],
        "kalman_v": lambda a, c: bl.seed_kalman(a, c)[1],
    }
    for k in (0, 1, 37, 120, alt.shape[1] - 2):
        alt2, acc2 = _perturb_after(alt, k, rng), _perturb_after(acc, k, rng)
        for name, f in filters.items():
            y1, y2 = f(alt, acc), f(alt2, acc2)
            np.testing.assert_array_equal(y1[:, : k + 1], y2[:, : k + 1], err_msg=f"{name} at {k}")
            assert not np.array_equal(y1[:, k + 1:], y2[:, k + 1:]), name


def test_methods_are_causal(flights):
    """A detection at sample k is unchanged when every later sample is replaced."""
    rng = np.random.default_rng(1)
    t = flights.time_s
    for name, method in bl.METHODS.items():
        d = method(t, flights.altitude_m, flights.accel_mps2)
        assert d.shape == (flights.n_flights,)
        assert np.isfinite(d).all(), name
        k = np.searchsorted(t, d)
        alt, acc = flights.altitude_m.copy(), flights.accel_mps2.copy()
        for r in range(flights.n_flights):
            alt[r, k[r] + 1:] = rng.normal(0, 100, alt.shape[1] - k[r] - 1)
            acc[r, k[r] + 1:] = rng.normal(0, 100, acc.shape[1] - k[r] - 1)
        np.testing.assert_array_equal(method(t, alt, acc), d, err_msg=name)


def test_filters_keep_a_constant_and_boxcar_lags_half_its_window():
    x = np.full((2, 50), 7.0)
    np.testing.assert_allclose(bl.boxcar(x), 7.0)
    np.testing.assert_allclose(bl.butterworth(x, 20.0), 7.0)
    # even-order elliptic: -1 dB at DC, the seed's attenuated output
    np.testing.assert_allclose(bl.elliptic(x, 20.0), 7.0 * 10 ** (-1 / 20))
    ramp = np.arange(100.0)[None, :]
    y = bl.boxcar(ramp, 40)
    np.testing.assert_allclose(y[0, 60:], ramp[0, 60:] - 19.5)      # lag (W - 1) / 2 samples
    assert bl.BOXCAR_WINDOW == 40


def test_seed_kalman_tracks_a_clean_parabola():
    T = 0.05
    t = np.arange(1000) * T     # the filter's slowest mode is 0.983 per sample
    alt = 100 + 50 * t - 9.81 / 2 * t**2
    acc = np.full_like(t, -9.81)
    s, v, a = bl.seed_kalman(alt[None], acc[None])
    assert s[0, 0] == 100 and v[0, 0] == 0 and a[0, 0] == -9.81        # [alt(1); 0; accel(1)]
    np.testing.assert_allclose(s[0, -50:], alt[-50:], atol=1e-3)
    np.testing.assert_allclose(v[0, -50:], 50 - 9.81 * t[-50:], atol=1e-3)


def test_seed_rule_on_hand_made_sequences():
    t = np.arange(8) * 0.5
    armed = np.ones((1, 8), dtype=bool)

    def det(x, armed=armed):
        return bl.detect_seed_rule(t, np.array([x], dtype=float), armed)[0]

    assert det([0, 1, 2, 3, 2, 1, 0, -1]) == t[5]            # 1 < 2 < 3
    assert det([0, 1, 2, 3, 3, 2, 1, 0]) == t[6]             # equal values are not a fall
    assert np.isnan(det([0, 1, 0, 1, 0, 1, 0, 1]))           # single falls only
    assert det([5, 4, 3, 2, 1, 0, -1, -2]) == t[2]            # falls from the start (why a lockout)
    late = np.zeros((1, 8), dtype=bool)
    late[0, 4:] = True
    assert det([5, 4, 3, 2, 1, 0, -1, -2], late) == t[4]
    assert np.isnan(det([5, 4, 3, 2, 1, 0, -1, -2], np.zeros((1, 8), dtype=bool)))


def test_velocity_rule_on_hand_made_sequences():
    t = np.arange(6) * 0.1
    armed = np.ones((1, 6), dtype=bool)
    v = np.array([[3.0, 2.0, 0.0, 0.0, -0.1, -1.0]])
    assert bl.detect_velocity_rule(t, v, armed)[0] == t[4]    # strictly below zero
    x = np.array([[0.0, 1.0, 2.0, 2.0, 1.5, 1.0]])
    assert bl.detect_velocity_rule(t, bl.first_difference(x), armed)[0] == t[4]
    assert np.isnan(bl.detect_velocity_rule(t, np.abs(v), armed)[0])


def test_lockout_after_launch():
    t = np.arange(60) * 0.1
    acc = np.full((2, 60), 9.81)
    acc[0, 5:10] = 100.0                      # launch at 0.5 s
    mask = bl.armed_mask(t, acc, lockout_s=1.0)
    assert not mask[0, :15].any() and mask[0, 15:].all()
    assert not mask[1].any()                  # never launched: never armed
    np.testing.assert_array_equal(bl.launch_times(t, acc), [0.5, np.nan])
    # the pad never reaches the threshold (it reads 9.81 or 6.81)
    fl = sm.simulate_monte_carlo(20, seed=2, pad_s=2.0)
    np.testing.assert_allclose(bl.launch_times(fl.time_s, fl.accel_mps2), fl.ignition_time_s + fl.time_s[1])


def test_seed_kalman_equals_the_matrix_form_flight_by_flight():
    """x = A x; x = x + K (z - H x), written with matrices, for several flights at once."""
    rng = np.random.default_rng(3)
    T = 0.05
    alt = np.cumsum(rng.normal(5.0, 3.0, size=(3, 80)), axis=1)
    acc = rng.normal(-9.0, 2.0, size=(3, 80))
    K = bl.seed_kalman_gain(T)
    A = bl.seed_transition(T)
    H = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    s, v, a = bl.seed_kalman(alt, acc, T=T, K=K)
    for i in range(3):
        x = np.array([alt[i, 0], 0.0, acc[i, 0]])
        for k in range(1, 80):
            x = A @ x
            x = x + K @ (np.array([alt[i, k], acc[i, k]]) - H @ x)
            np.testing.assert_allclose([s[i, k], v[i, k], a[i, k]], x, rtol=1e-12, atol=1e-9)

