"""The random-rocket benchmark's flight model against closed forms, and one rocket through it."""

import math

import numpy as np
import pytest

from desktop.sim.point_mass import point_mass_flight
from desktop.sim.trajectory import G0, drag_free_vertical
from tools import bench_family


def test_a_vertical_flight_without_drag_is_the_closed_form():
    flight = point_mass_flight(200.0, 2.0, 2.0, 0.0)
    exact = drag_free_vertical(thrust_n=200.0, burn_time_s=2.0, dry_mass_kg=2.0)
    assert flight.apogee_time_s == pytest.approx(exact.apogee_time_s, abs=0.02)  # 1 ms steps
    assert flight.apogee_m == pytest.approx(exact.apogee_m, rel=2e-3)
    # the accelerometer reads the thrust in boost and nothing in a drag-free coast
    boost = flight.time_s < 1.9
    assert np.allclose(flight.accel_mps2[boost], 100.0)
    assert np.allclose(flight.accel_mps2[flight.time_s > 2.1], 0.0)


def test_drag_rail_and_wind_lower_the_apogee_and_drag_decelerates_the_coast():
    vertical = point_mass_flight(200.0, 2.0, 2.0, 0.0)
    dragged = point_mass_flight(200.0, 2.0, 2.0, 0.002)
    tilted = point_mass_flight(200.0, 2.0, 2.0, 0.002, rail_deg=10.0, wind_mps=8.0)
    assert tilted.apogee_m < dragged.apogee_m < vertical.apogee_m
    coast = (dragged.time_s > 2.1) & (dragged.time_s < dragged.apogee_time_s)
    # in coast the axial specific force is the drag: negative, and shrinking as the rocket slows
    assert np.all(dragged.accel_mps2[coast] < 0.0)
    assert dragged.accel_mps2[coast][0] < dragged.accel_mps2[coast][-1]
    # the vertical deceleration exceeds g by the drag (vertical flight)
    dv = np.diff(dragged.velocity_mps[coast]) / np.diff(dragged.time_s[coast])
    assert np.all(dv < -G0 + 1e-6)


def test_a_thrust_that_cannot_leave_the_rail_is_refused():
    with pytest.raises(ValueError):
        point_mass_flight(10.0, 2.0, 2.0, 0.0)


def test_draws_stay_in_their_ranges():
    for i in range(200):
        p = bench_family.draw_rocket(np.random.default_rng([1, i]))
        assert 0.08 <= p["mass_kg"] <= 40.0
        assert 4.0 <= p["thrust_n"] / (p["mass_kg"] * G0) <= 40.0
        assert p["thrust_n"] / p["mass_kg"] * p["burn_s"] <= bench_family.MAX_IDEAL_DV_MPS * (1 + 1e-9)
        assert 0.0 <= p["rail_deg"] <= 15.0 and 0.0 <= p["wind_mps"] <= 10.0


def test_one_random_rocket_fault_free_on_both_boards():
    rows = bench_family.fly_rocket((1, 0, ("none",), ("both", "baro")))
    assert [r["board"] for r in rows] == ["both", "baro"]
    for r in rows:
        assert r["error_s"] is not None and abs(r["error_s"]) <= 0.3
        assert math.isfinite(r["speed_at_drogue_mps"])


def test_a_bad_option_is_one_line_and_exit_2(capsys):
    assert bench_family.main(["--classes", "nonsense"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: unknown class 'nonsense'") and err.count("\n") == 1


def test_a_track_ended_in_boost_waits_as_without_an_accelerometer():
    """Seed 4's rocket 149: 8 kg at 34 g for 3.1 s on a 16 g part, the fault clipping it lower
    still. Until 2026-12-05 the part, missing one reading after its clip, was judged frozen for
    that sample, which ended its track for the flight, and the filter ran on the barometer alone
    while the health called the accelerometer usable again; its apogee then waited as on a
    barometer-only board (docs/DESIGN.md D16 rule 11; without the wait the filter, ringing from
    the boost, fired 3.2 s early at 35 m/s). Now such a sample is judged as the clip and the
    track runs on: 0.26 s late (the rule's own test is now a part that stalls in the boost:
    tests/shared/test_arbitration.py)."""
    (row,) = bench_family.fly_rocket((4, 149, ("accel_clipped",), ("both",)))
    assert -0.5 <= row["error_s"] <= 1.0


def test_an_accelerometer_reading_zeros_from_the_boost_leaves_the_proof_to_the_barometer():
    """Seed 13's rocket 17: 0.11 kg at 5 N for 2 s, to 308 m; its accelerometer reads zeros
    from 0.73 to 4.84 s (a failed bus). The barometer, in use, climbs at up to 70 m/s while the
    part holds zero: no drag, no part. Its account (27 m/s, 46 m) neither agreed with the
    barometer's 300 m nor reached 100 m, and the flight was never proven: no drogue. Before the
    proof, rule 14's held zero retires the part whether or not the barometer is left out (D13,
    D16 rule 14), and the barometer proves the flight alone: 0.05 s late."""
    (row,) = bench_family.fly_rocket((13, 17, ("accel_zeroed",), ("both",)))
    assert row["error_s"] is not None and -0.5 <= row["error_s"] <= 0.3


def test_an_accelerometer_that_read_zeros_in_a_low_boost_never_fires_early():
    """Seed 7's rocket 11: 0.2 kg at 12 g, its accelerometer reading zeros from 0.6 to 1.5 s of
    the boost. The track reads the boost 60 m/s slow and the barometer is left out. The change
    test's noise, learnt in flight while the two parted, grew to 14 m/s; the barometer, taken back
    4.2 s before apogee on that noise, climbing at 48 m/s, let the filter through 4.2 s early at
    45 m/s until the hold of D16 rule 17 counted the noise learnt on the pad (0.25 m/s): then 0.4 s
    after apogee. Since the change test's noise stops learning at burnout (D16 rule 20; here the
    zeros end the boost at 1.0 s) the barometer, 60 m/s off the accelerometer's account, is not
    taken back, and at 565 m the rocket is too low to part from it beyond any barometric error
    (rule 14): the backup timer fires, 3.0 s late. Never early."""
    (row,) = bench_family.fly_rocket((7, 11, ("accel_zeroed",), ("both",)))
    assert -0.5 <= row["error_s"] <= 3.1


def test_a_barometer_returning_faster_than_20_mps_holds_the_filter_whatever_its_rate_does():
    """Seed 6's rocket 206: 279 m, 272 m low 0.4 s after burnout, decaying over 2.8 s. The filter,
    pulled down before the barometer was left out, carries on 10 m/s slow; the barometer is taken
    back at 47 m/s, decaying, with the rocket at 9 m/s. Both lie, on either side. A return
    decaying is no climb (D16 rule 17), but above 20 m/s the rule holds whatever the rate does:
    1.86 s late (0.89 s early without that tier)."""
    (row,) = bench_family.fly_rocket((6, 206, ("transient_burnout",), ("both",)))
    assert -0.5 <= row["error_s"] <= 2.5


def test_the_wait_goes_on_while_the_filter_blames_the_accelerometer_for_a_decay():
    """Seed 5's rocket 27: 13 kg at 21 g for 1 s, +211 m from 1.15 s, decaying with a time
    constant of 2.3 s. Taken back reading slow, the barometer still lies by 8 m/s at 7 s; the
    filter, its bias estimate at its upper bound, runs 16 m/s slow, and fired 1.50 s early at
    15 m/s when baro_settle_s ended. The wait goes on while the filter blames the accelerometer
    that much and the accelerometer's own account, 5 m/s fast there, still climbs (docs/DESIGN.md
    D16 rule 9): 0.40 s late."""
    (row,) = bench_family.fly_rocket((5, 27, ("transient_burnout",), ("both",)))
    assert -0.5 <= row["error_s"] <= 1.0


def test_the_wait_for_the_accelerometers_account_needs_a_track_that_did_not_clip():
    """Seed 6's rocket 47: 0.15 kg at 32 g on a 16 g part, +169 m in mid coast. After the clip
    the track and the account carried by it read 95 m/s slow and 21 m/s fast at apogee: no
    measure of the motion. The wait of D16 rule 9 does not go on for it: 0.05 s early; 2.09 s late
    if it did."""
    (row,) = bench_family.fly_rocket((6, 47, ("transient_midcoast",), ("both",)))
    assert -0.5 <= row["error_s"] <= 1.0


def test_a_barometer_frozen_in_a_clipped_boost_holds_the_apogee():
    """Seed 5's rocket 215: 35 kg at 39 g for 1.8 s on a 16 g part, Mach 1.8, its barometer frozen
    under its noise 0.1 s before burnout. The clipped track reads 245 m/s at burnout against
    593 m/s; the barometer, taken back 4.6 s after launch 20 m above the filter that track
    carried while the rocket climbed at 442 m/s 1.6 km higher, pulled the filter through zero:
    20.0 s early at 218 m/s. Standing still for 2.5 s of windows, it holds the apogee
    (docs/DESIGN.md D16 rule 20): the backup timer, 3.1 s late."""
    (row,) = bench_family.fly_rocket((5, 215, ("baro_frozen_noisy",), ("both",)))
    assert -0.5 <= row["error_s"] <= 3.2


def test_a_clipped_part_missing_a_reading_keeps_its_track():
    """Seed 8's rocket 82: 1.2 kg at 23 g for 4.9 s on a 16 g part, Mach 2.5. Clipped for 3.1 s,
    the part misses one reading (5 in that flight); judged frozen on that sample, its track ended
    for the flight, and the barometer, frozen under its noise from 4.4 s, decided alone: 26.6 s
    early at 299 m/s. A sample without a reading after a clip is judged as the clip
    (docs/DESIGN.md D16, sensor health): the track runs on, and the barometer's stillness holds
    the apogee to the backup timer, 3.2 s late."""
    (row,) = bench_family.fly_rocket((8, 82, ("baro_frozen_noisy",), ("both",)))
    assert -0.5 <= row["error_s"] <= 3.2


def test_a_barometer_frozen_near_apogee_is_left_out_by_its_drift():
    """Seed 5's rocket 117: 2.1 kg at 32 g for 1.1 s on a 200 g part, its barometer frozen under
    its noise 4.7 s before apogee at 46 m/s. The rate falls to zero within a window, inside the
    change test's 30 m/s and the track's 110 m/s margin, and the filter followed it through zero:
    2.82 s early at 28 m/s. The barometer's rate fell faster than the track's over 1.5 s for ten
    windows in a row, and it is left out (docs/DESIGN.md D16 rule 21). Taken back reading no
    climb, 0.06 s late; standing still, it stays out (rule 23) and the accelerometer-only apogee
    decides, late by the margin grown since the anchor: 2.04 s, before the backup timer."""
    (row,) = bench_family.fly_rocket((5, 117, ("baro_frozen_noisy",), ("both",)))
    assert -0.5 <= row["error_s"] <= 3.2


def test_the_drift_is_judged_over_the_barometers_own_use():
    """Seed 6's rocket 297: 1 kg to 99 m, +101 m at burnout held to apogee. The barometer is left
    out for the transient's rise and taken back at 2.2 s; judged against a window of the time it
    was out (its rate then 170 m/s off), it read a drift of 168 m/s and was left out again, the
    flight was never proven, and no drogue fired. The drift test judges only windows of the
    barometer's own use (docs/DESIGN.md D16 rule 21): 0.02 s late."""
    (row,) = bench_family.fly_rocket((6, 297, ("transient_burnout",), ("both",)))
    assert row["error_s"] is not None and abs(row["error_s"]) <= 0.3


def test_a_decay_taken_back_is_no_drift():
    """Seed 7's rocket 10: a burnout transient decaying after the barometer was taken back (its
    decay inside baro_readmit_mps). Judged from half a second after the agreement that took it
    back began, the end of the decay read as a drift, the truthful barometer was left out again,
    and the drogue came 2.29 s late. The drift test judges from 3.5 s after (docs/DESIGN.md D16
    rule 21): 0.51 s late, as before the test."""
    (row,) = bench_family.fly_rocket((7, 10, ("transient_burnout",), ("both",)))
    assert -0.5 <= row["error_s"] <= 1.0


def test_a_static_port_error_decaying_at_speed_is_no_drift():
    """Seed 5's rocket 31: 0.13 kg at 28 g for 0.8 s on a 16 g part, Mach 0.6, a static-port error
    of 7.2 % of pressure at Mach 1 (sigma 0.26 in Mach). As the rocket slows its decay moves the
    barometer's rate against the clipped track by more than 5 m/s over 1.5 s; judged at that
    speed from half a second after the barometer was taken back, it was left out, and the
    accelerometer could not bring the apogee: the backup timer, 2.97 s late. The drift test judges
    a slow rocket only, and from 3.5 s after a readmission (docs/DESIGN.md D16 rule 21; either
    holds this flight): 0.06 s late."""
    (row,) = bench_family.fly_rocket((5, 31, ("transonic_up",), ("both",)))
    assert -0.5 <= row["error_s"] <= 0.3


def test_an_accelerometer_reading_zeros_drifts_no_truthful_barometer_out():
    """Seed 5's rocket 23: an accelerometer reading zeros from 6.2 s in coast, 7.5 s before apogee.
    Its track then leaves out the drag, and the truthful barometer's rate falls faster than the
    track's by the drag: judged on 5 m/s and the margin alone, the drift test left the barometer
    out near apogee and the accelerometer-only apogee came 1.41 s late. Three times the learnt
    noise of the change test on top covers the drag of a slow rocket, and the test judges only
    below 50 m/s, where the drag is small (docs/DESIGN.md D16 rule 21): 0.01 s late."""
    (row,) = bench_family.fly_rocket((5, 23, ("accel_zeroed",), ("both",)))
    assert -0.5 <= row["error_s"] <= 0.3


@pytest.mark.parametrize("seed, rocket", [(5, 54), (5, 12), (6, 204)],
                         ids=["slow", "mach1.5", "in_the_boost"])
def test_a_barometer_only_board_frozen_early_in_the_coast_holds_the_apogee(seed, rocket):
    """Barometer-only boards whose barometer freezes under its noise in the coast's first 1.5 s
    (seed 5's rocket 54, 0.5 s after burnout at 76 m/s; rocket 12, Mach 1.5, 0.6 s after its
    Mach lockout ended at 123 m/s), before the coast's windows hold the drag law the ballistic
    floor needs: the change test fails for the freeze's fall, but no floor is set, and the
    filter, pulled to the frozen rate, crossed zero before the stillness count completed: 5.2 and
    7.4 s early at 55 and 82 m/s. A run of failures without a floor holds the apogee until a
    window clean of it falls as a coast (docs/DESIGN.md D16 rule 10): the backup timer. Seed 6's
    rocket 204 (24.5 kg, subsonic) froze 1.5 s into its 2.4 s boost: the filter, pulled to the
    frozen rate, crossed zero 1.3 s into the coast, before the stillness count's 2.5 s, and fired
    15.9 s early at 206 m/s; standing at zero, a quiet part's count completes in 0.8 s (D16 rule
    20): the backup timer."""
    (row,) = bench_family.fly_rocket((seed, rocket, ("baro_frozen_noisy",), ("baro",)))
    assert -0.5 <= row["error_s"] <= 4.0


def test_a_barometer_frozen_in_a_clipped_boost_leaves_the_proof_to_the_accelerometers_account():
    """Seed 21's rocket 151: 0.53 kg at 36 g for 0.7 s on a 16 g part, to 557 m; its barometer
    freezes (repeating its reading) 0.3 s into the boost. Before it was judged stuck (1.8 s) it
    pulled the filter to 42 m, and the filter then fell with the clipped track: the
    accelerometer-only proof, on the filter's climb, never held, and nothing fired. The
    accelerometer's own account, a lower bound after a clip (91 m, 88 m/s), proves the flight
    (docs/DESIGN.md D13), and a clipped track leaves the drogue to the backup timer: 3.1 s late,
    never early."""
    (row,) = bench_family.fly_rocket((21, 151, ("baro_frozen",), ("both",)))
    assert row["error_s"] is not None and 0 <= row["error_s"] <= 3.5


def test_a_barometer_frozen_under_its_noise_in_the_mach_lockout_holds_the_apogee():
    """Seed 23's rocket 103 on a barometer-only board: 0.9 kg at 16 g for 6.5 s, Mach 0.98, its
    mach_lockout_s 3 s after it slows below Mach 0.8. Its barometer froze under its noise 0.7 s
    before the lockout ended, at 120 m/s: the filter fell to zero within the lockout, where the
    coast's ballistic test does not run, and its first windows after it only carried on the
    fall's deceleration; the stillness count needs 1 s of still windows, the filter's apogee
    came first: 6.87 s early at 82 m/s. The lockout's end holds the apogee until a clean window
    of the coast falls as a coast (docs/DESIGN.md D16 rule 10): the backup timer."""
    (row,) = bench_family.fly_rocket((23, 103, ("baro_frozen_noisy",), ("baro",)))
    assert row["error_s"] is not None and -0.5 <= row["error_s"] <= 4.0


def test_an_unwritable_rows_file_is_one_line_and_exit_2(tmp_path, capsys):
    assert bench_family.main(["--rockets", "1", "--rows", str(tmp_path / "no" / "rows.jsonl")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --rows ") and err.count("\n") == 1
