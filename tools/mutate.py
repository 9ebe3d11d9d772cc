"""Mutation testing of the safety rules: remove each named rule in turn and check that a test fails.

    python tools/mutate.py            # every mutant; prints a table and the score
    python tools/mutate.py --list     # the mutants, without running anything
    python tools/mutate.py NAME...    # only these mutants
    python tools/mutate.py --json     # the results as JSON

Each mutant is one edit of the source (file, original text, mutated text): the rule removed, as a
careless change would remove it. The repository is copied once to a temporary directory and every
mutant is applied to the copy (the working tree is never touched). A mutant is killed when its
named test (the row of the safety-invariants table in docs/DESIGN.md) fails; a mutant that survives
its named test is run against the whole fast lane (tests/shared, not slow, not MicroPython) before
it counts as a survivor. Score = killed / mutants. docs/DESIGN.md says why each survivor survives.
"""

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FLIGHT = "shared/flight.py"
HEALTH = "shared/health.py"
PADCAL = "shared/padcal.py"
ARB = "shared/arbitration.py"
BALLISTIC = "shared/ballistic.py"
PAD_TESTS = "tests/shared/test_pad_launch_proof.py"
FLIGHT_TESTS = "tests/shared/test_flight.py"
ARB_TESTS = "tests/shared/test_arbitration.py"
BALLISTIC_TESTS = "tests/shared/test_ballistic.py"
BACKUP_TESTS = "tests/shared/test_backup_charges.py"
STAGING_TESTS = "tests/shared/test_staging.py"
FAST_LANE = [FLIGHT_TESTS, PAD_TESTS, ARB_TESTS, BALLISTIC_TESTS, BACKUP_TESTS, STAGING_TESTS, "-m",
             "not slow and not micropython"]

# (name, file, original, mutated, test that must fail)
MUTANTS = [
    ("drogue-needs-proof", FLIGHT,
     "if fc.flight_proven and fc.drogue_fired_ms < 0:",
     "if fc.drogue_fired_ms < 0:",
     FLIGHT_TESTS + "::test_knock_with_pressure_step_never_fires"),
    ("main-needs-proof", FLIGHT,
     "if not fc.flight_proven or since_ms < cfg.main_guard_ms:",
     "if since_ms < cfg.main_guard_ms:",
     PAD_TESTS + "::test_main_needs_proof_of_flight"),
    ("main-guard-time", FLIGHT,
     "if not fc.flight_proven or since_ms < cfg.main_guard_ms:",
     "if not fc.flight_proven:",
     PAD_TESTS + "::test_under_performing_flight_opens_the_main_after_the_guard"),
    ("proof-climb-held", FLIGHT,
     "proven = fc.climb_ms >= _PROOF_HOLD_MS",
     "proven = True",
     FLIGHT_TESTS + "::test_stuck_and_garbage_sensors_never_fire"),
    ("proof-accel-speed", FLIGHT,
     "proven = proven and fc.acc_dv_max_mmps >= cfg.proof_speed_mmps",
     "proven = proven",
     PAD_TESTS + "::test_shove_with_pressure_offset_never_fires"),
    ("baro-back-fast-takes-rate", FLIGHT,
     "                    kf.vel_q4 = arb.baro_rate_mmps << 4\n",
     "                    pass\n",
     "tests/tools/test_bench_faults.py"
     "::test_a_barometer_taken_back_climbing_faster_than_the_filter_gives_it_its_rate"),
    ("baro-back-fast-only-after-clip", FLIGHT,
     "            if state == COAST and not arb.upper_valid:\n",
     "            if state == COAST:\n",
     "tests/desktop/test_replay_altos.py::test_anomalous_flight_within_its_window"),
    ("reanchor-distance-afresh", FLIGHT,
     "            self.resid_sq_avg_q4 = 0\n",
     "",
     "tests/tools/test_bench_faults.py"
     "::test_a_barometer_taken_back_climbing_faster_than_the_filter_gives_it_its_rate"),
    ("proof-heights-agree", FLIGHT,
     "return -_AGREE_MM - (baro_mm >> 2) <= diff and (",
     "return True or -_AGREE_MM - (baro_mm >> 2) <= diff and (",
     FLIGHT_TESTS + "::test_knock_with_pressure_step_never_fires"),
    ("proof-heights-agree-since-back", FLIGHT,
     "held = climb_mm >= line_mm and _climbs_agree(\n"
     "                climb_mm, fc.acc_h_mm - fc.proof_ref_acc_mm, clipped)",
     "held = climb_mm >= line_mm",
     PAD_TESTS + "::test_a_knock_a_pressure_step_taken_back_and_a_climbing_pressure_never_fire"),
    ("proof-climbs-since-back", FLIGHT,
     "            climb_mm -= fc.proof_ref_baro_mm\n",
     "",
     "tests/tools/test_bench_faults.py::test_an_offset_held_from_burnout_still_proves_the_flight"),
    ("proof-baro-only-climb", FLIGHT,
     "line_mm = cfg.proof_climb_mm if accel_ok else cfg.proof_baro_climb_mm",
     "line_mm = cfg.proof_climb_mm",
     PAD_TESTS + "::test_barometer_only_offset_between_proof_and_rebase_never_fires"),
    ("proof-baro-only-speed", FLIGHT,
     "    elif baro_ok:\n        proven = proven and fc.max_vel_mmps >= cfg.proof_speed_mmps",
     "    elif baro_ok:\n        proven = proven",
     PAD_TESTS + "::test_barometer_only_slow_climb_never_proves"),
    ("proof-accel-only-boost", FLIGHT,
     "and fc.boost_max_ms >= _ACCEL_ONLY_BOOST_MS)",
     ")",
     FLIGHT_TESTS + "::test_knocks_never_fire"),
    ("proof-sensor-fallback", FLIGHT,
     "    else:\n        proven = False\n    fc.flight_proven = proven",
     "    else:\n        proven = False\n    proven = proven and accel_ok and baro_ok\n"
     "    fc.flight_proven = proven",
     PAD_TESTS + "::test_barometer_lost_before_proof_falls_back_to_the_accelerometer"),
    ("sensor-lost-baro", HEALTH,
     "ok = age < lost_ms\n        if not ok:\n            flags |= HEALTH_BARO_LOST",
     "ok = True\n        if not ok:\n            flags |= HEALTH_BARO_LOST",
     PAD_TESTS + "::test_barometer_lost_before_proof_falls_back_to_the_accelerometer"),
    ("sensor-lost-accel", HEALTH,
     "ok = age < lost_ms\n        if not ok:\n            flags |= HEALTH_ACCEL_LOST",
     "ok = True\n        if not ok:\n            flags |= HEALTH_ACCEL_LOST",
     PAD_TESTS + "::test_accelerometer_lost_before_proof_falls_back_to_the_barometer"),
    ("apogee-decel-gate", FLIGHT,
     "and cfg.coast_decel_mmps2 << 4 <= -fc.acc_avg_q4 <= _APOGEE_DECEL_MAX_MMPS2 << 4",
     "",
     "tests/desktop/test_replay_altos.py"),
    ("apogee-measured-coast", FLIGHT,
     "and (fc.coast_measured or not accel_ok)\n",
     "\n",
     PAD_TESTS + "::test_apogee_gate_uses_the_measured_acceleration_not_the_coast_clamp"),
    ("apogee-only-in-coast", FLIGHT,
     "            if state == COAST:\n                bal = self.arb.ballistic\n",
     "            if True:\n                bal = self.arb.ballistic\n",
     ARB_TESTS + "::test_no_apogee_within_the_mach_time_lockout"),
    ("apogee-needs-proof", FLIGHT,
     "return (fc.flight_proven and fc.drogue_fired_ms < 0",
     "return (fc.drogue_fired_ms < 0",
     PAD_TESTS + "::test_apogee_needs_proof_of_flight"),
    ("apogee-above-proof-climb", FLIGHT,
     "and fc.agl_mm >= cfg.proof_climb_mm\n",
     "\n",
     PAD_TESTS + "::test_no_apogee_on_the_ground_after_a_lockout_that_outlasted_the_flight"),
    ("resume-settle", FLIGHT,
     "and now_ms >= fc.settle_until_ms",
     "",
     PAD_TESTS + "::test_resume_settles_before_apogee_after_an_overestimated_reset"),
    ("mach-lockout", FLIGHT,
     "fast = (kf.vel_q4 >> 4 > cfg.mach_lockout_mmps\n",
     "fast = (False\n",
     FLIGHT_TESTS + "::test_apogee_delay_and_no_fire_through_mach"),
    ("baro-full-weight-when-alone", FLIGHT,
     "if state >= DROGUE or not mode & MODE_ACCEL or over <= 0:",
     "if state >= DROGUE or over <= 0:",
     "tests/tools/test_bench_faults.py::test_the_only_sensor_left_keeps_its_full_weight_through_mach"),
    ("baro-only-apogee-tracks", FLIGHT,
     "or (accel_ok or fc.resid_sq_avg_q4 < cfg.baro_track_sq_q4\n",
     "or (accel_ok or True\n",
     "tests/tools/test_bench_faults.py::test_baro_only_apogee_waits_for_the_filter_to_track_the_barometer"),
    ("baro-only-apogee-settles", FLIGHT,
     "and now_ms - fc.off_baro_ms >= cfg.baro_settle_ms))",
     "))",
     "tests/tools/test_bench_faults.py::"
     "test_baro_only_apogee_waits_for_the_filter_to_settle_after_it_was_off_the_barometer"),
    ("a-clipped-boost-waits-for-the-filter-to-settle", FLIGHT,
     "and (accel_ok and (arb.upper_valid or not arb.valid and fc.settle_until_ms)",
     "and (accel_ok",
     "tests/tools/test_bench_faults.py::test_a_clipped_boost_waits_for_the_filter_to_settle"),
    ("the-wait-spares-a-resumed-filter", FLIGHT,
     "or not arb.valid and fc.settle_until_ms)",
     ")",
     PAD_TESTS + "::test_resume_settles_before_apogee_after_an_overestimated_reset"),
    ("a-track-ended-by-a-fault-waits-too", FLIGHT,
     "or not arb.valid and fc.settle_until_ms)",
     "or not arb.valid)",
     "tests/tools/test_bench_family.py::test_a_track_ended_in_boost_waits_as_without_an_accelerometer"),
    ("a-clip-is-a-run-of-readings", HEALTH,
     "if (health._clip_held_n >= _CLIP_HOLD_N\n",
     "if (True\n",
     ARB_TESTS + "::test_two_equal_readings_either_side_of_a_gap_are_no_clip"),
    ("a-clipped-account-short-of-the-proof-speed-proves-nothing", FLIGHT,
     "fc.acc_clipped and fc.acc_dv_max_mmps < cfg.proof_speed_mmps)",
     "False)",
     "tests/tools/test_bench_faults.py::"
     "test_a_low_flight_whose_accelerometer_clipped_is_proven_by_the_barometer"),
    ("baro-only-apogee-decelerates-at-g", FLIGHT,
     "and -fc.acc_avg_q4 <= _BARO_APOGEE_DECEL_MAX_MMPS2 << 4)",
     "and True)",
     "tests/tools/test_bench_faults.py::test_baro_only_apogee_needs_a_coasting_deceleration"),
    ("apogee-waits-for-the-ballistic-floor", FLIGHT,
     "enabled = _apogee_enabled(self, cfg, now_ms) and not bal.holds",
     "enabled = _apogee_enabled(self, cfg, now_ms)",
     BALLISTIC_TESTS + "::test_the_floor_holds_a_transients_decay_off_apogee"),
    ("ballistic-floor-at-the-exclusion", FLIGHT,
     "ballistic.set_from_track(arb.ballistic, arb, now_ms)",
     "pass",
     "tests/tools/test_bench_faults.py::"
     "test_a_floor_set_at_the_exclusion_holds_a_decay_the_dead_reckoning_misses"),
    ("ballistic-nothing-lifts-a-coasting-rocket", BALLISTIC,
     "if -most - tol <= change <= -least + tol:",
     "if -most - tol <= change:",
     BALLISTIC_TESTS + "::test_a_rate_that_rises_or_falls_beyond_the_coast_fails"),
    ("ballistic-its-deceleration-does-not-grow", BALLISTIC,
     "if -most - tol <= change <= -least + tol:",
     "if change <= -least + tol:",
     BALLISTIC_TESTS + "::test_a_rate_that_rises_or_falls_beyond_the_coast_fails"),
    ("ballistic-a-fault-fails-a-run-of-windows", BALLISTIC,
     "elif bal.run >= _RUN and bal.floor_set:",
     "if bal.floor_set:",
     BALLISTIC_TESTS + "::test_a_single_slot_off_sets_no_floor"),
    ("ballistic-floor-from-clean-windows", BALLISTIC,
     "clean = now_ms - bal.fail_ms >= _CLEAN_MS",
     "clean = True",
     BALLISTIC_TESTS + "::test_no_floor_from_windows_that_held_an_earlier_failure"),
    ("ballistic-floor-needs-a-drag-law", BALLISTIC,
     "and clean and bal.windows >= _LAW_WINDOWS:",
     "and clean:",
     BALLISTIC_TESTS + "::test_no_floor_before_the_coast_has_a_drag_law"),
    ("ballistic-floor-below-the-rate", BALLISTIC,
     "_set_floor(bal, r[_R1] - _NOISE_K * noise // 2,",
     "_set_floor(bal, r[_R1] + _NOISE_K * noise // 2,",
     BALLISTIC_TESTS + "::test_the_floor_stays_under_the_coast_and_reaches_zero_near_its_apogee"),
    ("apogee-waits-after-the-barometer-comes-back-slow", FLIGHT,
     "if filter_decides and now_ms - self.baro_back_ms < cfg.baro_settle_ms:",
     "if False:",
     "tests/tools/test_bench_faults.py::test_apogee_waits_after_the_barometer_comes_back_reading_slow"),
    ("a-barometer-back-reading-slow-is-noted", FLIGHT,
     "if mode & MODE_ACCEL and reads_slow(arb, cfg.baro_back_slow_mmps):",
     "if False:",
     "tests/tools/test_bench_faults.py::test_apogee_waits_after_the_barometer_comes_back_reading_slow"),
    ("the-wait-ends-below-the-readmit-tolerance", FLIGHT,
     "prior_vel_mmps <= -cfg.baro_readmit_mmps or self._dead_reckoning)",
     "prior_vel_mmps <= 0 or self._dead_reckoning)",
     "tests/tools/test_bench_faults.py::test_apogee_waits_after_the_barometer_comes_back_reading_slow"),
    ("the-wait-ends-only-under-the-dead-reckoning-guard", FLIGHT,
     "prior_vel_mmps <= -cfg.baro_readmit_mmps or self._dead_reckoning)",
     "prior_vel_mmps <= -cfg.baro_readmit_mmps or True)",
     "tests/tools/test_bench_faults.py::test_apogee_waits_after_the_barometer_comes_back_reading_slow"),
    ("apogee-after-reconvergence", FLIGHT,
     "if filter_decides and not health.accel_ok and det.inside_us[0] >= 0:",
     "if False:",
     "tests/tools/test_bench_faults.py::test_baro_only_apogee_waits_for_the_filter_to_reconverge_after_a_resync"),
    ("main-by-altitude-needs-margin", FLIGHT,
     "elif fc.max_agl_mm >= cfg.main_deploy_mm + cfg.main_margin_mm:",
     "elif True:",
     PAD_TESTS + "::test_under_performing_flight_opens_the_main_after_the_guard"),
    ("main-descending", FLIGHT,
     "elif fc.vel_mmps >= 0:",
     "elif False:",
     PAD_TESTS + "::test_main_only_while_descending"),
    ("main-timer-without-baro", FLIGHT,
     "return since_drogue_ms >= cfg.main_delay_ms  # no steady descent seen",
     "return False  # no steady descent seen",
     PAD_TESTS + "::test_accelerometer_only_main_on_the_timer_after_the_drogue"),
    ("launch-refused-orientation", FLIGHT,
     "if fc.errors & ERR_ORIENTATION:",
     "if False:",
     FLIGHT_TESTS + "::test_board_not_upright_or_wrong_range_refuses_launch"),
    ("launch-height-refused-erratic", FLIGHT,
     "height = (not fc.errors & ERR_BARO_ERRATIC\n                  and ",
     "height = (",
     PAD_TESTS + "::test_erratic_barometer_refuses_a_launch_by_height"),
    ("launch-height-needs-push", FLIGHT,
     "and (not fc.health.accel_ok or fc.acc_dv_mmps >= cfg.launch_speed_mmps))",
     ")",
     FLIGHT_TESTS + "::test_board_not_upright_or_wrong_range_refuses_launch"),
    ("launch-by-height", FLIGHT,
     "if boost or height:",
     "if boost:",
     PAD_TESTS + "::test_thrust_to_weight_2_9_launches_and_fires_at_apogee"),
    ("ground-before-launch", FLIGHT,
     "ground = self.pad.launch_ground()",
     "ground = fc.ground_alt_mm",
     PAD_TESTS + "::test_bad_barometer_reading_on_the_launch_sample_is_not_the_ground"),
    ("pad-quiet-not-climbing", PADCAL,
     "quiet = -limit < acc_kin < limit and not (",
     "quiet = -limit < acc_kin < limit and False and not (",
     PAD_TESTS + "::test_thrust_to_weight_2_9_launches_and_fires_at_apogee"),
    ("pad-rebase", PADCAL,
     "if jump > PAD_BARO_JUMP_MM or jump < -PAD_BARO_JUMP_MM:",
     "if False:",
     FLIGHT_TESTS + "::test_pressure_steps_never_fire"),
    ("pad-erratic-baro", PADCAL,
     "if pad._jumps >= 3:",
     "if False:",
     PAD_TESTS + "::test_erratic_barometer_refuses_a_launch_by_height"),
    ("pad-orientation", PADCAL,
     "        pad.errors |= ERR_ORIENTATION",
     "            pass",
     FLIGHT_TESTS + "::test_board_not_upright_or_wrong_range_refuses_launch"),
    ("range-check", HEALTH,
     "if have & HAVE_BARO and (alt_mm >= ALT_TOP_MM or alt_mm <= ALT_BOTTOM_MM):",
     "if False:",
     PAD_TESTS + "::test_out_of_range_barometer_on_the_pad_is_not_a_pressure_step"),
    ("boost-gate", FLIGHT,
     "det.gate_alt_mm = cfg.boost_gate_mm",
     "det.gate_alt_mm = 0",
     ARB_TESTS + "::test_barometer_only_board_through_mach_without_its_lockout"),
    ("clipped-accel-unused", HEALTH,
     "have &= HAVE_BARO  # a clipped reading under-reads",
     "pass  # a clipped reading under-reads",
     PAD_TESTS + "::test_clipped_accelerometer_is_not_used"),
    ("false-launch-at-rest", FLIGHT,
     "if not (near or at_rest):",
     "if not near:",
     PAD_TESTS + "::test_a_pad_offset_that_launched_returns_to_the_pad_and_a_real_flight_still_flies"),
    ("pulse-ends", FLIGHT,
     "if fc.pyro_drogue and now_ms - fc.drogue_fired_ms >= pulse_ms:",
     "if False:",
     FLIGHT_TESTS + "::test_pulses_are_exactly_the_configured_length_and_fire_once"),
    ("coast-gates", FLIGHT,
     "det.gate_alt_mm = GATE_ALT_MM",
     "det.gate_alt_mm = 0",
     PAD_TESTS + "::test_barometer_transient_in_coast_does_not_fire_early"),
    # sensor arbitration and re-convergence (docs/DESIGN.md D16, D17)
    ("arb-apogee-guard", FLIGHT,
     "if arb.valid and arb.vel_mmps - arb.margin_mmps > cfg.apogee_guard_mmps:",
     "if False:",
     ARB_TESTS + "::test_transonic_static_port_error_does_not_fire_early"),
    ("arb-dead-reckoning-guard", FLIGHT,
     "and arb.dead_reckoned_mmps(now_ms) > cfg.dead_reckoning_guard_mmps)",
     "and False)",
     ARB_TESTS + "::test_dead_reckoning_guard_is_needed"),
    ("arb-anchor-bias-before-fault", ARB,
     "self.anchor_bias_mmps2 = self._fbias[i]",
     "self.anchor_bias_mmps2 = self._fbias[self._head]",
     ARB_TESTS + "::test_dead_reckoning_starts_from_the_filter_before_the_fault"),
    ("clip-needs-a-held-peak", HEALTH,
     "and now_ms - health._acc_change_ms >= _CLIP_HOLD_MS):",
     "):",
     ARB_TESTS + "::test_a_reading_held_at_the_flights_peak_is_clipped_only_when_held"),
    ("no-filter-apogee-without-baro", FLIGHT,
     "filter_decides = enabled and mode & MODE_BARO",
     "filter_decides = enabled and mode != MODE_ACCEL",
     ARB_TESTS + "::test_no_sensor_left_only_the_backup_timer_fires"),
    ("clip-not-far-below-range", HEALTH,
     "and size >= health._early_clip_mmps2):",
     "):",
     ARB_TESTS + "::test_a_held_peak_far_below_the_configured_range_is_not_clipped"),
    ("arb-baro-consistency", FLIGHT,
     "excluded = (BOOST <= state <= COAST and not arb.baro_consistent and mode == MODE_BOTH",
     "excluded = (False and mode == MODE_BOTH",
     ARB_TESTS + "::test_pressure_transients_are_not_motion"),
    ("arb-baro-consistency-in-boost", FLIGHT,
     "and (state != BOOST or arb.upper_valid))",
     "and state != BOOST)",
     "tests/tools/test_bench_faults.py::"
     "test_a_static_port_error_in_boost_is_left_out_while_the_accelerometer_bounds_it"),
    ("arb-baro-kept-in-a-clipped-boost", FLIGHT,
     "and (state != BOOST or arb.upper_valid))",
     "and True)",
     ARB_TESTS + "::test_a_part_stuck_at_full_scale_in_coast_does_not_hold_the_boost"),
    ("arb-accel-only-margin", FLIGHT,
     "return arb.upper_mmps() <= 0 or (",
     "return arb.vel_mmps <= 0 or (",
     ARB_TESTS + "::test_barometer_frozen_or_lost_in_coast_never_early"),
    ("arb-bias-bounded", FLIGHT,
     "self.kf.bias_limit_q4 = (config.accel_bias_max_mmps2",
     "self.kf.bias_limit_q4 = 2 ** 29 or (config.accel_bias_max_mmps2",
     ARB_TESTS),
    ("arb-mach-lockout-time", FLIGHT,
     "or now_ms - fc.launch_ms < cfg.mach_lockout_ms)",
     ")",
     ARB_TESTS + "::test_no_apogee_within_the_mach_time_lockout"),
    ("arb-baro-frozen", HEALTH,
     "and now_ms - health._baro_run_ms >= health.baro_stuck_ms):",
     "and False):",
     ARB_TESTS + "::test_barometer_frozen_or_lost_in_coast_never_early"),
    ("arb-accel-frozen", HEALTH,
     ">= (health.max_boost_ms if clipped else health.accel_stuck_ms)):",
     ">= 0 and False):",
     ARB_TESTS + "::test_accelerometer_faults_with_a_healthy_barometer"),
    ("arb-baro-spike", HEALTH,
     "and step > health.baro_rate_max_mmps * since_ms // 1000 + _SPIKE_ALLOW_MM):",
     "and False):",
     ARB_TESTS + "::test_a_barometer_glitching_faster_than_any_rocket_is_not_used"),
    ("arb-main-backup", FLIGHT,
     "if cfg.main_backup_ms and since_drogue_ms >= cfg.main_backup_ms:",
     "if False:",
     ARB_TESTS + "::test_main_when_the_barometer_dies_under_the_drogue"),
    ("arb-main-predicted", FLIGHT,
     "return drop_dm <= 0 or fc.now_ms - fc._good_ms >= drop_dm * took_ds // fell_dm * 100",
     "return since_drogue_ms >= cfg.main_delay_ms",
     ARB_TESTS + "::test_main_when_the_barometer_dies_under_the_drogue"),
    ("arb-baro-change", ARB,
     "stepped = arb._change_run >= _CHANGE_RUN",
     "stepped = False",
     ARB_TESTS + "::test_a_pressure_step_below_100_mps_is_not_motion"),
    ("arb-change-noise", ARB,
     "_CHANGE_NOISE_K = const(3)",
     "_CHANGE_NOISE_K = const(0)",
     ARB_TESTS + "::test_a_noisy_barometer_is_not_a_step"),
    ("arb-change-run", ARB,
     "_CHANGE_RUN = const(3)",
     "_CHANGE_RUN = const(1)",
     ARB_TESTS + "::test_one_bad_reading_is_not_a_step"),
    ("arb-readmit-change-tolerance", ARB,
     "tol = arb.readmit_tol_mmps + _CHANGE_NOISE_K * arb._change_avg_mmps",
     "pass",
     ARB_TESTS + "::test_a_decaying_transient_stays_out_until_its_rate_stops_lying"),
    ("arb-readmit-floor", ARB,
     "tol = arb.readmit_tol_mmps + _CHANGE_NOISE_K * arb._change_avg_mmps",
     "tol = arb.change_tol_mmps + _CHANGE_NOISE_K * arb._change_avg_mmps",
     ARB_TESTS + "::test_a_transient_decaying_at_30_mps_stays_out"),
    ("baro-step-resync", "shared/detector.py",
     "self.kf.set_altitude((self.kf.alt_q4 >> 4) + late * 16)",
     "pass",
     "tests/shared/test_kalman.py::test_a_steady_barometric_step_moves_the_altitude_not_the_velocity"),
    ("gate-rearm", "shared/detector.py",
     "if self.inside_us[sensor] >= GATE_REARM_US:",
     "if True:",
     "tests/shared/test_reconvergence.py"),
    ("resume-proof-from-one-sensor", FLIGHT,
     "self.acc_account = False  # proof, if still owed, from one sensor alone",
     "pass",
     FLIGHT_TESTS + "::test_resume_after_reset_in_flight"),
    # the backup channels (docs/CONFIG.md, "Backup charges")
    ("backup-drogue-needs-proof", FLIGHT,
     "if (cfg.backup_drogue_delay_ms and fc.backup_drogue_fired_ms < 0 and fc.flight_proven",
     "if (cfg.backup_drogue_delay_ms and fc.backup_drogue_fired_ms < 0",
     BACKUP_TESTS + "::test_backup_needs_proof_of_flight[drogue]"),
    ("backup-main-needs-proof", FLIGHT,
     "if (cfg.backup_main_mm and fc.backup_main_fired_ms < 0 and fc.flight_proven",
     "if (cfg.backup_main_mm and fc.backup_main_fired_ms < 0",
     BACKUP_TESTS + "::test_backup_needs_proof_of_flight[main]"),
    ("backup-drogue-after-drogue", FLIGHT,
     "            and fc.drogue_fired_ms >= 0\n",
     "",
     BACKUP_TESTS + "::test_backup_drogue_only_after_the_drogue_fired"),
    ("backup-drogue-delay", FLIGHT,
     "and fc.now_ms - fc.drogue_fired_ms >= cfg.backup_drogue_delay_ms):",
     "):",
     BACKUP_TESTS + "::test_backups_fire_after_their_primaries_on_a_synthetic_flight"),
    ("backup-drogue-once", FLIGHT,
     "cfg.backup_drogue_delay_ms and fc.backup_drogue_fired_ms < 0 and",
     "cfg.backup_drogue_delay_ms and",
     BACKUP_TESTS + "::test_backups_fire_after_their_primaries_on_a_synthetic_flight"),
    ("backup-main-after-main", FLIGHT,
     "            and fc.main_fired_ms >= 0\n",
     "",
     BACKUP_TESTS + "::test_backup_main_waits_for_the_main_and_its_delay_on_a_low_flight"),
    ("backup-main-delay", FLIGHT,
     "            and fc.now_ms - fc.main_fired_ms >= cfg.backup_main_delay_ms\n",
     "",
     BACKUP_TESTS + "::test_backup_main_waits_for_the_main_and_its_delay_on_a_low_flight"),
    ("backup-main-altitude", FLIGHT,
     "or fc.agl_mm <= cfg.backup_main_mm)",
     "or True)",
     BACKUP_TESTS + "::test_backups_fire_after_their_primaries_on_a_synthetic_flight"),
    ("backup-main-without-baro", FLIGHT,
     "(not fc.mode & MODE_BARO or fc.agl_mm <= cfg.backup_main_mm)",
     "(fc.agl_mm <= cfg.backup_main_mm)",
     BACKUP_TESTS + "::test_backup_main_without_a_barometer_fires_its_delay_after_the_main"),
    ("backup-main-once", FLIGHT,
     "cfg.backup_main_mm and fc.backup_main_fired_ms < 0 and",
     "cfg.backup_main_mm and",
     BACKUP_TESTS + "::test_backups_fire_after_their_primaries_on_a_synthetic_flight"),
    ("backup-drogue-pulse-ends", FLIGHT,
     "if fc.pyro_backup_drogue and now_ms - fc.backup_drogue_fired_ms >= pulse_ms:",
     "if False:",
     BACKUP_TESTS + "::test_backups_fire_after_their_primaries_on_a_synthetic_flight"),
    ("backup-main-pulse-ends", FLIGHT,
     "if fc.pyro_backup_main and now_ms - fc.backup_main_fired_ms >= pulse_ms:",
     "if False:",
     BACKUP_TESTS + "::test_backups_fire_after_their_primaries_on_a_synthetic_flight"),
    ("backups-not-in-ascent", FLIGHT,
     "        _drogue_rule(fc, cfg, now_ms, apogee)\n",
     "        _drogue_rule(fc, cfg, now_ms, apogee)\n        _backup_rule(fc, cfg)\n",
     BACKUP_TESTS + "::test_backups_never_in_the_ascent"),
    ("backups-not-landed", FLIGHT,
     "    elif state == MAIN:\n        _backup_rule(fc, cfg)",
     "    elif state >= MAIN:\n        _backup_rule(fc, cfg)",
     BACKUP_TESTS + "::test_no_backup_fires_once_landed"),
    ("resume-keeps-backup-drogue", FLIGHT,
     "        if w1 & 0x100:\n            self.backup_drogue_fired_ms = self.now_ms\n",
     "",
     BACKUP_TESTS + "::test_each_backup_fires_once_across_a_reset"),
    ("resume-keeps-backup-main", FLIGHT,
     "        if w1 & 0x200:\n            self.backup_main_fired_ms = self.now_ms\n",
     "",
     BACKUP_TESTS + "::test_each_backup_fires_once_across_a_reset"),
    ("config-backup-main-below-main", "shared/config.py",
     'if backup_main and not MAIN_DEPLOY_MIN_M <= backup_main < merged["main_deploy_m"]:',
     "if False:",
     "tests/shared/test_config.py::test_bad_values_name_the_key"),
    ("board-backup-channel-needed", "device/board.py",
     'if config.values[key] and ch not in board["pyro"]:',
     "if False:",
     "tests/device/test_device_backup_channels.py::test_config_needs_the_backup_channels"),
    # a motor lit in coast (docs/DESIGN.md D18)
    ("ignition-in-coast", FLIGHT,
     "elif (fc.boost_ms >= cfg.launch_accel_ms and fc.apogee_ms < 0",
     "elif (False and fc.boost_ms >= cfg.launch_accel_ms and fc.apogee_ms < 0",
     STAGING_TESTS + "::test_a_motor_lit_in_coast_never_fires_the_drogue_early[both-9.0-air_start]"),
    ("ignition-sustained", FLIGHT,
     "elif (fc.boost_ms >= cfg.launch_accel_ms and fc.apogee_ms < 0",
     "elif (fc.boost_ms > 0 and fc.apogee_ms < 0",
     STAGING_TESTS + "::test_only_a_sustained_boost_is_an_ignition"),
    ("ignition-needs-the-barometer", FLIGHT,
     "and (fc.arb.baro_agrees() if fc.mode & MODE_BARO else not fc.baro_excluded)):",
     "):",
     "tests/desktop/test_replay_altos.py::test_anomalous_flight_within_its_window"),
    ("ignition-needs-a-judged-window", ARB,
     "return self.baro_consistent and not self._unjudged and not self.judge_due",
     "return self.baro_consistent and not self.judge_due",
     "tests/desktop/test_sensor_rows.py::test_alternating_rows_give_the_events_of_the_merged_rows[2012-05-28-serial-319-flight-005.csv]"),
    ("ignition-needs-the-current-verdict", ARB,
     "return self.baro_consistent and not self._unjudged and not self.judge_due",
     "return self.baro_consistent and not self._unjudged",
     "tests/desktop/test_sensor_rows.py::test_alternating_rows_give_the_events_of_the_merged_rows[2012-05-28-serial-319-flight-005.csv]"),
    ("burnout-ends-the-boost-run", FLIGHT,
     "fc.boost_ms = 0  # an ignition in coast needs boost readings of its own",
     "pass",
     STAGING_TESTS + "::test_an_accelerometer_lost_in_the_boost_is_no_ignition"),
    ("upper-bound-covers-thrust", ARB,
     "if acc_mmps2 > G_MMPS2:",
     "if False:",
     STAGING_TESTS + "::test_velocity_bounds_hold_through_a_second_burn"),
    # a part clipped at full scale (docs/DESIGN.md D16, "A clipped accelerometer")
    ("clip-lifts-the-filter", FLIGHT,
     "if clipped and state == BOOST and self.arb.baro_consistent and kf.acc_q4 >> 4 < acc_kin:",
     "if False:",
     ARB_TESTS + "::test_the_filter_keeps_accelerating_through_a_clipped_boost[configured]"),
    ("clip-yields-to-the-barometer", FLIGHT,
     "if clipped and state == BOOST and self.arb.baro_consistent and kf.acc_q4 >> 4 < acc_kin:",
     "if clipped and state == BOOST and kf.acc_q4 >> 4 < acc_kin:",
     ARB_TESTS + "::test_a_part_stuck_at_full_scale_in_coast_does_not_hold_the_boost[configured]"),
    ("clip-is-not-frozen", HEALTH,
     "(health.max_boost_ms if clipped else health.accel_stuck_ms)",
     "health.accel_stuck_ms",
     ARB_TESTS + "::test_a_part_clipped_through_the_boost_is_clipped_not_frozen[configured]"),
    ("clip-outlasting-a-boost-is-frozen", HEALTH,
     "                    clipped = True\n            elif not held",
     "                    clipped = True\n                run_now = True\n            elif not held",
     ARB_TESTS + "::test_a_clip_held_longer_than_any_boost_is_a_frozen_part[unknown]"),
]


def _pytest(workdir, args, timeout_s):
    cmd = [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", *args]
    try:
        proc = subprocess.run(cmd, cwd=workdir, capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        return None  # a mutant that hangs is killed (the flight loop would miss its deadlines)
    return proc.returncode


def run(names=None, timeout_s=600):
    chosen = [m for m in MUTANTS if names is None or m[0] in names]
    if names is not None and len(chosen) != len(set(names)):
        unknown = sorted(set(names) - {m[0] for m in MUTANTS})
        raise SystemExit("mutate: unknown mutant(s): %s" % ", ".join(unknown))
    results = []
    with tempfile.TemporaryDirectory(prefix="mutate-") as tmp:
        work = Path(tmp) / "repo"
        shutil.copytree(ROOT, work, ignore=shutil.ignore_patterns(".git", ".venv", "__pycache__", "*.pyc"))
        for name, rel, original, mutated, test in chosen:
            path = work / rel
            source = path.read_text()
            if source.count(original) != 1:
                raise SystemExit("mutate: %s: the rule's text is not found exactly once in %s" % (name, rel))
            path.write_text(source.replace(original, mutated))
            t0 = time.time()
            try:
                code = _pytest(work, [test], timeout_s)
                if code not in (0, 1, None):  # 4 or 5: the named test does not exist
                    raise SystemExit("mutate: %s: pytest exit %d on %s" % (name, code, test))
                killed_by = test if code != 0 else None
                if killed_by is None:
                    code = _pytest(work, FAST_LANE, timeout_s)
                    killed_by = "fast lane" if code in (1, None) else None
            finally:
                path.write_text(source)
            results.append({"mutant": name, "file": rel, "test": test, "killed": killed_by is not None,
                            "killed_by": killed_by, "seconds": round(time.time() - t0, 1)})
            print("%-32s %-8s %5.1f s  %s" % (name, "killed" if killed_by else "SURVIVED",
                                             time.time() - t0, killed_by or test), flush=True)
    return results


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", help="mutants to run (default: all)")
    ap.add_argument("--list", action="store_true", help="list the mutants and their tests")
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args(argv)
    if args.list:
        for name, rel, _o, _m, test in MUTANTS:
            print("%-32s %-18s %s" % (name, rel, test))
        return 0
    t0 = time.time()
    results = run(args.names or None)
    killed = sum(r["killed"] for r in results)
    score = 100.0 * killed / len(results)
    if args.json:
        print(json.dumps({"score_pct": round(score, 1), "killed": killed, "mutants": len(results),
                          "seconds": round(time.time() - t0), "results": results}, indent=1))
    else:
        print("score: %d/%d killed = %.0f %% in %.0f s" % (killed, len(results), score, time.time() - t0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
