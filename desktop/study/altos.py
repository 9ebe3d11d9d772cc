"""AltOS's published apogee and deployment algorithm, as a desktop comparison method (floats).

The algorithm of the Altus Metrum boards (TeleMetrum, TeleMega, EasyMega, EasyMini; AltOS 1.9),
restated from its published description; docs/ALTOS.md explains each rule and what this version
leaves out. Nothing here runs on the board: it is the yardstick the flight computer is compared
with in tools/bench_faults.py and on real logs.

Filter: three states (height above the pad, vertical speed, vertical acceleration), constant
acceleration between samples, fixed steady-state gains computed AltOS's way (``altos_gains``:
white-jerk process noise sigma_m = 2 m/s^2, barometer sigma_h = 6 m, accelerometer sigma_a =
2 m/s^2 (4 for the accelerometer-only set), AltOS's scaling of speed and acceleration by 16). Boards
with both sensors correct with both until apogee and with the barometer alone from the drogue on;
barometer-only boards always with the barometer. The barometric height is the standard atmosphere
in whole metres relative to the pad. In ascent the barometric innovation is scaled down above
248 m/s: weight 1 - 2 (v - 248) / 256, at least 37.5 % (accelerometer boards only), and to 0 within
256 m of the sensor's 30 km ceiling.

States: pad -> boost (height > 20 m, or acceleration > 20 m/s^2 with speed > 5 m/s) -> fast (both
sensors; burnout: acceleration < -2.5 m/s^2, or 15 s of boost) -> coast (speed < 248 m/s) ->
drogue (speed < 0; barometer-only boards also need the averaged squared barometric innovation below
100 m^2, "not transonic") -> main (height <= main altitude). A re-boost (averaged acceleration
> 20 m/s^2 in fast or coast) returns to boost. The drogue fires on entering drogue (plus the apogee
delay), the main on entering main but never sooner than 2 s after the drogue (the igniter task's
charge time).

Not in AltOS, needed to replay records here: a reading the record lacks (an empty cell) is not
used for that sample (the barometer-only or accelerometer-only gains correct with the other sensor;
with neither, the filter predicts); the gains are those of each sample's actual period to the
millisecond (AltOS boards sample at a fixed 100 Hz; its replay harness switches gains for the 10 Hz
descent logs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from desktop.sim.trajectory import isa_altitude
from shared.physics import G0_MPS2

# AltOS's sigmas (make-kalman): model (jerk) error m/s^2, barometer m, accelerometer m/s^2.
SIGMA_MODEL_MPS2 = 2.0
SIGMA_BARO_M = 6.0
SIGMA_ACCEL_MPS2 = 2.0
SIGMA_ACCEL_ONLY_MPS2 = 4.0
_AO_SCALE = 16.0  # AltOS stores speed and acceleration x16 and builds its model in those units

# State-machine thresholds (ao_flight.c, AltOS 1.9).
BOOST_HEIGHT_M = 20.0
BOOST_ACCEL_MPS2 = 20.0
BOOST_SPEED_MPS = 5.0
BURNOUT_ACCEL_MPS2 = -2.5
BOOST_MAX_S = 15.0
MAX_BARO_SPEED_MPS = 248.0  # fast -> coast; the barometer de-weighting starts here
MAX_SPEED_DISTRUST = 160  # of 256: the barometer's weight never falls below 96/256 = 37.5 %
MAX_BARO_HEIGHT_M = 30000.0  # MS5607 ceiling (MSL); the barometer is ignored 256 m above it
REBOOST_ACCEL_MPS2 = 20.0
REBOOST_AVG_SHIFT = 5  # averaged with weight 1/32 per sample
ERROR_BOUND_M2 = 100.0  # barometer-only apogee: averaged squared innovation below this
ERROR_AVG_SHIFT = 4  # weight 1/16 per sample
ERROR_CLAMP_M = 127.0
IGNITER_CHARGE_S = 2.0  # the igniter task waits this long after a pulse
GROUND_BLOCK_SAMPLES = 512  # pad: ground reference re-averaged over blocks of this many samples
MAIN_DEPLOY_DEFAULT_M = 250.0

STATES = ("pad", "boost", "fast", "coast", "drogue", "main")
PAD, BOOST, FAST, COAST, DROGUE, MAIN = range(6)


def altos_gains(dt_s: float, kind: str) -> np.ndarray:
    """Steady-state Kalman gains in SI units (rows h, v, a; columns the measurements), computed as
    AltOS's gain generator does: iterate predict/correct from P = 0 until K changes by < 1e-10.

    ``kind``: "both" (barometer, accelerometer), "baro" or "accel"."""
    t = float(dt_s)
    s = _AO_SCALE
    a = np.array([[1.0, t / s, t * t / 2.0 / s], [0.0, 1.0, t], [0.0, 0.0, 1.0]])
    sm = s * SIGMA_MODEL_MPS2
    q = sm * sm * np.array([[t**5 / 20, t**4 / 8, t**3 / 6], [t**4 / 8, t**3 / 3, t**2 / 2],
                            [t**3 / 6, t**2 / 2, t]])
    if kind == "both":
        h = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
        r = np.diag([SIGMA_BARO_M**2, (s * SIGMA_ACCEL_MPS2) ** 2])
        unscale = np.diag([1.0, s])
    elif kind == "baro":
        h = np.array([[1.0, 0.0, 0.0]])
        r = np.array([[SIGMA_BARO_M**2]])
        unscale = np.eye(1)
    elif kind == "accel":
        h = np.array([[0.0, 0.0, 1.0]])
        r = np.array([[(s * SIGMA_ACCEL_ONLY_MPS2) ** 2]])
        unscale = np.array([[s]])
    else:
        raise ValueError(f"unknown gain set {kind!r}")
    p = np.zeros((3, 3))
    k_prev = None
    for i in range(100000):
        p = a @ p @ a.T + q
        k = p @ h.T @ np.linalg.inv(h @ p @ h.T + r)
        p = (np.eye(3) - k @ h) @ p
        if k_prev is not None and i > 10 and np.max(np.abs(k - k_prev)) < 1e-10:
            break
        k_prev = k
    return np.diag([1.0, 1.0 / s, 1.0 / s]) @ k @ unscale


@dataclass
class AltosSettings:
    """What the board is configured with. ``accel_plus_g_mps2`` / ``accel_minus_g_mps2``: what the
    accelerometer reads nose up / nose down (AltOS's two-point calibration); ``None`` for a
    barometer-only board."""

    main_deploy_m: float = MAIN_DEPLOY_DEFAULT_M
    apogee_delay_s: float = 0.0
    apogee_lockout_s: float = 0.0
    has_accel: bool = True
    accel_plus_g_mps2: float = G0_MPS2
    accel_minus_g_mps2: float = -G0_MPS2


@dataclass
class AltosResult:
    events: dict = field(default_factory=dict)  # name -> time s (boost, burnout, coast, apogee, drogue, main)
    event_index: dict = field(default_factory=dict)
    height_m: np.ndarray | None = None
    speed_mps: np.ndarray | None = None
    state: np.ndarray | None = None

    def time(self, name: str) -> float:
        return float(self.events.get(name, math.nan))


_GAIN_CACHE: dict = {}


def _gains(dt_s: float, kind: str):
    key = (max(1, round(dt_s * 1e3)), kind)  # to the millisecond: jittered periods share a row
    g = _GAIN_CACHE.get(key)
    if g is None:
        k = altos_gains(key[0] / 1e3, kind)
        g = tuple(tuple(float(x) for x in row) for row in k)
        _GAIN_CACHE[key] = g
    return g


def run_altos(time_s, pressure_pa, accel_mps2, settings: AltosSettings | None = None,
              trace: bool = False, stop_after_main_s: float | None = 0.0) -> AltosResult:
    """Run AltOS's algorithm over one record (arrays; NaN = no reading in that sample).

    Returns the times of its events; with ``trace``, also the height, speed and state per sample.
    ``stop_after_main_s``: stop that long after the main fired (None: run to the end)."""
    settings = settings or AltosSettings()
    t = np.asarray(time_s, dtype=np.float64)
    p = np.asarray(pressure_pa, dtype=np.float64)
    have_p = np.isfinite(p)
    alt_msl = np.full(len(t), math.nan)
    alt_msl[have_p] = np.rint(isa_altitude(p[have_p]))  # AltOS's table gives whole metres
    alt_l = alt_msl.tolist()
    have_a = settings.has_accel and accel_mps2 is not None
    if have_a:
        f = np.asarray(accel_mps2, dtype=np.float64)
        plus, minus = settings.accel_plus_g_mps2, settings.accel_minus_g_mps2
        acc_l = ((f - plus) * (2.0 * G0_MPS2 / (plus - minus))).tolist()  # NaN stays NaN
    else:
        acc_l = [math.nan] * len(t)
    t_l = t.tolist()
    n = len(t_l)
    ev: dict = {}
    ev_i: dict = {}
    if trace:
        out_h, out_v, out_s = np.full(n, math.nan), np.full(n, math.nan), np.zeros(n, dtype=np.int8)

    def mark(name, i):
        if name not in ev:
            ev[name] = t_l[i]
            ev_i[name] = i

    # Pad: ground reference = running mean of the barometer until a block of 512 samples is complete,
    # then the mean of the latest complete block (AltOS re-averages while on the pad).
    ground = math.nan
    block_sum, block_n, all_sum, all_n = 0.0, 0, 0.0, 0
    h = v = a = 0.0
    state = PAD
    started = False
    launch_t = boost_t = math.nan
    coast_avg = 0.0
    err_sq_avg = 0.0
    drogue_fire_t = math.nan
    main_state_t = math.nan
    prev_t = t_l[0]
    main_deploy = settings.main_deploy_m
    accel_board = have_a
    for i in range(n):
        ti = t_l[i]
        z_alt = alt_l[i]
        za = acc_l[i]
        baro_ok = z_alt == z_alt
        acc_ok = za == za
        if state == PAD and baro_ok:
            all_sum += z_alt
            all_n += 1
            block_sum += z_alt
            block_n += 1
            if block_n == GROUND_BLOCK_SAMPLES:
                ground = round(block_sum / block_n)
                block_sum, block_n = 0.0, 0
            elif all_n <= GROUND_BLOCK_SAMPLES:
                ground = round(all_sum / all_n)
        if ground != ground:
            prev_t = ti
            continue
        if not started:
            h, v, a = (z_alt - ground) if baro_ok else 0.0, 0.0, 0.0
            started = True
            prev_t = ti
            continue
        dt = ti - prev_t
        prev_t = ti
        if dt > 0:
            h += v * dt + a * dt * dt / 2.0
            v += a * dt
        use_accel = accel_board and acc_ok and state < DROGUE
        if baro_ok:
            e_h = (z_alt - ground) - h
            ec = min(abs(e_h), ERROR_CLAMP_M)
            err_sq_avg += (ec * ec - err_sq_avg) / (1 << ERROR_AVG_SHIFT)
            if state < DROGUE:
                distrust = 0.0
                if accel_board and v > MAX_BARO_SPEED_MPS:
                    distrust = min(2.0 * (v - MAX_BARO_SPEED_MPS), MAX_SPEED_DISTRUST)
                height_distrust = z_alt - MAX_BARO_HEIGHT_M
                if height_distrust > distrust:
                    distrust = height_distrust
                distrust = min(distrust, 256.0)
                e_h *= (256.0 - distrust) / 256.0
            if use_accel:
                k = _gains(dt, "both")
                e_a = za - a
                h += k[0][0] * e_h + k[0][1] * e_a
                v += k[1][0] * e_h + k[1][1] * e_a
                a += k[2][0] * e_h + k[2][1] * e_a
            else:
                k = _gains(dt, "baro")
                h += k[0][0] * e_h
                v += k[1][0] * e_h
                a += k[2][0] * e_h
        elif use_accel:
            k = _gains(dt, "accel")
            e_a = za - a
            h += k[0][0] * e_a
            v += k[1][0] * e_a
            a += k[2][0] * e_a

        if state == PAD:
            if h > BOOST_HEIGHT_M or (accel_board and a > BOOST_ACCEL_MPS2 and v > BOOST_SPEED_MPS):
                state = BOOST
                launch_t = boost_t = ti
                mark("boost", i)
        elif state == BOOST:
            if a < BURNOUT_ACCEL_MPS2 or ti - boost_t > BOOST_MAX_S:
                state = FAST if accel_board else COAST
                coast_avg = a
                mark("burnout", i)
        elif state in (FAST, COAST):
            coast_avg += (a - coast_avg) / (1 << REBOOST_AVG_SHIFT)
            if coast_avg > REBOOST_ACCEL_MPS2:
                state = BOOST
                boost_t = ti
            elif state == FAST:
                if v < MAX_BARO_SPEED_MPS:
                    state = COAST
                    mark("coast", i)
            elif ti - launch_t >= settings.apogee_lockout_s and v < 0.0 and (
                    accel_board or z_alt >= MAX_BARO_HEIGHT_M or err_sq_avg < ERROR_BOUND_M2):
                state = DROGUE
                mark("apogee", i)
                drogue_fire_t = ti + settings.apogee_delay_s
        elif state == DROGUE:
            if h <= main_deploy:
                state = MAIN
                main_state_t = ti
        if state >= DROGUE and "drogue" not in ev and ti >= drogue_fire_t:
            mark("drogue", i)
        if state == MAIN and "drogue" in ev and "main" not in ev and (
                ti >= max(main_state_t, ev["drogue"] + IGNITER_CHARGE_S)):
            mark("main", i)
        if trace:
            out_h[i], out_v[i], out_s[i] = h, v, state
        if stop_after_main_s is not None and "main" in ev and ti - ev["main"] >= stop_after_main_s:
            break
    res = AltosResult(events=ev, event_index=ev_i)
    if trace:
        res.height_m, res.speed_mps, res.state = out_h, out_v, out_s
    return res


def run_altos_log(log, settings: AltosSettings | None = None, trace: bool = False) -> AltosResult:
    """AltOS's algorithm over a flight CSV (``desktop.io.flightcsv.FlightLog``): the main altitude
    from its ``main_deploy_m`` metadata when present; an accelerometer board when it has one."""
    if settings is None:
        main = log.metadata_float("main_deploy_m")
        settings = AltosSettings(main_deploy_m=main if main is not None else MAIN_DEPLOY_DEFAULT_M,
                                 has_accel=log.has_accel)
    if log.pressure_pa is None:
        raise ValueError(f"{log.path}: AltOS's algorithm needs a pressure_pa column")
    return run_altos(log.time_s, log.pressure_pa, log.accel_mps2 if settings.has_accel else None,
                     settings, trace=trace, stop_after_main_s=None if trace else 0.0)
