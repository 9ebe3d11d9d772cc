"""Sensor fault classes for the fault benchmark (tools/bench_faults.py), written from physics.

A fault either changes what reaches the sensor (applied to the truth ``Trajectory`` before the sensor
models of desktop/sim/sensor_models.py, so the part's lag, noise and quantisation act on it) or
breaks the sensor itself (applied to the board's record afterwards). docs/FAULTS.md gives the
physics and the ranges of each class.

Before the sensor (``apply_to_trajectory``):

- ``transonic_up`` / ``transonic_down``: static-port error dp = eps p exp(-(M - 1)^2 / (2 sigma^2)),
  eps uniform in +-10 % of the static pressure, sigma uniform in 0.05 to 0.3: a port that reads
  high (eps > 0, the "Mach dip") or low around Mach 1. ``up`` acts while the Mach number rises,
  ``down`` while it falls (a fast rocket decelerating through Mach 1 in coast), blended over
  +-0.25 s around the Mach peak (where the Mach number hardly changes). A rocket that stays
  subsonic gets one error, a function of Mach alone, both ways (its ``up`` class); ``down`` is a
  class only for rockets that pass Mach 1.
- ``transient_burnout`` / ``transient_midcoast`` / ``transient_ejection``: a pressure transient
  worth dh (uniform in +-300 m of altitude) rising smoothly within 0.1 to 0.5 s, starting 0 to 0.5 s
  after burnout (airbrakes opening), in the middle half of the coast, or 0 to 0.5 s after true
  apogee (the drogue's ejection charge); then it decays exponentially (time constant 0.3 to 3 s) or,
  for half of the burnout and mid-coast draws, persists until apogee (airbrakes held open) and
  decays then. dp = -rho g dh, rho from the standard atmosphere at the rocket.
- ``accel_tilted``: the accelerometer mounted up to 30 degrees off the rocket's axis reads the axial
  specific force times cos(tilt), on the pad as in flight.

After the sensor (``apply_to_record``):

- ``baro_frozen``: from an instant on, the barometer returns its last reading forever.
- ``baro_frozen_noisy``: from an instant on, the barometer's pressure stands still but its noise
  goes on (a stuck conversion: an MS5611 whose pressure result stops updating while its
  temperature still does, a driver that re-reads a stale result): the last reading's smoothed
  value plus the record's own noise (the reading less the least-squares line through the readings
  within 0.1 s of it), so that no reading repeats and a stuck test on identical readings cannot
  see it.
- ``baro_lost``: from an instant on, no barometer reading (empty cells).
- ``accel_lost``: from an instant on, no accelerometer reading.
- ``accel_clipped``: the accelerometer's full scale is 30 to 90 % of the flight's peak reading, at
  least 2 g (the board is told that full scale, as docs/CONFIG.md asks).
- ``accel_biased``: from launch on, the accelerometer reads an extra bias uniform in +-1 m/s^2 (a
  shock or thermal shift that the pad calibration cannot see).
- ``accel_zeroed``: from an instant on, the accelerometer reads 0 (a failed bus returns zero bytes:
  no specific force, a drag-free coast), for 0.2 to 5 s or, in half the draws, for good.

The instant of the frozen, lost and zeroed classes: a phase drawn with equal odds (boost, coast, the 6 s
around apogee, descent to the main altitude; the accelerometer classes: the first three), then a
time uniform in it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from desktop.sim.trajectory import G0, R_AIR, Trajectory, isa_temperature

BARO_CLASSES = ("none", "transonic_up", "transonic_down", "transient_burnout", "transient_midcoast",
                "transient_ejection", "baro_frozen", "baro_lost", "baro_frozen_noisy")
ACCEL_CLASSES = ("accel_lost", "accel_clipped", "accel_biased", "accel_tilted", "accel_zeroed")
# (each class draws from its index here: a class added later goes last, so that the others draw
# what they always drew)
CLASSES = BARO_CLASSES[:-1] + ACCEL_CLASSES + BARO_CLASSES[-1:]

TRANSONIC_MAX_FRACTION = 0.10  # of static pressure
TRANSONIC_SIGMA_MACH = (0.05, 0.3)
TRANSONIC_BLEND_S = 0.25  # up/down blend half-width around the Mach peak (Mach is flat there)
FAST_ROCKET_MACH = 1.0  # a rocket whose peak Mach reaches this gets the transonic_down class
TRANSIENT_MAX_M = 300.0
TRANSIENT_RISE_S = (0.1, 0.5)
TRANSIENT_DECAY_S = (0.3, 3.0)
TRANSIENT_START_S = (0.0, 0.5)  # after burnout / after apogee (ejection)
TILT_MAX_DEG = 30.0
BIAS_MAX_MPS2 = 1.0
CLIP_FRACTION = (0.3, 0.9)  # of the flight's peak accelerometer reading
CLIP_MIN_MPS2 = 2.0 * G0  # no part has a full scale below 2 g (it would clip on the pad)
APOGEE_WINDOW_S = 3.0  # the "around apogee" phase: +- this
ZEROED_S = (0.2, 5.0)  # how long a zeroed accelerometer reads 0 when it comes back
NOISE_MEAN_S = 0.2  # baro_frozen_noisy: the span of the local line whose residual is the part's noise


class FaultError(ValueError):
    """An unknown fault class."""


@dataclass
class Fault:
    """One drawn fault: its class and parameters (JSON-ready)."""

    kind: str
    params: dict = field(default_factory=dict)

    @property
    def on_board_record(self) -> bool:
        return self.kind in ("baro_frozen", "baro_lost", "baro_frozen_noisy", "accel_lost", "accel_clipped",
                             "accel_biased", "accel_zeroed")


def classes_for(max_mach: float, board: str) -> tuple[str, ...]:
    """The fault classes that apply to a rocket (its nominal peak Mach) and a board ("both" or
    "baro")."""
    out = [c for c in (BARO_CLASSES if board == "baro" else CLASSES)]
    if max_mach < FAST_ROCKET_MACH:
        out.remove("transonic_down")
    return tuple(out)


def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _phase_instant(rng, traj: Trajectory, end_s: float, phases: tuple[str, ...]) -> tuple[str, float]:
    burnout = float(traj.burnout_time_s)
    apogee = float(traj.apogee_time_s)
    bounds = {
        "boost": (0.0, burnout),
        "coast": (burnout, max(burnout, apogee - APOGEE_WINDOW_S)),
        "apogee": (apogee - APOGEE_WINDOW_S, apogee + APOGEE_WINDOW_S),
        "descent": (apogee + APOGEE_WINDOW_S, max(apogee + APOGEE_WINDOW_S, end_s)),
    }
    phase = phases[int(rng.integers(len(phases)))]
    lo, hi = (min(x, end_s) for x in bounds[phase])
    return phase, float(lo + rng.random() * (hi - lo))


def draw_fault(kind: str, rng: np.random.Generator, traj: Trajectory, end_s: float,
               subsonic: bool = False) -> Fault:
    """Draw the parameters of one fault of class ``kind`` for this trajectory. ``subsonic``: the
    rocket stays below Mach 1 (its transonic error is a function of Mach alone)."""
    if kind not in CLASSES:
        raise FaultError(f"unknown fault class {kind!r} (known: {', '.join(CLASSES)})")
    p: dict = {}
    if kind == "none":
        pass
    elif kind.startswith("transonic"):
        p["eps"] = float(rng.uniform(-TRANSONIC_MAX_FRACTION, TRANSONIC_MAX_FRACTION))
        p["sigma_mach"] = float(rng.uniform(*TRANSONIC_SIGMA_MACH))
        p["both_ways"] = bool(subsonic)
    elif kind.startswith("transient"):
        p["dh_m"] = float(rng.uniform(-TRANSIENT_MAX_M, TRANSIENT_MAX_M))
        p["rise_s"] = float(rng.uniform(*TRANSIENT_RISE_S))
        p["decay_s"] = float(rng.uniform(*TRANSIENT_DECAY_S))
        burnout, apogee = float(traj.burnout_time_s), float(traj.apogee_time_s)
        if kind == "transient_burnout":
            p["start_s"] = burnout + float(rng.uniform(*TRANSIENT_START_S))
        elif kind == "transient_midcoast":
            p["start_s"] = burnout + (apogee - burnout) * float(rng.uniform(0.25, 0.75))
        else:
            p["start_s"] = apogee + float(rng.uniform(*TRANSIENT_START_S))
        persist = kind != "transient_ejection" and rng.random() < 0.5
        p["hold_until_s"] = apogee if persist else None
    elif kind in ("baro_frozen", "baro_lost", "baro_frozen_noisy"):
        p["phase"], p["start_s"] = _phase_instant(rng, traj, end_s, ("boost", "coast", "apogee", "descent"))
    elif kind == "accel_lost":
        p["phase"], p["start_s"] = _phase_instant(rng, traj, end_s, ("boost", "coast", "apogee"))
    elif kind == "accel_zeroed":
        p["phase"], p["start_s"] = _phase_instant(rng, traj, end_s, ("boost", "coast", "apogee"))
        p["until_s"] = None if rng.random() < 0.5 else p["start_s"] + float(rng.uniform(*ZEROED_S))
    elif kind == "accel_clipped":
        p["fraction_of_peak"] = float(rng.uniform(*CLIP_FRACTION))
    elif kind == "accel_biased":
        p["bias_mps2"] = float(rng.uniform(-BIAS_MAX_MPS2, BIAS_MAX_MPS2))
    elif kind == "accel_tilted":
        p["tilt_deg"] = float(rng.uniform(0.0, TILT_MAX_DEG))
    return Fault(kind, p)


def transonic_fraction(mach, eps: float, sigma_mach: float):
    """The static-port error as a fraction of static pressure: eps exp(-(M-1)^2 / (2 sigma^2))."""
    m = np.asarray(mach, dtype=float)
    return eps * np.exp(-((m - 1.0) ** 2) / (2.0 * sigma_mach**2))


def transient_altitude_m(time_s, dh_m: float, start_s: float, rise_s: float, decay_s: float,
                         hold_until_s: float | None = None):
    """The transient as altitude equivalent (m): a smooth rise over ``rise_s`` to ``dh_m``, held
    until ``hold_until_s`` (if later than the rise), then an exponential decay."""
    t = np.asarray(time_s, dtype=float)
    up = _smoothstep((t - start_s) / rise_s)
    peak_end = start_s + rise_s
    if hold_until_s is not None:
        peak_end = max(peak_end, float(hold_until_s))
    decay = np.where(t > peak_end, np.exp(-np.maximum(t - peak_end, 0.0) / decay_s), 1.0)
    return dh_m * up * decay


def apply_to_trajectory(traj: Trajectory, fault: Fault) -> Trajectory:
    """The trajectory as the sensors see it: pressure at the port, axis of the accelerometer."""
    k, p = fault.kind, fault.params
    if k.startswith("transonic"):
        frac = transonic_fraction(traj.mach, p["eps"], p["sigma_mach"])
        if not p["both_ways"]:
            t_peak = float(traj.time_s[int(np.argmax(traj.mach))])
            rising = 1.0 - _smoothstep((traj.time_s - (t_peak - TRANSONIC_BLEND_S)) / (2 * TRANSONIC_BLEND_S))
            frac = frac * (rising if k == "transonic_up" else 1.0 - rising)
        return replace(traj, pressure_pa=traj.pressure_pa * (1.0 + frac))
    if k.startswith("transient"):
        dh = transient_altitude_m(traj.time_s, p["dh_m"], p["start_s"], p["rise_s"], p["decay_s"],
                                  p["hold_until_s"])
        temp = isa_temperature(traj.site_altitude_m + traj.altitude_m)
        # hydrostatic: the port reads the pressure of dh higher (dp = -rho g dh, rho = p / (R T))
        return replace(traj, pressure_pa=traj.pressure_pa * np.exp(-G0 * dh / (R_AIR * temp)))
    if k == "accel_tilted":
        c = math.cos(math.radians(p["tilt_deg"]))
        return replace(traj, accel_mps2=traj.accel_mps2 * c, pad_accel_mps2=traj.pad_accel_mps2 * c)
    return traj


def _last_reading(pres, first):
    """The index of the last finite reading before sample ``first`` (``first`` if none)."""
    before = np.flatnonzero(np.isfinite(pres[:first]))
    return int(before[-1]) if before.size else first


def _frozen_with_noise(t, pres, first):
    """``pres`` from sample ``first`` on: the local line (``_local_line``) at the last finite
    reading before it, plus each reading's residual from its own local line (its noise)."""
    good = np.isfinite(pres)
    if not good.any():
        return pres
    filled = np.where(good, pres, np.interp(t, t[good], pres[good]))
    line = _local_line(t, filled, NOISE_MEAN_S / 2.0)
    held = line[_last_reading(pres, first)]
    out = pres.copy()
    out[first:] = np.where(good[first:], held + (filled[first:] - line[first:]), np.nan)
    return out


def _local_line(t, values, half_s):
    """At each sample, the least-squares line through the samples within ``half_s`` of it in time,
    taken there: the motion, so that the residual is the part's noise alone. (A running mean over a
    number of samples spans a gap in the record on one side: at 100 m/s it took metres of the
    flight's motion into the "noise".)"""
    u = t - t[0]
    v = values - values[0]
    lo = np.searchsorted(t, t - half_s, side="left")
    hi = np.searchsorted(t, t + half_s, side="right")

    def window_sum(x):
        c = np.concatenate(([0.0], np.cumsum(x)))
        return c[hi] - c[lo]

    n = (hi - lo).astype(float)
    mean_u = window_sum(u) / n
    mean_v = window_sum(v) / n
    var = window_sum(u * u) / n - mean_u * mean_u
    cov = window_sum(u * v) / n - mean_u * mean_v
    slope = np.divide(cov, var, out=np.zeros_like(cov), where=var > 1e-12)
    return values[0] + mean_v + slope * (u - mean_u)


def apply_to_record(time_s: np.ndarray, pressure_pa: np.ndarray, accel_mps2: np.ndarray, fault: Fault):
    """(pressure_pa, accel_mps2, accel_range_mps2) of the board's record with a sensor fault:
    copies; ``accel_range_mps2`` is the clipping level of ``accel_clipped`` (else None)."""
    k, p = fault.kind, fault.params
    t = np.asarray(time_s, dtype=float)
    pres = np.array(pressure_pa, dtype=float)
    acc = None if accel_mps2 is None else np.array(accel_mps2, dtype=float)
    clip = None
    if k in ("baro_frozen", "baro_lost"):
        after = t >= p["start_s"]
        if k == "baro_lost":
            pres[after] = math.nan
        elif after.any():
            pres[after] = pres[_last_reading(pres, int(np.argmax(after)))]
    elif k == "baro_frozen_noisy":
        after = t >= p["start_s"]
        if after.any():
            pres = _frozen_with_noise(t, pres, int(np.argmax(after)))
    elif acc is None:
        pass
    elif k == "accel_lost":
        acc[t >= p["start_s"]] = math.nan
    elif k == "accel_clipped":
        clip = max(CLIP_MIN_MPS2, p["fraction_of_peak"] * float(np.nanmax(np.abs(acc))))
        acc = np.clip(acc, -clip, clip)
    elif k == "accel_biased":
        acc[t >= 0.0] += p["bias_mps2"]
    elif k == "accel_zeroed":
        zeroed = t >= p["start_s"]
        if p["until_s"] is not None:
            zeroed &= t < p["until_s"]
        acc[zeroed & np.isfinite(acc)] = 0.0
    return pres, acc, clip
