"""Flight configuration: every threshold of the state machine, with units, defaults and ranges.

Portable (MicroPython and CPython). A configuration is a JSON object (``config.json`` on the
board); ``load_config`` validates it and converts it once to the integer units the state machine
uses. Any problem raises ``ConfigError`` with one line naming the key, the value and the allowed
range; unknown keys are errors, never ignored.
"""

import math

from shared.physics import G_MMPS2

# Lowest main deployment height: below it a main cannot open before the ground (0 = no main).
MAIN_DEPLOY_MIN_M = 10

# key: (default, minimum, maximum, unit, meaning). Numbers accept int or float; 0 disables the
# keys documented as "0 = off". Defaults suit a typical high-power dual-deploy flight.
SCHEMA = {
    "main_deploy_m": (250, 0, 5000, "m AGL",
        "main fires when the descending rocket is at or below this (0 = no main: single deployment)"),
    "main_guard_s": (2.0, 0, 60, "s",
        "main never fires sooner than this after the drogue fired; after a maximum altitude below "
        "main_deploy_m + main_margin_m the main fires this long after the drogue"),
    "main_margin_m": (50, 0, 1000, "m",
        "the main fires by altitude only after a maximum altitude at least this far above "
        "main_deploy_m (an under-performing flight must not land on its drogue)"),
    "main_delay_s": (10, 1, 600, "s",
        "no barometer (accelerometer-only board, or the barometer lost, or not descending under the "
        "drogue) and no steady descent seen: the main fires this long after the drogue; set it to "
        "(apogee - main altitude) / drogue descent rate"),
    "apogee_delay_s": (0, 0, 30, "s", "drogue fires this long after apogee is detected"),
    "apogee_lockout_s": (0, 0, 120, "s", "no apogee sooner than this after launch (0 = off)"),
    "backup_drogue_s": (0, 0, 600, "s",
        "drogue fires this long after launch if apogee was not detected (0 = off)"),
    "pulse_ms": (500, 10, 5000, "ms", "how long a pyro output stays on (each channel its own pulse)"),
    # Backup channels (a second charge per deployment; docs/CONFIG.md "Backup charges"): each
    # obeys the primaries' proof of flight, fires at most once, and only after its primary fired
    "backup_drogue_delay_s": (0, 0, 30, "s",
        "the backup drogue channel fires this long after the drogue channel fired (0 = no backup "
        "drogue; not the drogue's own timer backup_drogue_s)"),
    "backup_main_m": (0, 0, 5000, "m AGL",
        "the backup main channel fires when the descending rocket is at or below this, after the "
        "main fired (0 = no backup main); below main_deploy_m"),
    "backup_main_delay_s": (1, 0.1, 60, "s",
        "the backup main never fires sooner than this after the main; without a usable barometer "
        "it fires this long after the main"),
    "launch_accel_mps2": (20, 5, 500, "m/s^2",
        "boost: acceleration above 1 g sustained for launch_accel_time_s (launch, and a motor lit "
        "in coast: staging, air-start)"),
    "launch_accel_time_s": (0.1, 0.02, 2, "s", "how long the boost acceleration must be sustained"),
    "launch_height_m": (20, 5, 500, "m",
        "launch also when the filtered height exceeds this at launch_speed_mps (low thrust-to-weight; "
        "AltOS launches at 20 m); launching fires nothing without proof of flight"),
    "launch_speed_mps": (10, 2, 300, "m/s", "launch by height: the filtered climb rate reached"),
    "proof_climb_m": (30, 5, 1000, "m",
        "proof of flight: the barometer must confirm this climb above the pad"),
    "proof_speed_mps": (15, 5, 300, "m/s",
        "proof of flight: the boost integrated from the accelerometer reaches this speed (barometer-only: "
        "the estimated climb rate); a shove of 4 g for 0.3 s gives 11.8 m/s"),
    "proof_baro_climb_m": (100, 30, 1000, "m",
        "proof of flight without the accelerometer: the barometer's climb held for a second; above "
        "any pad pressure disturbance (offsets of 60 m; RRC3 arms at 100 ft)"),
    "sensor_lost_s": (0.5, 0.05, 10, "s",
        "a sensor without a usable reading for this long is lost: proof falls back to the other, "
        "the decision mode leaves it out"),
    "boost_gate_m": (100, 20, 1000, "m",
        "from the first sample of boost, a barometric reading this far from the estimate is not used "
        "(a glitch; resynchronised after 1 s)"),
    "coast_decel_mps2": (4.9, 1, 9.8, "m/s^2",
        "apogee needs the averaged deceleration to exceed this (coast ~ g)"),
    "max_boost_s": (15, 1, 60, "s", "a boost (launch, or a motor lit in coast) ends after this even without "
        "burnout; an accelerometer held at full scale this long is frozen"),
    "mach_lockout_mps": (250, 50, 3000, "m/s",
        "above this estimated speed no apogee and the barometer is de-weighted"),
    "mach_baro_weight_pct": (37.5, 0, 100, "%", "barometer weight reached at 1.32 x mach_lockout_mps"),
    "landed_window_s": (10, 2, 120, "s", "landed: altitude varies less than landed_alt_m over this window"),
    "landed_alt_m": (4, 0.5, 100, "m", "landed: altitude band"),
    "baro_lag_ms": (0, 0, 500, "ms",
        "the barometer's reading lag (its IIR/oversampling filter and the static port); compensated"),
    "accel_range_g": (0, 0, 1000, "g",
        "accelerometer full scale; readings at it are clipped: left out of the filter, a lower bound "
        "on the boost's acceleration (0 = unknown)"),
    # Sensor arbitration and health (docs/DESIGN.md, "Sensor arbitration")
    "accel_bias_max_mps2": (1.0, 0, 10, "m/s^2",
        "largest accelerometer bias left after pad calibration (error budget of its velocity)"),
    "accel_tilt_max_deg": (30, 0, 60, "deg",
        "largest angle between the accelerometer's axis and the vertical (error budget of its velocity)"),
    "apogee_guard_mps": (0, -50, 100, "m/s",
        "no apogee while the accelerometer's lowest possible vertical velocity exceeds this"),
    "baro_consistency_mps": (50, 10, 500, "m/s",
        "barometric climb rate outside the accelerometer's velocity bounds by more than this is not motion"),
    "baro_change_mps": (30, 5, 500, "m/s",
        "below baro_change_below_mps: a barometric rate that changes this much more than the "
        "accelerometer's within half a second (plus 3 x its learnt noise) is a pressure step, not motion"),
    "baro_change_below_mps": (100, 0, 1000, "m/s",
        "the change test applies below this vertical speed (the accelerometer's; 0 = off)"),
    "baro_readmit_mps": (20, 1, 500, "m/s",
        "below baro_change_below_mps, a barometer left out in coast comes back only when its rate "
        "agrees within this (plus 3 x its learnt noise and the margin grown since) with the "
        "accelerometer's velocity carried on from the filter's before the fault; taken back climbing "
        "faster than the filter's velocity by more than this, that velocity below it, it gives the "
        "filter its rate"),
    "baro_lie_max_m": (1200, 300, 5000, "m",
        "the largest barometric error that is not motion (a static-port error of 10 % of pressure "
        "through Mach, 880 m, and a transient): a barometer left out that parts from the "
        "accelerometer-carried filter by more than this plus the accelerometer's own error since "
        "shows that the accelerometer lies, and it is not used for the rest of the flight"),
    "baro_transient_max_m": (300, 50, 5000, "m",
        "the largest pressure transient (airbrakes, an ejection): at an accelerometer-only apogee the "
        "rocket is slow (no static-port error), and a barometer left out that lies farther than this "
        "(plus baro_readmit_mps x the time since) from the accelerometer-carried filter holds it; "
        "taken back that far, climbing faster than the filter, it gives the filter its rate"),
    "baro_back_slow_mps": (5, 0, 100, "m/s",
        "a barometer taken back reading this much (plus 3 x its learnt noise) slower than the "
        "accelerometer's velocity since the fault does not decide apogee for baro_settle_s"),
    "dead_reckoning_guard_mps": (0, 0, 50, "m/s",
        "after the barometer was left out in coast: no apogee while the accelerometer's velocity "
        "carried on from the filter's before the fault exceeds this"),
    "baro_track_m": (10, 2, 100, "m",
        "apogee on the barometer alone (no accelerometer in use) needs the filter within this of the "
        "barometer (RMS over 0.16 s; AltOS's 10 m): not while it re-converges or reads a transonic lie"),
    "baro_diverged_m": (30, 10, 127, "m",
        "apogee on the barometer alone (no accelerometer in use) waits baro_settle_s after the filter "
        "was this far from the barometer (RMS over 0.16 s): its velocity is then a re-convergence "
        "transient, not the motion"),
    "baro_settle_s": (4, 0, 30, "s",
        "how long apogee on the barometer alone waits after the filter was baro_diverged_m off it, "
        "and any filter apogee after a barometer taken back reading slow (baro_back_slow_mps; 0 = off)"),
    "baro_step_rate_mps": (20, 0, 100, "m/s",
        "a barometer rejected by the gate for a second whose innovation then moves slower than this "
        "stepped (a pressure offset): the filter re-takes its altitude, not its velocity (0 = off)"),
    "baro_ballistic_mps": (10, 0, 500, "m/s",
        "apogee on the barometer alone: a barometric rate that changes beyond what a coasting rocket "
        "can (rising, or falling faster than its drag a moment before allows) by more than this (plus "
        "3 x its learnt noise) sets a ballistic floor under the velocity; with both sensors the "
        "barometer left out in coast sets it; no apogee while it is above zero (0 = off)"),
    "baro_stuck_s": (1.0, 0.2, 10, "s", "identical barometer readings for this long in flight: frozen"),
    "accel_stuck_s": (0.5, 0.1, 10, "s",
        "identical accelerometer readings for this long while above 1 g (noise expected): frozen"),
    "baro_rate_max_mps": (1500, 100, 5000, "m/s",
        "a barometric reading that moved faster than this from the previous one is a spike"),
    "mach_lockout_s": (0, 0, 120, "s",
        "after launch: treated as above Mach (no apogee, barometer de-weighted) for this long (0 = off)"),
    "main_backup_s": (0, 0, 600, "s",
        "barometer lost, frozen or not descending under the drogue: main fires this long after the "
        "drogue at the latest (0 = off)"),
}
CHOICES = {
    "apogee_rule": ("velocity", ("velocity", "seed"),
        "velocity: estimated speed reaches zero; seed: altitude falls twice"),
    "sensors": ("both", ("both", "baro", "accel"), "which sensors the board has"),
    "baro_noise": ("standard", ("standard", "low"),
        "standard: gains for 6 m of barometer noise (transients included, as AltOS); low: a modern "
        "part behind a good static port (BMP390, MS5611), trusted more near apogee"),
}


class ConfigError(ValueError):
    """A configuration problem; the message is one line naming the key."""


class ConfigFileMissing(ConfigError):
    """The configuration file cannot be read (the board then flies the defaults)."""


class Config:
    """Validated configuration in integer units (mm, mm/s, mm/s^2, ms)."""

    def __init__(self, values):
        self.values = values  # the user-facing values, for logging and display
        v = values
        self.main_deploy_mm = int(v["main_deploy_m"] * 1000)
        self.main_guard_ms = int(v["main_guard_s"] * 1000)
        self.main_margin_mm = int(v["main_margin_m"] * 1000)
        self.main_delay_ms = int(v["main_delay_s"] * 1000)
        self.apogee_delay_ms = int(v["apogee_delay_s"] * 1000)
        self.apogee_lockout_ms = int(v["apogee_lockout_s"] * 1000)
        self.backup_drogue_ms = int(v["backup_drogue_s"] * 1000)
        self.pulse_ms = int(v["pulse_ms"])
        self.backup_drogue_delay_ms = int(v["backup_drogue_delay_s"] * 1000)
        self.backup_main_mm = int(v["backup_main_m"] * 1000)
        self.backup_main_delay_ms = int(v["backup_main_delay_s"] * 1000)
        self.launch_accel_mmps2 = int(v["launch_accel_mps2"] * 1000)
        self.launch_accel_ms = int(v["launch_accel_time_s"] * 1000)
        self.launch_height_mm = int(v["launch_height_m"] * 1000)
        self.launch_speed_mmps = int(v["launch_speed_mps"] * 1000)
        self.proof_baro_climb_mm = int(v["proof_baro_climb_m"] * 1000)
        self.sensor_lost_ms = int(v["sensor_lost_s"] * 1000)
        self.boost_gate_mm = int(v["boost_gate_m"] * 1000)
        self.proof_climb_mm = int(v["proof_climb_m"] * 1000)
        self.proof_speed_mmps = int(v["proof_speed_mps"] * 1000)
        self.coast_decel_mmps2 = int(v["coast_decel_mps2"] * 1000)
        self.max_boost_ms = int(v["max_boost_s"] * 1000)
        self.mach_lockout_mmps = int(v["mach_lockout_mps"] * 1000)
        self.mach_baro_weight_256 = int(v["mach_baro_weight_pct"] * 256 / 100)
        self.landed_window_ms = int(v["landed_window_s"] * 1000)
        self.landed_alt_mm = int(v["landed_alt_m"] * 1000)
        self.accel_limit_mmps2 = int(v["accel_range_g"] * G_MMPS2 * 98 // 100)  # 0 = no check
        self.baro_lag_ms = int(v["baro_lag_ms"])
        self.accel_bias_max_mmps2 = int(v["accel_bias_max_mps2"] * 1000)
        # 1/cos(tilt) - 1 in 1/1024: a tilted path hides 1 - cos of the specific force from the
        # vertical, a tilted mount reads cos x the true force: both errors are within this
        # fraction of the reading
        self.tilt_loss_1024 = int(round((1 / math.cos(math.radians(v["accel_tilt_max_deg"])) - 1) * 1024))
        self.apogee_guard_mmps = int(v["apogee_guard_mps"] * 1000)
        self.baro_consistency_mmps = int(v["baro_consistency_mps"] * 1000)
        self.baro_change_mmps = int(v["baro_change_mps"] * 1000)
        self.baro_change_below_mmps = int(v["baro_change_below_mps"] * 1000)
        self.baro_readmit_mmps = int(v["baro_readmit_mps"] * 1000)
        self.dead_reckoning_guard_mmps = int(v["dead_reckoning_guard_mps"] * 1000)
        self.baro_back_slow_mmps = int(v["baro_back_slow_mps"] * 1000)
        self.baro_track_sq_q4 = int(v["baro_track_m"] ** 2 * 16)  # 1/16 m^2
        self.baro_diverged_sq_q4 = int(v["baro_diverged_m"] ** 2 * 16)  # 1/16 m^2
        self.baro_settle_ms = int(v["baro_settle_s"] * 1000)
        self.baro_step_rate_mmps = int(v["baro_step_rate_mps"] * 1000)
        self.baro_stuck_ms = int(v["baro_stuck_s"] * 1000)
        self.accel_stuck_ms = int(v["accel_stuck_s"] * 1000)
        self.baro_rate_max_mmps = int(v["baro_rate_max_mps"] * 1000)
        self.mach_lockout_ms = int(v["mach_lockout_s"] * 1000)
        self.main_backup_ms = int(v["main_backup_s"] * 1000)
        self.seed_rule = v["apogee_rule"] == "seed"
        self.has_baro = v["sensors"] in ("both", "baro")
        self.has_accel = v["sensors"] in ("both", "accel")
        self.low_noise_baro = v["baro_noise"] == "low"


def _is_number(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool) and x == x and x not in (
        float("inf"), float("-inf"))


def load_config(values=None):
    """Validate a dict of settings (missing keys take defaults) and return a Config."""
    if values is None:
        values = {}
    if not isinstance(values, dict):
        raise ConfigError("config: expected a JSON object of settings, got %s" % type(values).__name__)
    merged = {}
    for key in values:
        if key not in SCHEMA and key not in CHOICES:
            raise ConfigError("config: unknown key %r (known: %s)" % (key, ", ".join(sorted(
                list(SCHEMA) + list(CHOICES)))))
    for key, (default, low, high, unit, _meaning) in SCHEMA.items():
        value = values.get(key, default)
        if not _is_number(value):
            raise ConfigError("config: %s must be a number (%s), got %r" % (key, unit, value))
        if not low <= value <= high:
            raise ConfigError("config: %s = %r is out of range: allowed %g to %g %s" % (
                key, value, low, high, unit))
        merged[key] = value
    for key, (default, allowed, _meaning) in CHOICES.items():
        value = values.get(key, default)
        if value not in allowed:
            raise ConfigError("config: %s = %r is not one of %s" % (key, value, ", ".join(allowed)))
        merged[key] = value
    if 0 < merged["main_deploy_m"] < MAIN_DEPLOY_MIN_M:
        raise ConfigError("config: main_deploy_m = %r is out of range: allowed 0 (no main) or %g to %g m AGL"
                          % (merged["main_deploy_m"], MAIN_DEPLOY_MIN_M, SCHEMA["main_deploy_m"][2]))
    backup_main = merged["backup_main_m"]
    if backup_main and not MAIN_DEPLOY_MIN_M <= backup_main < merged["main_deploy_m"]:
        raise ConfigError("config: backup_main_m = %r is out of range: allowed 0 (no backup main) or "
                          "%g m AGL to below main_deploy_m = %r" % (backup_main, MAIN_DEPLOY_MIN_M,
                                                                    merged["main_deploy_m"]))
    if merged["backup_drogue_s"] and merged["backup_drogue_s"] < merged["apogee_lockout_s"]:
        raise ConfigError("config: backup_drogue_s = %r fires before apogee_lockout_s = %r ends" % (
            merged["backup_drogue_s"], merged["apogee_lockout_s"]))
    if merged["sensors"] == "accel" and merged["apogee_rule"] == "seed":
        raise ConfigError("config: apogee_rule = 'seed' needs a barometer, but sensors = 'accel'")
    return Config(merged)


def load_config_file(path):
    """Read and validate a JSON configuration file."""
    import json

    try:
        with open(path) as f:
            text = f.read()
    except OSError as exc:
        raise ConfigFileMissing("config: cannot read %s: %s" % (path, exc)) from None
    try:
        values = json.loads(text)
    except ValueError as exc:
        raise ConfigError("config: %s is not valid JSON: %s" % (path, exc)) from None
    return load_config(values)
