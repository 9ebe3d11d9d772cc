"""The seed's chapter-4 flight model (desktop/sim/seed_model.py): truth, noise, quantisation, seeding."""

import numpy as np
import pytest

from desktop.sim import seed_model as sm


def seed_loop_truth(acc, dt=1e-3):
    """The seed's MATLAB loop, literally (state_vecs column i = state after step i; last column 0)."""
    n = len(acc)
    trans = np.array([[1.0, dt, 0.5 * dt * dt], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    prv = np.zeros((3, n))
    prv[2, :] = acc
    state = np.zeros((3, n))
    for i in range(n - 1):
        state[:, i] = trans @ prv[:, i]
        prv[0, i + 1] = state[0, i]
        prv[1, i + 1] = state[1, i]
    return state


def analytic_apogee(a_peak, t1, t2, t3, g=-9.81):
    """Apogee of the continuous profile: rise g -> a_peak over [0, t1], hold to t2, decay to g at
    t3 (end times), then free flight. Returns (burnout velocity, apogee time, apogee altitude)."""
    s = v = 0.0
    for a0, a1, dur in ((g, a_peak, t1), (a_peak, a_peak, t2 - t1), (a_peak, g, t3 - t2)):
        jerk = (a1 - a0) / dur
        s, v = s + v * dur + a0 * dur**2 / 2 + jerk * dur**3 / 6, v + a0 * dur + jerk * dur**2 / 2
    return v, t3 + v / -g, s + v * v / (2 * -g)


def test_default_flight_burnout_and_apogee():
    fl = sm.simulate_paper_flight(seed=0)
    v_bo, t_apo, h_apo = analytic_apogee(160.0, 0.05, 0.35, 0.5)
    assert v_bo == pytest.approx(63.019, abs=1e-9)
    # DESIGN.md D7: burns out at 63.0 m/s at 0.5 s, reaches 219.7 m at 6.92 s
    t = sm.seed_time_vector(15.0)
    _, v_ms, _ = sm.integrate_truth(sm.acceleration_profile(fl.params, len(t)))
    assert v_ms[0, 499] == pytest.approx(63.019, abs=1e-9)       # after the 500th step (t_g = 0.5 s)
    assert round(float(v_ms[0, 499]), 1) == 63.0
    assert round(float(fl.true_apogee_m[0]), 1) == 219.7
    assert round(float(fl.true_apogee_time_s[0]), 2) == 6.92
    assert fl.true_apogee_m[0] == pytest.approx(h_apo, abs=0.01)
    assert fl.true_apogee_time_s[0] == pytest.approx(t_apo, abs=0.002)


def test_truth_matches_the_seed_loop():
    params = sm.FlightParams.paper_default()
    acc = sm.acceleration_profile(params, 15000)
    # the profile: linspace(g, 160, 50), 160 for 300 ms, linspace(160, g, 150), then g
    assert acc[0, 0] == -9.81 and acc[0, 49] == 160.0 and acc[0, 50] == 160.0
    assert acc[0, 349] == 160.0 and acc[0, 499] == pytest.approx(-9.81) and acc[0, 500] == -9.81
    ref = seed_loop_truth(acc[0])
    s, v, a = sm.integrate_truth(acc)
    np.testing.assert_allclose(s[0], ref[0], atol=1e-9)
    np.testing.assert_allclose(v[0], ref[1], atol=1e-9)
    np.testing.assert_array_equal(a[0], ref[2])
    assert np.argmax(s[0]) == np.argmax(ref[0])
    # the fast path used by simulate(): boost cumsum + exact coast solution
    idx = np.arange(0, 15000, 50)
    s2, v2, a2, k, apo_m = sm.truth_at(params, 15.0, idx)
    np.testing.assert_allclose(s2[0], ref[0, idx], atol=1e-9)
    np.testing.assert_allclose(v2[0], ref[1, idx], atol=1e-9)
    np.testing.assert_array_equal(a2[0], ref[2, idx])
    assert k[0] == np.argmax(ref[0]) and apo_m[0] == pytest.approx(ref[0].max(), abs=1e-9)


def test_fast_truth_equals_cumsum_truth_for_drawn_flights():
    fl = sm.simulate_monte_carlo(40, seed=5, pad_s=0.0)
    n_ms = sm.n_ms_samples(fl.t_length_s)
    s, v, a = sm.integrate_truth(sm.acceleration_profile(fl.params, n_ms))
    idx = np.arange(0, n_ms, 50)
    np.testing.assert_allclose(fl.true_altitude_m, s[:, idx], atol=1e-8)
    np.testing.assert_allclose(fl.true_velocity_mps, v[:, idx], atol=1e-9)
    np.testing.assert_array_equal(fl.true_accel_mps2, a[:, idx])
    t = sm.seed_time_vector(fl.t_length_s)
    np.testing.assert_array_equal(fl.true_apogee_time_s, t[np.argmax(s, axis=1)])
    # closed-form 1 ms velocity (used for "velocity at deployment") at every 1 ms index
    every = np.arange(n_ms - 1)
    cf = sm.true_velocity_ms_index(fl.params, every[:, None], n_ms).T
    np.testing.assert_allclose(cf, v[:, :-1], atol=1e-9)
    # and through the time lookup, at sample times
    vt = fl.true_velocity_at(np.broadcast_to(fl.time_s[:, None], (len(fl.time_s), fl.n_flights)))
    np.testing.assert_allclose(vt.T, fl.true_velocity_mps, atol=1e-9)


def test_seed_time_vector_and_samples():
    fl = sm.simulate_paper_flight(seed=3)
    t = np.linspace(0, 15, 15000)
    np.testing.assert_array_equal(fl.time_s, t[::50])          # the seed's t_q = t(1:50:end)
    assert len(fl.time_s) == 300
    assert fl.time_s[1] == pytest.approx(50 * 15 / 14999)      # not exactly 50 ms
    assert fl.ignition_time_s == 0.0 and fl.n_pad == 0


def test_noise_statistics_before_quantisation():
    fl = sm.simulate_monte_carlo(30, seed=11, pad_s=0.0, keep_unquantised=True)
    n = fl.altitude_m.size
    for key, truth, sigma in (("altitude_m", fl.true_altitude_m, sm.SIGMA_ALT_M),
                              ("velocity_mps", fl.true_velocity_mps, sm.SIGMA_VEL_MPS),
                              ("accel_kinematic_mps2", fl.true_accel_mps2, sm.SIGMA_ACC_MPS2)):
        resid = fl.unquantised[key] - truth
        # the std of a sample std is sigma / sqrt(2 n); allow 5 of those; the mean within 5 sigma/sqrt(n)
        assert np.std(resid) == pytest.approx(sigma, rel=5 / np.sqrt(2 * n)), key
        assert abs(np.mean(resid)) < 5 * sigma / np.sqrt(n), key


def test_floor_quantisation_in_steps_of_three():
    fl = sm.simulate_monte_carlo(10, seed=2, pad_s=1.0, keep_unquantised=True)
    for key, q in (("altitude_m", fl.altitude_m), ("velocity_mps", fl.velocity_mps),
                   ("accel_kinematic_mps2", fl.accel_kinematic_mps2)):
        raw = fl.unquantised[key]
        np.testing.assert_array_equal(np.mod(q, 3.0), 0.0)
        assert (q <= raw).all() and (raw < q + 3.0).all(), key      # floor, not round
        np.testing.assert_array_equal(q, np.floor(raw / 3) * 3)
    # accel_mps2 is specific force: quantised kinematic + 9.81 (DESIGN.md D6)
    np.testing.assert_allclose(fl.accel_mps2, fl.accel_kinematic_mps2 + 9.81, atol=1e-12)
    # coast: true -9.81 always reads -12 kinematic (noise 0.0346 never crosses a step), -2.19 specific
    coast = fl.time_s[None, :] > fl.ignition_time_s + 1.0
    assert np.all(fl.accel_kinematic_mps2[np.broadcast_to(coast, fl.accel_mps2.shape)] == -12.0)
    # the pad reads 0 or -3 kinematic (9.81 or 6.81 specific force)
    pad = fl.accel_kinematic_mps2[:, : fl.n_pad]
    assert set(np.unique(pad)) <= {0.0, -3.0}


def test_pad_is_at_rest_with_a_slow_drift_before_ignition():
    fl = sm.simulate_monte_carlo(8, seed=4, pad_s=2.0, keep_unquantised=True)
    assert fl.n_pad == 40
    assert fl.ignition_time_s == pytest.approx(40 * fl.time_s[1])
    np.testing.assert_allclose(np.diff(fl.time_s), fl.time_s[1], rtol=1e-9)
    assert (fl.true_altitude_m[:, :40] == 0).all() and (fl.true_velocity_mps[:, :40] == 0).all()
    assert (fl.true_accel_mps2[:, :40] == 0).all()
    # slow linear drift, zero at ignition, plus the seed's noise
    t_rel = fl.time_s[:40] - fl.ignition_time_s
    resid = fl.unquantised["altitude_m"][:, :40] - fl.pad_drift_mps[:, None] * t_rel[None, :]
    assert np.std(resid) == pytest.approx(sm.SIGMA_ALT_M, rel=0.15)
    assert (np.abs(fl.pad_drift_mps) <= sm.DEFAULT_RANGES.pad_drift_mps).all()
    # the flight part (noise and truth) does not depend on the pad length
    no_pad = sm.simulate_monte_carlo(8, seed=4, pad_s=0.0)
    np.testing.assert_array_equal(fl.altitude_m[:, 40:], no_pad.altitude_m)
    np.testing.assert_array_equal(fl.accel_mps2[:, 40:], no_pad.accel_mps2)
    np.testing.assert_allclose(fl.true_apogee_time_s - fl.ignition_time_s, no_pad.true_apogee_time_s,
                               atol=1e-12)


def test_determinism_and_batch_independence():
    a = sm.simulate_monte_carlo(12, seed=7, pad_s=1.0)
    b = sm.simulate_monte_carlo(12, seed=7, pad_s=1.0, chunk=5)
    c = sm.simulate(7, [9, 3, 4], pad_s=1.0)
    for name in ("altitude_m", "velocity_mps", "accel_mps2", "true_altitude_m", "true_velocity_mps",
                 "true_apogee_time_s", "true_apogee_m", "pad_drift_mps"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        np.testing.assert_array_equal(getattr(a, name)[[9, 3, 4]], getattr(c, name), err_msg=name)
    np.testing.assert_array_equal(a.params.a_peak_mps2[[9, 3, 4]], c.params.a_peak_mps2)
    np.testing.assert_array_equal(a.time_s, c.time_s)
    d = sm.simulate_monte_carlo(12, seed=8, pad_s=1.0)
    assert not np.array_equal(a.altitude_m, d.altitude_m)


def test_every_monte_carlo_draw_contains_apogee_plus_3_s():
    ranges = sm.DEFAULT_RANGES
    fl = sm.simulate_monte_carlo(2000, seed=1, pad_s=0.0)
    end = fl.time_s[-1]
    assert (fl.true_apogee_time_s + ranges.after_apogee_s <= end).all()
    p = fl.params
    assert (p.a_peak_mps2 >= ranges.a_peak_mps2[0]).all() and (p.a_peak_mps2 <= ranges.a_peak_mps2[1]).all()
    assert (p.hold_end_ms >= 250).all() and (p.hold_end_ms <= 600).all()
    decay = p.decay_end_ms - p.hold_end_ms
    assert (decay >= 100).all() and (decay <= 300).all()
    # the worst corner of the ranges too (the flight length is computed from it)
    t_apo, _ = sm.true_apogee(ranges.worst_case(), fl.t_length_s)
    assert t_apo[0] + ranges.after_apogee_s <= end
    # apogee is a real maximum inside the flight, descending afterwards
    k = np.searchsorted(fl.time_s, fl.true_apogee_time_s, side="right")
    assert (fl.true_velocity_mps[np.arange(fl.n_flights), k] <= 0).all()


def test_flight_csv_columns_round_trip(tmp_path):
    flightcsv = pytest.importorskip("desktop.io.flightcsv")
    fl = sm.simulate_monte_carlo(3, seed=9, pad_s=0.5)
    cols, meta = sm.flight_csv_columns(fl, 2)
    path = tmp_path / "f.csv"
    flightcsv.write_flight_csv(path, cols, meta)
    log = flightcsv.read_flight_csv(path)
    np.testing.assert_allclose(log.altitude_m, fl.altitude_m[2])
    np.testing.assert_allclose(log.accel_mps2, fl.accel_mps2[2], atol=1e-4)
    np.testing.assert_allclose(log.time_s, fl.time_s, atol=1e-6)
    assert log.metadata_float("true_apogee_time_s") == fl.true_apogee_time_s[2]
    assert log.metadata_float("flight_index") == 2
    assert log.metadata_float("seed") == 9
