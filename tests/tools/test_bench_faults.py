"""The fault benchmark's corner cases (tools/bench_faults.py), one flight each, through the same
path as the benchmark: the sensor models, the fault, the flight computer as ``desktop replay`` runs
it, configured as docs/CONFIG.md tells users (``bench.user_settings``: the backup timer at nominal
apogee + 3 s, the main's timers, a barometer-only board's Mach lockout).

Each test states a goal of the issue "Never fooled by one sensor". Where today's flight computer
misses the goal, the test is marked ``xfail(strict=True)``: it turns into a failure (remove the
mark) once the detector meets it. The flights are analytic (drag-free ascent, then a parachute
descent at 20 m/s that joins free fall smoothly), so no RocketPy run is needed.
"""

import dataclasses
import json
import math

import numpy as np
import pytest

from desktop.sim import faults as flt
from desktop.sim.trajectory import G0, drag_free_vertical, isa_pressure, isa_speed_of_sound
from tools import bench_faults as bench

pytestmark = pytest.mark.slow  # each flight takes 1 to 3 s on the shared machine

EARLY_S = bench.EARLY_S
MAIN_M = 250.0


def flight(thrust_n, burn_s, mass_kg, descent_mps=20.0, until_m=None, after_apogee_s=6.0):
    """Drag-free ascent, then v = -D (1 - exp(-t/tau)) with tau = D/g after apogee (acceleration
    continuous at apogee: -g), down to ``until_m`` (or ``after_apogee_s`` past apogee)."""
    up = drag_free_vertical(thrust_n=thrust_n, burn_time_s=burn_s, dry_mass_kg=mass_kg, site_altitude_m=300.0)
    keep = up.time_s <= up.apogee_time_s
    t_up, z_up, v_up, f_up = up.time_s[keep], up.altitude_m[keep], up.velocity_mps[keep], up.accel_mps2[keep]
    tau = descent_mps / G0
    end = up.apogee_time_s + after_apogee_s
    if until_m is not None:
        end = up.apogee_time_s + (up.apogee_m - until_m) / descent_mps + tau
    s = np.arange(t_up[-1] + 0.001, end, 0.001) - up.apogee_time_s
    decay = np.exp(-s / tau)
    z_dn = up.apogee_m - descent_mps * (s - tau * (1.0 - decay))
    t = np.concatenate([t_up, s + up.apogee_time_s])
    z = np.concatenate([z_up, z_dn])
    v = np.concatenate([v_up, -descent_mps * (1.0 - decay)])
    f = np.concatenate([f_up, G0 * (1.0 - decay)])
    h = up.site_altitude_m + z
    return dataclasses.replace(up, time_s=t, altitude_m=z, velocity_mps=v, accel_mps2=f,
                               pressure_pa=np.asarray(isa_pressure(h)),
                               mach=np.abs(v) / isa_speed_of_sound(h),
                               thrust_n=None, mass_kg=None)


@pytest.fixture(scope="module")
def subsonic():
    # 1.8 km, 180 m/s (Mach 0.53) at burnout; descends to below the main altitude
    return flight(200.0, 2.0, 2.0, until_m=MAIN_M - 40.0)


def drag_flight(thrust_n, burn_s, mass_kg, cda_m2, after_apogee_s=6.0, site_m=300.0, dt_s=0.001):
    """Vertical point mass with drag (drag area ``cda_m2`` x 1.5 from Mach 0.9 to 1.2, the
    transonic drag rise), troposphere, integrated at 1 ms; ends ``after_apogee_s`` past apogee."""
    t = z = v = 0.0
    ts, zs, vs, fs = [0.0], [0.0], [0.0], [thrust_n / mass_kg]
    apogee_s = None
    while apogee_s is None or t < apogee_s + after_apogee_s:
        temp = 288.15 - 0.0065 * (site_m + z)
        rho = 101325.0 * (temp / 288.15) ** 5.25588 / (287.05287 * temp)
        mach = abs(v) / math.sqrt(1.4 * 287.05287 * temp)
        cda = cda_m2 * (1.0 + 0.5 * min(max((mach - 0.9) / 0.3, 0.0), 1.0))
        force = (thrust_n if t < burn_s else 0.0) - 0.5 * rho * v * abs(v) * cda
        v += (force / mass_kg - G0) * dt_s
        z += v * dt_s
        t += dt_s
        if apogee_s is None and v < 0.0:
            apogee_s, apogee_m = t, z
        ts.append(t), zs.append(z), vs.append(v), fs.append(force / mass_kg)
    up = drag_free_vertical(site_altitude_m=site_m)
    time_s, z_m, v_mps = np.array(ts), np.array(zs), np.array(vs)
    h = site_m + z_m
    return dataclasses.replace(
        up, time_s=time_s, altitude_m=z_m, velocity_mps=v_mps, accel_mps2=np.array(fs),
        pressure_pa=np.asarray(isa_pressure(h)), mach=np.abs(v_mps) / isa_speed_of_sound(h),
        apogee_time_s=apogee_s, apogee_m=apogee_m, burnout_time_s=burn_s, thrust_n=None, mass_kg=None)


@pytest.fixture(scope="module")
def model_rocket():
    # a C6-class model rocket (0.11 kg, 25 mm, 7.6 N for 1.86 s): 100 m/s at burnout, apogee
    # 430 m at 9.5 s
    return drag_flight(7.6, 1.86, 0.11, 0.5 * math.pi * 0.0125**2)


@pytest.fixture(scope="module")
def supersonic():
    # a 78 mm minimum-diameter K1000-class flight: Mach 1.7 at burnout (2.5 s), through Mach 1
    # again about 5 s later, apogee 3.9 km at 23 s; ends 6 s past apogee
    return drag_flight(1000.0, 2.5, 3.0, 0.5 * math.pi * 0.039**2)


def run(traj, fault, board="both", profile="ms5611+adxl375", seed=7, main_m=MAIN_M, **config):
    """(drogue s, main s) of the flight computer on the faulted record (``main_m`` None: one
    parachute); ``config``: configuration keys beside the user settings (a rule's threshold
    changed to show what the rule does)."""
    rec, pres, acc, clip = bench.faulted_record(traj, fault, profile, seed, bench.board_config(100.0))
    return bench.run_methods(rec, pres, acc, clip, board, main_m,
                             dict(bench.user_settings(traj, main_m), **config))["flight-computer"]


def fault(kind, **params):
    return flt.Fault(kind, params)


def assert_not_early(traj, drogue_s):
    assert math.isfinite(drogue_s), "no drogue"
    early_s = traj.apogee_time_s - drogue_s
    assert early_s <= EARLY_S, "drogue %.2f s before apogee" % early_s


def assert_within(traj, drogue_s, tol_s):
    assert_not_early(traj, drogue_s)
    assert abs(drogue_s - traj.apogee_time_s) <= tol_s


XFAIL_MACH = pytest.mark.xfail(strict=True, reason=(
    "the arbitration keeps the drogue after apogee, but a static-port error on the way down leaves it "
    "0.15-0.19 s late: beyond the 0.1 s goal"))
XFAIL_TRANSIENT = pytest.mark.xfail(strict=True, reason=(
    "a transient that decays over 3 s in mid coast changes the barometric rate slowly enough to stay "
    "inside the consistency tolerance: -300 m fires 0.68 s late (the filter follows the barometer's "
    "false climb); +300 m, 0.29 s early before the dead reckoning was calibrated, passes"))


# --- both sensors -------------------------------------------------------------------------------


@pytest.mark.parametrize("settle_s, early", [(None, False), (0, True)], ids=["wait", "no_wait"])
def test_apogee_waits_after_the_barometer_comes_back_reading_slow(model_rocket, settle_s, early):
    """+300 m within 0.4 s just after burnout, decaying over 1.5 s, on a model rocket: the
    arbitration leaves the barometer out and takes it back while its decay still lies, reading
    slower than the accelerometer carries the velocity on, inside the accelerometer's worst-case
    margin (its tilt budget x the boost); the coast before the fault was too short for the
    dead-reckoning guard. Waiting baro_settle_s (the default) after the barometer came back:
    0.21 s early; without the wait, 0.68 s early. (Decaying over 2.5 s, the filter then blames
    the accelerometer for its whole error budget, and the wait goes on after baro_settle_s:
    next test.)"""
    config = {} if settle_s is None else {"baro_settle_s": settle_s}
    drogue = _burnout_transient_drogue(model_rocket, 300.0, decay_s=1.5, **config)
    assert math.isfinite(drogue)
    assert (model_rocket.apogee_time_s - drogue > EARLY_S) == early


def test_a_smaller_transient_at_burnout_of_a_model_rocket_is_not_early(model_rocket):
    """+200 m at burnout, decaying over 2.5 s, on the model rocket: taken back about 6 s before
    apogee, its decay still lies inside the accelerometer's worst-case margin (its tilt budget x
    the boost) after the baro_settle_s wait, and the filter, its bias estimate at its upper bound,
    follows it through zero. The wait goes on while the filter blames the accelerometer that much
    and the accelerometer's own account still climbs (docs/DESIGN.md D16 rule 9): 0.16 s early;
    1.03 s early without."""
    assert_not_early(model_rocket, _burnout_transient_drogue(model_rocket, 200.0))


def _burnout_transient_drogue(traj, dh_m, decay_s=2.5, **config):
    """A transient rising within 0.4 s from 0.1 s after burnout, then decaying (time constant
    ``decay_s``)."""
    drogue, _ = run(traj, fault("transient_burnout", dh_m=dh_m, start_s=traj.burnout_time_s + 0.1, rise_s=0.4,
                                decay_s=decay_s, hold_until_s=None), **config)
    return drogue


def test_fault_free_subsonic_within_0_1_s(subsonic):
    drogue, main = run(subsonic, fault("none"))
    assert_within(subsonic, drogue, 0.1)
    assert abs(np.interp(main, subsonic.time_s, subsonic.altitude_m) - MAIN_M) <= 20.0


def test_fault_free_supersonic_within_0_1_s(supersonic):
    drogue, _ = run(supersonic, fault("none"))
    assert_within(supersonic, drogue, 0.1)


@pytest.mark.parametrize("eps", [0.10, -0.10])
@pytest.mark.parametrize("sigma_mach", [0.1, 0.3])
def test_transonic_error_on_the_way_up(supersonic, eps, sigma_mach):
    drogue, _ = run(supersonic, fault("transonic_up", eps=eps, sigma_mach=sigma_mach, both_ways=False))
    assert_within(supersonic, drogue, 0.1)


@XFAIL_MACH
@pytest.mark.parametrize("eps", [0.10, -0.10])
def test_transonic_error_on_the_way_down(supersonic, eps):
    drogue, _ = run(supersonic, fault("transonic_down", eps=eps, sigma_mach=0.3, both_ways=False))
    assert_within(supersonic, drogue, 0.1)


@pytest.mark.parametrize("dh_m, hold", [
    (-300.0, True), (300.0, True), (-300.0, False)])
def test_pressure_transient_at_burnout_leaves_the_drogue_within_0_1_s_of_apogee(subsonic, dh_m, hold):
    start = subsonic.burnout_time_s + 0.1
    drogue, _ = run(subsonic, fault("transient_burnout", dh_m=dh_m, start_s=start, rise_s=0.1, decay_s=3.0,
                                    hold_until_s=subsonic.apogee_time_s if hold else None))
    assert_within(subsonic, drogue, 0.1)


def test_a_static_port_error_in_boost_is_left_out_while_the_accelerometer_bounds_it():
    """A 26 kg rocket at 29 g for 3.8 s to Mach 0.95, its static port reading -9.2 % of the
    pressure at Mach 1 (sigma 0.29 in Mach, up and down): the barometer lies by hundreds of metres
    through the boost. In coast the arbitration leaves it out; in boost it did not, the filter
    followed it, and left the boost with a velocity the coast never made good: drogue 0.63 s
    early. In boost too, while the accelerometer's track bounds the velocity from both sides,
    the barometer it contradicts is left out (docs/DESIGN.md D16 rule 2)."""
    heavy = drag_flight(7435.4, 3.818, 25.8, 0.118)
    assert 0.9 < heavy.max_mach < 1.0
    drogue, _ = run(heavy, fault("transonic_down", eps=-0.092, sigma_mach=0.287, both_ways=True),
                    main_m=None)
    assert_within(heavy, drogue, 0.1)


@pytest.mark.parametrize("dh_m, decay_s", [
    (-300.0, 0.3), (300.0, 0.3), pytest.param(-300.0, 3.0, marks=XFAIL_TRANSIENT), (300.0, 3.0)])
def test_transient_in_mid_coast(subsonic, dh_m, decay_s):
    assert_within(subsonic, _mid_coast_transient_drogue(subsonic, dh_m, decay_s), 0.1)


@pytest.mark.parametrize("dh_m", [-300.0, 300.0])
@pytest.mark.parametrize("decay_s", [0.3, 3.0])
def test_transient_in_mid_coast_never_fires_early(subsonic, dh_m, decay_s):
    assert_not_early(subsonic, _mid_coast_transient_drogue(subsonic, dh_m, decay_s))


@pytest.mark.parametrize("rocket", ["subsonic", "supersonic"])
def test_an_offset_released_just_before_apogee_does_not_hold_the_filter(rocket, request):
    """A barometer reading 100 m low from mid coast (airbrakes held open) until 0.2 s before
    apogee, then decaying over 2.7 s: as the filter reaches zero, the barometer's return sets in,
    climbing at 6 to 20 m/s. A coasting rocket's climb rate falls by at least g x 0.5 s over a
    window; this one fell by less, so it is no climb, and D16 rule 17 does not hold the filter
    (drogue 0.1 s after apogee; held, the filter follows the return and the barometer is left out:
    2.2 to 2.5 s late)."""
    traj = request.getfixturevalue(rocket)
    mid = 0.5 * (traj.burnout_time_s + traj.apogee_time_s)
    drogue, _ = run(traj, fault("transient_midcoast", dh_m=-100.0, start_s=mid, rise_s=0.25,
                                decay_s=2.7, hold_until_s=traj.apogee_time_s - 0.2))
    assert_not_early(traj, drogue)
    assert drogue - traj.apogee_time_s <= 0.5


def _mid_coast_transient_drogue(traj, dh_m, decay_s):
    start = 0.5 * (traj.burnout_time_s + traj.apogee_time_s)
    drogue, _ = run(traj, fault("transient_midcoast", dh_m=dh_m, start_s=start, rise_s=0.1,
                                decay_s=decay_s, hold_until_s=None))
    return drogue


@pytest.mark.slow
@pytest.mark.parametrize("dh_m", [-300.0, 300.0])
def test_ejection_transient_leaves_the_main_at_its_altitude(subsonic, dh_m):
    drogue, main = run(subsonic, fault("transient_ejection", dh_m=dh_m, start_s=subsonic.apogee_time_s + 0.2,
                                       rise_s=0.1, decay_s=3.0, hold_until_s=None))
    assert_within(subsonic, drogue, 0.3)
    assert abs(np.interp(main, subsonic.time_s, subsonic.altitude_m) - MAIN_M) <= 20.0


@pytest.mark.parametrize("kind", ["baro_frozen", "baro_frozen_noisy"])
@pytest.mark.parametrize("phase", ["boost", "coast"])
def test_frozen_barometer_never_fires_early(subsonic, phase, kind):
    # (frozen under its noise in the boost, the barometer looks alive and never agrees with the
    # accelerometer again: the flight is proven once it is retired in coast, far below the
    # filter reading no climb, docs/DESIGN.md D16 rule 20; the backup timer fires)
    start = 1.0 if phase == "boost" else subsonic.burnout_time_s + 2.0
    drogue, _ = run(subsonic, fault(kind, phase=phase, start_s=start))
    assert_not_early(subsonic, drogue)


@pytest.mark.parametrize("start_s", [1.0, 8.0, 18.0])
def test_lost_barometer_never_fires_early_and_the_drogue_comes(subsonic, start_s):
    drogue, _ = run(subsonic, fault("baro_lost", phase="any", start_s=start_s))
    assert_not_early(subsonic, drogue)


@pytest.mark.parametrize("kind, params", [
    ("accel_lost", {"phase": "boost", "start_s": 1.0}),
    ("accel_lost", {"phase": "coast", "start_s": 2.1}),
    ("accel_clipped", {"fraction_of_peak": 0.3}),
    ("accel_biased", {"bias_mps2": 1.0}),
    ("accel_biased", {"bias_mps2": -1.0}),
    ("accel_tilted", {"tilt_deg": 30.0}),
])
def test_accelerometer_faults_with_a_healthy_barometer_within_0_3_s(subsonic, kind, params):
    drogue, _ = run(subsonic, fault(kind, **params))
    assert_within(subsonic, drogue, 0.3)


@pytest.mark.parametrize("start_s, until_s", [(0.5, 3.0), (0.5, None), (3.5, None)])
def test_an_accelerometer_reading_zeros_is_found_out_by_the_barometer(supersonic, start_s, until_s):
    """A failed bus reads zero bytes: 0 m/s^2 of specific force, a drag-free coast, from 0.5 s into
    the Mach 1.7 boost (for 2.5 s, or for good) or from 1 s after burnout. The filter and the
    accelerometer's bounds believe it, and the healthy barometer, disagreeing, is left out; the
    barometer then parts from the accelerometer-carried filter by more than any barometric error,
    or climbs fast while the accelerometer holds zero, and the accelerometer is retired for the
    flight (docs/DESIGN.md D16 rule 14). Before, the first fired 17.6 s early and the last 3.1 s
    late, on the backup timer."""
    drogue, _ = run(supersonic, fault("accel_zeroed", phase="boost", start_s=start_s, until_s=until_s))
    assert_within(supersonic, drogue, 0.1)


def test_a_model_rocket_whose_accelerometer_reads_zeros_is_proven_by_the_barometer(model_rocket):
    """The same from 0.5 s into a C6's boost, for good: a 430 m flight never parts 1.2 km from
    anything, but the accelerometer holds zero while the barometer climbs faster than 50 m/s, which
    no drag allows, and it is retired (D16 rule 14): the barometer alone proves the flight. Before,
    the two climbs never agreed, the flight was never proven, and nothing fired at all."""
    drogue, _ = run(model_rocket, fault("accel_zeroed", phase="boost", start_s=0.5, until_s=None))
    assert_within(model_rocket, drogue, 0.1)


@pytest.mark.parametrize("fraction_of_peak", [0.3, 0.5])
def test_a_clipped_boost_waits_for_the_filter_to_settle(supersonic, fraction_of_peak):
    """The accelerometer clips at 30 % of a Mach 1.7 boost's peak: its track bounds the velocity
    from below only, and the filter, held at the clipped acceleration, leaves the boost hundreds of
    m/s off and re-converges on the barometer through coast. Apogee waits, as on a
    barometer-only board, baro_settle_s after the filter was baro_diverged_m off the barometer
    (docs/DESIGN.md D16 rule 11); without it the drogue came 14.4 s early."""
    drogue, _ = run(supersonic, fault("accel_clipped", fraction_of_peak=fraction_of_peak))
    assert_within(supersonic, drogue, 0.1)


@pytest.mark.parametrize("start_s", [7.0, 8.0, 9.0])
def test_baro_only_apogee_needs_a_coasting_deceleration(start_s):
    """A 0.25 kg rocket on a 4.8 s, 23 g boost to Mach 0.94, on a barometer-only board: the
    filter, a third-order model of the barometer alone, rings after so long a boost (its
    acceleration at -7 g 3 s after burnout, its velocity 46 m/s slow). A barometer frozen at
    8.0 s, as the Mach lockout ends, pulls that velocity through zero before the freeze is judged
    (baro_stuck_s): drogue 5.7 s early. Near apogee a coasting rocket decelerates at g (the
    vertical drag vanishes), so the filter decides only within 2 g of it (docs/DESIGN.md D16 rule
    12): the freeze is judged, and the backup timer fires."""
    long_burn = drag_flight(58.24, 4.805, 0.254, 0.001)
    drogue, _ = run(long_burn, fault("baro_frozen", phase="coast", start_s=start_s), board="baro",
                    main_m=None)
    assert_not_early(long_burn, drogue)


def test_a_low_flight_whose_accelerometer_clipped_is_proven_by_the_barometer():
    """A 4 kg rocket on a short 8 g boost to 190 m, its accelerometer clipping at a third of that:
    the clipped readings integrate to less than proof_speed_mps, so the accelerometer's account
    proves nothing, and the barometer alone proves the flight, as on a barometer-only board (its
    100 m climb held a second). Before, such a flight was never proven: no drogue, no main."""
    low = drag_flight(311.8, 0.91, 4.12, 0.0107)
    assert 150.0 < low.apogee_m < 250.0
    drogue, _ = run(low, fault("accel_clipped", fraction_of_peak=0.32), main_m=None)
    assert_within(low, drogue, 0.3)


@pytest.fixture(scope="module")
def small_rocket():
    # 0.6 kg on 70 N for 0.77 s: 80 m/s at burnout, apogee 260 m at 7.2 s
    return drag_flight(70.0, 0.77, 0.6, 0.002)


@pytest.mark.parametrize("dh_m, late_s", [(280.0, 0.3), (-280.0, bench.BACKUP_MARGIN_S + 0.3)])
def test_an_offset_held_from_burnout_still_proves_the_flight(small_rocket, dh_m, late_s):
    """A pressure offset as large as the flight, from just after burnout to apogee (airbrakes
    open): the barometer comes back into use 1.5 s later, agreeing with the accelerometer's
    rates, but its reading, offset since, never agreed with the height integrated from the
    accelerometer since the pad. The flight was never proven: no drogue, no main, and 10 s after
    launch, descending near terminal speed (reading 1 g, as on the pad), the board went back to
    pad mode. Counted from where the barometer came back, the two climbs agree. Reading 280 m
    high, the drogue fires at apogee; reading below the pad, the filter is below the proof climb,
    where no apogee is decided, and the backup timer fires it."""
    assert 200.0 < small_rocket.apogee_m < 320.0
    start_s = small_rocket.burnout_time_s + 0.07
    drogue, _ = run(small_rocket, fault("transient_burnout", dh_m=dh_m, start_s=start_s, rise_s=0.43,
                                        decay_s=2.1, hold_until_s=small_rocket.apogee_time_s),
                    main_m=None)
    assert_not_early(small_rocket, drogue)
    assert drogue - small_rocket.apogee_time_s <= late_s


@pytest.fixture(scope="module")
def clipping_rocket():
    # 5 kg on 1931 N for 2.15 s: 38 g, Mach 1.75, apogee 3.8 km at 22.9 s
    return drag_flight(1931.0, 2.15, 5.15, 0.004)


@pytest.mark.parametrize("dh_m", [74.0, -74.0])
def test_a_barometer_taken_back_climbing_faster_than_the_filter_gives_it_its_rate(clipping_rocket, dh_m):
    """A 5 kg rocket at 38 g on a 16 g part (Mach 1.75, apogee 3.8 km at 22.9 s): the clipped
    boost leaves the filter's velocity wrong, and the arbitration's anchor with it. A 74 m transient
    at 7.6 s has the barometer left out for 15 s; taken back, it climbs at 47 m/s while the filter,
    carried by its wrong anchor, descends: the filter's velocity crossed zero at once, 0.63 s before
    apogee (on a 2-D flight of the random rockets, 4.4 s before apogee at 44 m/s). Given the
    barometer's rate (D16 rule 13), and its distance to the barometer measured afresh, the drogue
    is not early, and comes before the backup timer."""
    traj = clipping_rocket
    assert traj.accel_mps2.max() > 30 * G0 and 3500.0 < traj.apogee_m < 4200.0
    drogue, _ = run(traj, fault("transient_midcoast", dh_m=dh_m, start_s=7.6, rise_s=0.45, decay_s=0.54,
                                hold_until_s=None),
                    profile="bmp388+mpu6050", main_m=None, accel_range_g=16.0)
    assert_not_early(traj, drogue)
    assert drogue - traj.apogee_time_s < bench.BACKUP_MARGIN_S - 0.5


@pytest.mark.parametrize("start_s", [2.0, 2.3])
@pytest.mark.parametrize("baro_track_m", [10, 100], ids=["tracking_check", "tracking_check_widest"])
def test_accelerometer_lost_late_in_boost_of_a_supersonic_flight(supersonic, start_s, baro_track_m):
    """The accelerometer dies with the motor still burning: the filter keeps the thrust in its
    acceleration. The barometer, now the only sensor, keeps its full weight through Mach, and the
    filter re-converges on it; the tracking check holds apogee back while it does. Each rule alone
    keeps the drogue at apogee (the widest check leaves the weight rule alone); without both it came
    17 s early at 270 m/s."""
    drogue, _ = run(supersonic, fault("accel_lost", phase="boost", start_s=start_s),
                    baro_track_m=baro_track_m)
    assert_within(supersonic, drogue, 0.1)


@pytest.mark.parametrize("start_s", [2.0, 2.3])
def test_the_only_sensor_left_keeps_its_full_weight_through_mach(supersonic, start_s):
    """The accelerometer dies in the boost of a Mach 1.7 flight: the barometer, now the only sensor,
    keeps its full weight, so the filter's velocity follows it back from the thrust it kept
    (190 to 200 m/s off at most, 5 to 13 m/s from 5 s after the loss). De-weighted through Mach as
    on a board with both sensors, it ran 410 to 460 m/s off (47 to 52 m/s after 5 s): the drogue's
    tracking and re-convergence rules then carry the flight alone."""
    from desktop.review.replay import config_for, ground_alt_mm, readings
    from shared.flight import FlightComputer

    rec, pres, acc, clip = bench.faulted_record(
        supersonic, fault("accel_lost", phase="boost", start_s=start_s), "ms5611+adxl375", 7,
        bench.board_config(100.0))
    log = bench.flight_log(rec.time_s, pres, acc, rec.metadata)
    overrides = bench.board_overrides(bench.user_settings(supersonic, MAIN_M), "both", MAIN_M, clip)
    fc = FlightComputer(config_for(log, overrides=overrides), ground_alt_mm=ground_alt_mm(log))
    worst_mps = 0.0
    for t, d, a, f, h in zip(log.time_s, *readings(log), strict=True):
        fc.step(int(d), int(a), int(f), int(h))
        if start_s < t < supersonic.apogee_time_s:
            true_mps = np.interp(t, supersonic.time_s, supersonic.velocity_mps)
            worst_mps = max(worst_mps, abs(fc.vel_mmps / 1000 - true_mps))
    assert worst_mps <= 300.0


# --- barometer-only board -------------------------------------------------------------------------


def test_baro_only_fault_free_subsonic(subsonic):
    drogue, main = run(subsonic, fault("none"), board="baro")
    assert_within(subsonic, drogue, 0.3)
    assert abs(np.interp(main, subsonic.time_s, subsonic.altitude_m) - MAIN_M) <= 20.0


@pytest.mark.parametrize("kind, eps", [("none", 0.0), ("transonic_up", 0.10)])
def test_baro_only_through_mach_never_fires_early(supersonic, kind, eps):
    drogue, _ = run(supersonic, fault(kind, eps=eps, sigma_mach=0.1, both_ways=False), board="baro")
    assert_not_early(supersonic, drogue)


@pytest.mark.parametrize("dh_m, decay_s", [(-300.0, 0.3), (300.0, 0.3), (-300.0, 3.0), (300.0, 3.0)])
def test_baro_only_transient_in_mid_coast_never_fires_early(subsonic, dh_m, decay_s):
    start = 0.5 * (subsonic.burnout_time_s + subsonic.apogee_time_s)
    drogue, _ = run(subsonic, fault("transient_midcoast", dh_m=dh_m, start_s=start, rise_s=0.1,
                                    decay_s=decay_s, hold_until_s=None), board="baro")
    assert_not_early(subsonic, drogue)


@pytest.mark.parametrize("tol_mps, early", [(None, False), (0, True)], ids=["floor", "no_floor"])
def test_baro_only_apogee_waits_for_the_ballistic_floor(subsonic, tol_mps, early):
    """+300 m within 0.1 s in mid coast, decaying over 3 s, on a barometer-only board: the filter
    follows the decay within baro_diverged_m once the gate has re-synchronised, and its velocity
    crosses zero 1.02 s before apogee. The rise is beyond what a coasting rocket can do: the
    ballistic floor from the rates before it (baro_ballistic_mps, the default) holds apogee until
    a coast that began at that speed could have stopped climbing."""
    config = {} if tol_mps is None else {"baro_ballistic_mps": tol_mps}
    start = 0.5 * (subsonic.burnout_time_s + subsonic.apogee_time_s)
    drogue, _ = run(subsonic, fault("transient_midcoast", dh_m=300.0, start_s=start, rise_s=0.1,
                                    decay_s=3.0, hold_until_s=None), board="baro", **config)
    assert math.isfinite(drogue)
    assert (subsonic.apogee_time_s - drogue > EARLY_S) == early


@pytest.mark.parametrize("baro_track_m, early", [(10, False), (100, True)],
                         ids=["tracking_check", "tracking_check_widest"])
def test_baro_only_apogee_waits_for_the_filter_to_track_the_barometer(subsonic, baro_track_m, early):
    """-45 m within 0.1 s, 1 s before apogee, decaying over 2 s: inside the gate, so the filter
    follows it and its velocity dips through zero. The tracking check (baro_track_m) holds apogee
    until the filter is back on the barometer: 0.10 s early; at its widest, 0.73 s early. (The
    ballistic floor holds this flight too: it is off here, so this test speaks for the check.)"""
    drogue, _ = run(subsonic, fault("transient_midcoast", dh_m=-45.0, start_s=subsonic.apogee_time_s - 1.0,
                                    rise_s=0.1, decay_s=2.0, hold_until_s=None), board="baro",
                    baro_track_m=baro_track_m, baro_ballistic_mps=0)
    assert (subsonic.apogee_time_s - drogue > EARLY_S) == early


def test_baro_only_apogee_waits_for_the_filter_to_reconverge_after_a_resync(subsonic):
    # +300 m within 0.3 s in mid coast, decaying over 2 s: the gate rejects it for a second, then
    # re-synchronises, and the re-converging filter's velocity swung through zero 5.65 s before
    # apogee. No apogee until the gate has re-armed (0.31 s early). The baro_settle_s wait and
    # the ballistic test (since a run of failing windows without a floor holds too, D16 rule 10)
    # hold this flight too, so they are off here: this test speaks for the re-arm alone.
    start = 0.5 * (subsonic.burnout_time_s + subsonic.apogee_time_s)
    drogue, _ = run(subsonic, fault("transient_midcoast", dh_m=300.0, start_s=start, rise_s=0.3,
                                    decay_s=2.0, hold_until_s=None), board="baro", baro_settle_s=0,
                    baro_ballistic_mps=0)
    assert_not_early(subsonic, drogue)


@pytest.mark.parametrize("settle_s, early", [(None, False), (0, True)], ids=["settle", "no_settle"])
def test_baro_only_apogee_waits_for_the_filter_to_settle_after_it_was_off_the_barometer(
        subsonic, settle_s, early):
    """+80 m within 0.3 s, 5 s before apogee, decaying over 1 s: the gate rejects its peak for
    less than the second a re-synchronisation takes, and the filter, pulled off the barometer,
    swings back through the transient of its gains; its altitude tracks the barometer again while
    its velocity is still 16 m/s low. Waiting baro_settle_s (the default) after it was
    baro_diverged_m off the barometer: 0.26 s early; without the wait, 1.67 s early. (The
    ballistic floor holds this flight too: it is off here, so this test speaks for the wait.)"""
    config = {"baro_ballistic_mps": 0}
    if settle_s is not None:
        config["baro_settle_s"] = settle_s
    drogue, _ = run(subsonic, fault("transient_midcoast", dh_m=80.0, start_s=subsonic.apogee_time_s - 5.0,
                                    rise_s=0.3, decay_s=1.0, hold_until_s=None), board="baro", **config)
    assert (subsonic.apogee_time_s - drogue > EARLY_S) == early


def test_pressure_step_held_to_apogee_moves_the_altitude_not_the_velocity(supersonic):
    # -120 m within 0.4 s, 6 s before apogee, held to apogee (airbrakes): the Mach 1.7 boost leaves
    # the accelerometer's worst-case margin wide enough to admit it, the gate rejects it for a
    # second and re-synchronises. Taken through the gains, the step pulled the filter's velocity
    # through zero 4.34 s before apogee; taken as a step (the innovation held still), at apogee,
    # and 0.13 s late since the dead-reckoning guard is calibrated against the barometer (its
    # anchor is one window's barometric rate, here 1.3 m/s fast: D16 rule 7).
    start = supersonic.apogee_time_s - 6.0
    drogue, _ = run(supersonic, fault("transient_midcoast", dh_m=-120.0, start_s=start, rise_s=0.4,
                                      decay_s=1.0, hold_until_s=supersonic.apogee_time_s))
    assert_within(supersonic, drogue, 0.15)


def test_pressure_step_inside_the_gate_in_the_late_coast(subsonic):
    # -60 m within 0.4 s, 3 s before apogee, held: inside the 50 m gate once the filter follows
    # it, and within the accelerometer's bounds; the late-coast filter (barometer and -g) pulled
    # its velocity through zero 2.2 s early. The barometer's rate changed by 150 m/s within half
    # a second while the accelerometer's changed by 5: the change test leaves it out.
    start = subsonic.apogee_time_s - 3.0
    drogue, _ = run(subsonic, fault("transient_midcoast", dh_m=-60.0, start_s=start, rise_s=0.4,
                                    decay_s=1.0, hold_until_s=subsonic.apogee_time_s))
    assert_within(subsonic, drogue, 0.1)


@pytest.mark.parametrize("rocket, phase, after_s", [("subsonic", "coast", 2.0), ("supersonic", "boost", -1.5),
                                                   ("supersonic", "coast", 2.0),
                                                   ("model_rocket", "coast", 0.5)])
def test_baro_only_barometer_frozen_under_its_noise_holds_the_apogee(rocket, phase, after_s, request):
    """A barometer-only board whose barometer freezes under its noise (no reading repeats): its
    rate stops falling by g every second, and after windows that did not fall (0.5 s and one more
    window per 50 mm/s of the part's noise) the filter's apogee waits for one that does, at worst
    the backup timer (docs/DESIGN.md D16 rule 20). Before the rule: 9.7 s early (subsonic), 13.6
    and 10.8 s early (the K1000-class flight, frozen in the boost and in coast). The model rocket
    frozen 0.5 s after burnout at 90 m/s fired 4.8 s early at 52 m/s with a count of 2.5 s, with a
    pad noise learnt from the climb's beginning, or with a coast noise learnt from the burnout."""
    traj = request.getfixturevalue(rocket)
    drogue, _ = run(traj, fault("baro_frozen_noisy", phase=phase, start_s=traj.burnout_time_s + after_s),
                    board="baro")
    assert_not_early(traj, drogue)


@pytest.mark.parametrize("rocket, before_s, seed", [("supersonic", 1.8, 7), ("supersonic", 2.0, 7),
                                                    ("subsonic", 1.8, 8)])
def test_a_barometer_frozen_under_its_noise_near_apogee_does_not_pull_the_filter_through_zero(
        rocket, before_s, seed, request):
    """Both sensors, a barometer frozen under its noise 1.8 to 2 s before apogee (at 18 to 20
    m/s): its rate drops to zero within a window, too little for the change test and too close to
    apogee for the drift test, and the filter, pulled down, crossed zero 0.56 to 0.69 s early. The
    filter's velocity then fell faster than the accelerometer's track allows, while the velocity
    of 1.5 s before, carried on by the track, still climbed, and the frozen rate stood still
    against the track's fall: no apogee (docs/DESIGN.md D16 rule 22). Measured: 0.17 to 0.37 s
    late; without the carried velocity's bound up to 0.78 s."""
    traj = request.getfixturevalue(rocket)
    drogue, _ = run(traj, fault("baro_frozen_noisy", phase="apogee", start_s=traj.apogee_time_s - before_s),
                    seed=seed)
    assert_within(traj, drogue, 0.5)


def test_an_accelerometer_reading_zeros_near_apogee_does_not_hold_the_filter(subsonic):
    """A failed bus returns zeros from 3 s before apogee: the track then misses the drag, and the
    filter, on the truthful barometer, falls faster than that track; rule 22 without its
    stillness test held its apogee 0.72 s. A truthful barometer's rate falls with the coast
    (measured: 0.00 s)."""
    drogue, _ = run(subsonic, fault("accel_zeroed", phase="coast", start_s=subsonic.apogee_time_s - 3.0,
                                    until_s=None))
    assert_within(subsonic, drogue, 0.1)


def test_baro_only_frozen_barometer_never_fires_early(subsonic):
    drogue, _ = run(subsonic, fault("baro_frozen", phase="coast", start_s=subsonic.burnout_time_s + 2.0),
                    board="baro")
    assert_not_early(subsonic, drogue)


# --- the tool -----------------------------------------------------------------------------------


def test_user_settings_follow_config_md(subsonic, supersonic):
    """docs/CONFIG.md's recipes: backup timer at apogee + 3 s, main_delay_s the time from apogee
    to the main altitude, main_backup_s 3 s less, mach_lockout_s (barometer-only boards) the time
    the flight slows below Mach 0.8 + 3 s, and none for a rocket that never reaches Mach 0.8."""
    sub = bench.user_settings(subsonic, MAIN_M)
    assert sub["backup_drogue_s"] == round(subsonic.apogee_time_s + 3.0, 1)
    at_main_s = subsonic.apogee_time_s + sub["main_delay_s"]
    assert abs(np.interp(at_main_s, subsonic.time_s, subsonic.altitude_m) - MAIN_M) < 2.0  # 20 m/s x 0.05 s
    assert sub["main_backup_s"] == round(sub["main_delay_s"] - 3.0, 1)
    assert "baro" not in sub
    sup = bench.user_settings(supersonic, None)
    assert "main_delay_s" not in sup
    lockout_s = sup["baro"]["mach_lockout_s"] - 3.0
    assert np.interp(lockout_s, supersonic.time_s, supersonic.mach) == pytest.approx(0.8, abs=0.01)
    assert lockout_s > supersonic.burnout_time_s


def test_unknown_rocket_is_a_one_line_error(capsys):
    assert bench.main(["--rockets", "saturn_v"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: unknown rocket 'saturn_v'") and err.count("\n") == 1


@pytest.mark.parametrize("option, value", [("--classes", "gremlins"), ("--boards", "accel"),
                                           ("--methods", "eggtimer")])
def test_unknown_class_board_or_method_is_a_one_line_error(capsys, option, value):
    assert bench.main([option, value]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: unknown %s '%s'" % (option[2:-1].replace("classe", "class"), value))
    assert err.count("\n") == 1


def test_resume_from_an_unreadable_rows_file_is_a_one_line_error(tmp_path, capsys):
    rows = tmp_path / "rows.jsonl"
    rows.write_text('{"rocket": "c6_model"\n')
    assert bench.main(["--resume", str(rows)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --resume %s: cannot read the rows" % rows) and err.count("\n") == 1


def test_a_selection_runs_only_its_classes_boards_and_methods(subsonic, monkeypatch):
    monkeypatch.setattr(bench, "trajectory", lambda *a: subsonic)
    user = bench.user_settings(subsonic, MAIN_M)
    rows = bench.evaluate(("k400_dual_deploy", 2, 0, [0], 1, None, user, subsonic.max_mach,
                           (["baro"], ["transient_midcoast"], ["flight-computer"])))
    assert [(r["class"], r["board"], r["method"]) for r in rows] == [
        ("transient_midcoast", "baro", "flight-computer")]


def test_summarize_counts_early_and_missed_drogues_per_class_and_method(tmp_path, capsys):
    rows = tmp_path / "rows.jsonl"
    base = {"rocket": "c6_model", "board": "both", "flight": 0, "trajectory": 0, "true_apogee_s": 8.0,
            "main_set_m": None, "fault": {}, "drogue_s": 7.0, "main_s": None, "speed_at_drogue_mps": 9.5,
            "altitude_at_main_m": None}
    lines = [dict(base, **{"class": "none", "method": m, "error_s": -1.0}) for m in bench.METHODS]
    lines.append(dict(base, **{"class": "baro_lost", "method": "altos", "error_s": None, "drogue_s": None,
                               "speed_at_drogue_mps": None}))
    rows.write_text("".join(json.dumps(r) + "\n" for r in lines))
    assert bench.main(["--summarize", str(rows), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)["summary"]
    none_fc = [s for s in summary if s["class"] == "none" and s["method"] == "flight-computer"][0]
    assert none_fc["early"] == 1 and none_fc["missed"] == 0
    lost = [s for s in summary if s["class"] == "baro_lost"][0]
    assert lost["missed"] == 1
    # a later file's run replaces the earlier one of the same rocket, class, board, method and flight
    later = tmp_path / "later.jsonl"
    later.write_text(json.dumps(dict(lines[0], error_s=0.01, drogue_s=8.01)) + "\n")
    assert bench.main(["--summarize", str(rows), str(later), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)["summary"]
    none_fc = [s for s in summary if s["class"] == "none" and s["method"] == "flight-computer"][0]
    assert none_fc["early"] == 0 and none_fc["flights"] == 1


@pytest.fixture(scope="module")
def bench_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("fault_cache")


def _bench_row(bench_cache, name, flight, kind, **config):
    """The fault benchmark's run of rocket ``name``, flight ``flight``, class ``kind``, both
    sensors, flight computer, with the user settings docs/CONFIG.md gives (and ``config``)."""
    from desktop.io.rocket_file import load_rocket

    nominal = bench.trajectory(name, 1, None, bench_cache)
    spec = load_rocket(bench._rocket_path(name))
    main_m = spec.main.deploy_altitude_m if spec.main is not None else None
    user = dict(bench.user_settings(nominal, main_m), **config)
    rows = bench.evaluate((name, bench.ROCKETS.index(name), flight % bench.DEFAULT_TRAJECTORIES, [flight], 1,
                           bench_cache, user, nominal.max_mach, (("both",), {kind}, ("flight-computer",))))
    (row,) = [r for r in rows if r["class"] == kind]
    return row


@pytest.mark.parametrize("config, early", [
    ({}, False),
    ({"dead_reckoning_guard_mps": 50}, False),
    ({"dead_reckoning_guard_mps": 50, "baro_ballistic_mps": 0}, True),
], ids=["guard_and_floor", "floor", "neither"])
def test_a_floor_set_at_the_exclusion_holds_a_decay_without_the_dead_reckoning(bench_cache, config, early):
    """The fault benchmark's K400, flight 138, both sensors: +283 m within 0.43 s, 7.5 s before
    apogee, decaying over 2.5 s. Left out, taken back 4 s later with its decay still lying by about
    25 m/s; rule 9's wait yields to the dead-reckoning guard. From the filter's velocity at the
    anchor and its bias estimate the guard's velocity was 7.5 m/s below the true one: 0.78 s
    early, and the ballistic floor set at the exclusion, with the drag the accelerometer measured,
    held it to 0.46 s early. Calibrated against the barometer (D16 rule 7) the guard holds it to
    0.10 s early; with the guard off (`dead_reckoning_guard_mps` beyond any velocity here) the
    floor alone holds it to 0.48 s early, and neither 1.29 s early."""
    row = _bench_row(bench_cache, "k400_dual_deploy", 138, "transient_midcoast", **config)
    assert abs(row["fault"]["dh_m"] - 282.6) < 0.1  # the flight traced in docs/DESIGN.md
    assert (row["error_s"] < -EARLY_S) == early


def test_a_filter_converging_after_a_transient_is_not_held_as_one_pulled_down(bench_cache):
    """The fault benchmark's J360, flight 102, both sensors: +236 m held from 11.7 s (airbrakes)
    to 16.4 s. The filter, pulled 7 m/s fast by the transient's onset, converges to the truth and
    crosses zero at the apogee, its fall then leading the track's by more than the margin, as a
    filter pulled down by a frozen barometer does; but the barometer's rate falls with the coast:
    no hold (D16 rule 22's stillness; without it 2.97 s late, the backup timer)."""
    row = _bench_row(bench_cache, "j360_sport", 102, "transient_midcoast")
    assert abs(row["fault"]["dh_m"] - 236.1) < 0.1  # the flight traced in docs/BENCHMARKS.md
    assert abs(row["error_s"]) <= 0.1


def test_after_a_clipped_boost_a_barometer_frozen_near_apogee_does_not_pull_the_filter_down(bench_cache):
    """The fault benchmark's C6, flight 111, both sensors: its 16 g part clips in the boost, so the
    track bounds the velocity from below only; frozen under its noise 2.2 s before apogee, the
    barometer pulled the filter through zero 0.81 s early. Rule 22 reads only the track's change
    over 1.5 s, which a clip in the boost leaves whole in coast: 0.14 s late (D16 rule 22)."""
    row = _bench_row(bench_cache, "c6_model", 111, "baro_frozen_noisy")
    assert row["fault"]["phase"] == "apogee"
    assert -EARLY_S <= row["error_s"] <= EARLY_S


def test_a_frozen_barometer_standing_still_is_not_taken_back(bench_cache):
    """The fault benchmark's K400, flight 44, both sensors: frozen under its noise 11.7 s before
    apogee at 140 m/s, its rate fell to zero within 0.3 s and it was left out, while the filter's
    bias estimate, pulled to its bound, left the filter 13 m/s slow. 6.2 s later, reading no
    climb against a velocity carried at 45 to 52 m/s, it came back inside the tolerance the
    track's margin had grown to, and the filter followed it through zero: 1.17 s early at 11 m/s.
    Its rate stood while the track's fell by g: held out (D16 rule 23), the accelerometer-only
    apogee decides, late by the margin grown since the anchor: 1.75 s, before the backup timer."""
    row = _bench_row(bench_cache, "k400_dual_deploy", 44, "baro_frozen_noisy")
    assert row["fault"]["phase"] == "coast"
    assert -EARLY_S <= row["error_s"] < 3.0


def test_a_decay_standing_where_gravity_cancels_it_is_taken_back(bench_cache):
    """The fault benchmark's J360, flight 126, both sensors: +196 m at 11.9 s decaying over 2.7 s.
    Its rate, once the lie's rise had slowed to gravity's fall, stood at -21 to -30 m/s, inside
    the readmission's tolerance: not at zero, so not still (D16 rule 23), and it comes back:
    0.06 s late (1.57 s held out as a frozen reading)."""
    row = _bench_row(bench_cache, "j360_sport", 126, "transient_midcoast")
    assert abs(row["error_s"]) <= 0.3


def test_an_ejection_transient_under_the_drogue_does_not_retire_the_barometer(bench_cache):
    """The fault benchmark's M1670 3 km, flight 107, both sensors: at the drogue the barometer
    jumps about 200 m (the ejection) and decays for seconds, so 10 s after the first descending
    sample it still reads above that sample's reading, though its rate descends at 20 m/s. A
    frozen barometer's rate stands at zero: rule 24 waits for that too (D16 rule 24), and the
    main fires at its altitude (683 m, 283 m high, on the prediction with the altitude test
    alone)."""
    row = _bench_row(bench_cache, "m1670_3km", 107, "transient_burnout")
    assert abs(row["altitude_at_main_m"] - row["main_set_m"]) <= 20


def test_a_transient_held_to_the_drogue_does_not_retire_the_barometer_whose_rate_descends(bench_cache):
    """The fault benchmark's M1670 minimum-diameter, flight 26, both sensors: -297 m from burnout,
    held to the drogue at 34.4 s, then decaying over 1.4 s. Its return and decay hold the reading
    near the first descending sample's for seconds while its rate descends; only a barometer whose
    rate also stands within 2 m/s of zero is retired under the drogue (D16 rule 24). Without the
    rate's condition it was retired, and no main fired in the record (with it: 299 m for 300)."""
    row = _bench_row(bench_cache, "m1670_min_dia", 26, "transient_burnout")
    assert row["altitude_at_main_m"] is not None and abs(row["altitude_at_main_m"] - row["main_set_m"]) <= 20


def test_a_clipped_boost_still_holds_the_filter_while_the_barometer_climbs_as_a_rocket(bench_cache):
    """The fault benchmark's C6, flight 133, both sensors: its part clips in the boost, so the
    track bounds the velocity from below only. 15 m low from 2.3 s before apogee, within 0.4 s,
    held to apogee: inside the filter's gate, the step pulls the filter's velocity 5 m/s low, and
    it fired 0.60 s early with the barometer climbing at 10 m/s as a coasting rocket does. The
    lower tier of D16 rule 17 reads the track's change over a window, not its level, which a clip
    leaves whole in coast: 0.26 s early."""
    row = _bench_row(bench_cache, "c6_model", 133, "transient_midcoast")
    assert abs(row["fault"]["dh_m"] + 14.6) < 0.1  # the flight traced in docs/DESIGN.md
    assert -EARLY_S <= row["error_s"] <= 0.5
