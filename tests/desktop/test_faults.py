"""The fault models of the fault benchmark (desktop/sim/faults.py) against their physics."""

import math

import numpy as np
import pytest

from desktop.sim import faults as flt
from desktop.sim.trajectory import G0, drag_free_vertical, isa_pressure


@pytest.fixture(scope="module")
def supersonic():
    # 600 N for 1.5 s on 2 kg, drag-free: about Mach 1.3 at burnout, Mach 1 again in coast
    return drag_free_vertical(thrust_n=600.0, burn_time_s=1.5, dry_mass_kg=2.0, dt_s=0.001)


def _fault(kind, **params):
    return flt.Fault(kind, params)


def test_transonic_error_is_its_fraction_of_pressure_at_mach_1(supersonic):
    traj = supersonic
    out = flt.apply_to_trajectory(traj, _fault("transonic_up", eps=0.05, sigma_mach=0.1, both_ways=True))
    ratio = out.pressure_pa / traj.pressure_pa
    at_mach_1 = int(np.argmin(np.abs(traj.mach - 1.0)))
    assert abs(traj.mach[at_mach_1] - 1.0) < 1e-3
    assert ratio[at_mach_1] == pytest.approx(1.05, abs=1e-5)
    # one sigma away in Mach: exp(-1/2) of the peak
    at_sigma = int(np.argmin(np.abs(traj.mach[: int(np.argmax(traj.mach))] - 0.9)))
    assert ratio[at_sigma] - 1.0 == pytest.approx(0.05 * math.exp(-0.5), rel=1e-2)
    # and nothing on the pad (Mach 0: 100 sigma away)
    assert ratio[0] == 1.0


def test_transonic_up_and_down_act_on_their_own_crossing(supersonic):
    traj = supersonic
    t_peak = traj.time_s[int(np.argmax(traj.mach))]
    up = flt.apply_to_trajectory(traj, _fault("transonic_up", eps=-0.08, sigma_mach=0.2, both_ways=False))
    down = flt.apply_to_trajectory(traj, _fault("transonic_down", eps=-0.08, sigma_mach=0.2, both_ways=False))
    after, before = traj.time_s > t_peak + 0.25, traj.time_s < t_peak - 0.25
    assert np.all(up.pressure_pa[after] == traj.pressure_pa[after])
    assert np.all(down.pressure_pa[before] == traj.pressure_pa[before])
    # each reaches -8 % where its crossing passes Mach 1
    crossing_down = after & (np.abs(traj.mach - 1.0) < 2e-3)
    ratio_down = down.pressure_pa[crossing_down] / traj.pressure_pa[crossing_down]
    assert np.min(ratio_down) == pytest.approx(0.92, abs=1e-3)
    crossing_up = before & (np.abs(traj.mach - 1.0) < 2e-3)
    ratio_up = up.pressure_pa[crossing_up] / traj.pressure_pa[crossing_up]
    assert np.min(ratio_up) == pytest.approx(0.92, abs=1e-3)


def test_transient_reads_the_pressure_of_dh_higher_hydrostatically():
    traj = drag_free_vertical(thrust_n=200.0, burn_time_s=2.0, dry_mass_kg=2.0)
    f = _fault("transient_midcoast", dh_m=250.0, start_s=8.0, rise_s=0.3, decay_s=1.0, hold_until_s=None)
    out = flt.apply_to_trajectory(traj, f)
    i = int(np.searchsorted(traj.time_s, 8.3))  # fully risen
    h = traj.site_altitude_m + traj.altitude_m[i]
    # the standard atmosphere 250 m higher, to the hydrostatic approximation over 250 m (< 0.01 %)
    assert out.pressure_pa[i] == pytest.approx(isa_pressure(h + 250.0), rel=1e-4)
    assert np.all(out.pressure_pa[traj.time_s < 8.0] == traj.pressure_pa[traj.time_s < 8.0])


def test_transient_rises_within_its_rise_time_then_decays_or_persists():
    t = np.arange(0.0, 20.0, 0.001)
    dh = flt.transient_altitude_m(t, -300.0, 5.0, 0.2, 1.5)
    assert dh[t < 5.0].max() == 0.0
    assert dh[int(np.searchsorted(t, 5.2))] == pytest.approx(-300.0)
    assert dh[int(np.searchsorted(t, 6.7))] == pytest.approx(-300.0 * math.exp(-1.0), rel=1e-3)
    held = flt.transient_altitude_m(t, 200.0, 5.0, 0.5, 1.0, hold_until_s=12.0)
    assert np.all(held[(t >= 5.5) & (t <= 12.0)] == pytest.approx(200.0))
    assert held[int(np.searchsorted(t, 13.0))] == pytest.approx(200.0 * math.exp(-1.0), rel=1e-3)


def test_tilted_accelerometer_reads_cos_tilt_of_the_axial_force():
    traj = drag_free_vertical()
    out = flt.apply_to_trajectory(traj, _fault("accel_tilted", tilt_deg=30.0))
    assert np.allclose(out.accel_mps2, traj.accel_mps2 * math.cos(math.radians(30.0)), rtol=1e-12, atol=0.0)
    assert out.pad_accel_mps2 == pytest.approx(G0 * math.cos(math.radians(30.0)))


def test_record_faults_change_readings_from_their_start_instant():
    t = np.arange(-1.0, 10.0, 0.01)
    p = 100000.0 - 10.0 * np.arange(len(t))
    p[150] = math.nan  # a read error just before the freeze
    a = 9.8 + np.sin(t)
    frozen, _, _ = flt.apply_to_record(t, p, a, _fault("baro_frozen", phase="coast", start_s=0.51))
    assert np.all(frozen[t >= 0.51] == p[149])  # the last reading before the instant
    assert np.array_equal(frozen[t < 0.5], p[t < 0.5], equal_nan=True)
    lost, _, _ = flt.apply_to_record(t, p, a, _fault("baro_lost", phase="coast", start_s=3.0))
    assert np.all(np.isnan(lost[t >= 3.0])) and np.all(np.isfinite(lost[(t < 3.0) & (t > 0.6)]))
    _, acc, _ = flt.apply_to_record(t, p, a, _fault("accel_lost", phase="boost", start_s=0.2))
    assert np.all(np.isnan(acc[t >= 0.2])) and np.all(np.isfinite(acc[t < 0.2]))
    _, acc, _ = flt.apply_to_record(t, p, a, _fault("accel_biased", bias_mps2=-0.7))
    assert np.all(acc[t < 0] == a[t < 0])  # the pad calibration cannot see it
    assert acc[t >= 0] == pytest.approx(a[t >= 0] - 0.7)
    _, acc, _ = flt.apply_to_record(t, p, a, _fault("accel_zeroed", phase="boost", start_s=0.5, until_s=2.0))
    assert np.all(acc[(t >= 0.5) & (t < 2.0)] == 0.0)
    assert np.array_equal(acc[(t < 0.5) | (t >= 2.0)], a[(t < 0.5) | (t >= 2.0)])
    _, acc, _ = flt.apply_to_record(t, p, a, _fault("accel_zeroed", phase="coast", start_s=3.0, until_s=None))
    assert np.all(acc[t >= 3.0] == 0.0) and np.array_equal(acc[t < 3.0], a[t < 3.0])
    peak = 200.0 * np.exp(-((t - 1.0) ** 2))
    _, acc, clip = flt.apply_to_record(t, p, peak, _fault("accel_clipped", fraction_of_peak=0.5))
    assert clip == pytest.approx(0.5 * peak.max()) and acc.max() == pytest.approx(clip)


def test_frozen_noisy_barometer_keeps_the_parts_noise_and_none_of_the_motion_across_a_gap():
    # A climb at 150 m/s (about 1.8 kPa/s) read at 100 Hz with 2 Pa of noise, 120 ms of readings
    # missing after the freeze: the frozen reading is the noise about one pressure, the gap no
    # bump (a running mean over samples spanned it and read metres of the climb as noise)
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 10.0, 0.01)
    t = np.delete(t, np.arange(520, 532))
    noise = rng.normal(0.0, 2.0, len(t))
    p = 100000.0 - 1800.0 * t + noise
    frozen, _, _ = flt.apply_to_record(t, p, None, _fault("baro_frozen_noisy", phase="coast", start_s=5.0))
    after = frozen[t >= 5.0]
    assert len(np.unique(after)) == len(after)  # no reading repeats
    assert np.std(after) == pytest.approx(2.0, rel=0.15)
    assert np.ptp(after) < 2.0 * 2 * 4.5  # within +-4.5 sigma of one pressure, the gap included
    assert np.array_equal(frozen[t < 5.0], p[t < 5.0])


def test_draws_stay_in_the_stated_ranges(supersonic):
    traj = supersonic
    rng = np.random.default_rng(3)
    for kind in flt.CLASSES:
        for _ in range(200):
            p = flt.draw_fault(kind, rng, traj, traj.end_time_s).params
            if kind.startswith("transonic"):
                assert abs(p["eps"]) <= 0.10 and 0.05 <= p["sigma_mach"] <= 0.3
            elif kind.startswith("transient"):
                assert abs(p["dh_m"]) <= 300.0 and 0.1 <= p["rise_s"] <= 0.5
                if kind == "transient_burnout":
                    assert 0.0 <= p["start_s"] - traj.burnout_time_s <= 0.5
                elif kind == "transient_ejection":
                    assert 0.0 <= p["start_s"] - traj.apogee_time_s <= 0.5 and p["hold_until_s"] is None
            elif kind in ("baro_frozen", "baro_lost", "accel_lost"):
                assert 0.0 <= p["start_s"] <= traj.end_time_s
            elif kind == "accel_zeroed":
                assert 0.0 <= p["start_s"] <= traj.end_time_s
                assert p["until_s"] is None or 0.2 <= p["until_s"] - p["start_s"] <= 5.0
            elif kind == "accel_biased":
                assert abs(p["bias_mps2"]) <= 1.0
            elif kind == "accel_tilted":
                assert 0.0 <= p["tilt_deg"] <= 30.0
    with pytest.raises(flt.FaultError):
        flt.draw_fault("gremlins", rng, traj, 1.0)


def test_classes_per_rocket_and_board():
    assert "transonic_down" not in flt.classes_for(0.8, "both")
    assert "transonic_down" in flt.classes_for(1.6, "both")
    assert not set(flt.classes_for(1.6, "baro")) & set(flt.ACCEL_CLASSES)
