"""Physical flights with sensor faults, for the arbitration and health tests.

A vertical flight from the equations of motion (thrust, transonic drag, ISA atmosphere; a second
motor lit in coast for staging or an air-start), read by a barometer and an axial accelerometer as
the board would, with the faults of issue 13 injected from physics rather than fitted to a log:

- transonic static-port error: the static pressure reads p (1 + c exp(-(M - 1)^2 / (2 sigma^2)))
  (c of either sign, up to 10 %; sigma 0.05 to 0.3 in Mach), on the way up (and down if fast);
- a pressure transient: an altitude offset that rises within ``rise_s`` to ``amp_m`` and decays
  with ``decay_s`` (0: persists, as behind deployed airbrakes);
- a barometer frozen from an instant, or lost from an instant;
- an accelerometer biased, mounted at a tilt (it reads f cos tilt, also on the pad), clipped at
  its range, frozen or lost.

``fly()`` returns integer board readings (dt_us, alt_mm, accel_mmps2, have) and the truth.
"""

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from desktop.sim.trajectory import isa_pressure
from shared.altitude import pressure_to_alt_mm
from shared.config import load_config
from shared.detector import HAVE_ACCEL, HAVE_BARO
from shared.flight import EV_DROGUE, EV_MAIN, FlightComputer

G = 9.80665


def isa(h_m):
    """(pressure Pa, density kg/m^3, speed of sound m/s) at geopotential altitude h (troposphere
    and the isothermal layer above 11 km)."""
    if h_m < 11000:
        t = 288.15 - 0.0065 * h_m
        p = 101325.0 * (t / 288.15) ** 5.25588
    else:
        t = 216.65
        p = 22632.1 * math.exp(-G * (h_m - 11000) / (287.053 * t))
    return p, p / (287.053 * t), math.sqrt(1.4 * 287.053 * t)


@dataclass
class Rocket:
    """Dry mass, propellant, thrust and burn time, drag coefficient and diameter; optionally a
    second motor lit in coast (a sustainer after staging, or an air-start)."""

    dry_kg: float = 1.2
    prop_kg: float = 0.35
    thrust_n: float = 800.0
    burn_s: float = 1.6
    cd: float = 0.45
    diameter_m: float = 0.041
    descent_mps: float = 25.0  # under the drogue (the flight does not depend on the board)
    motor2_at_s: float = None  # flight time the second motor lights (None: one motor)
    motor2_thrust_n: float = 0.0
    motor2_burn_s: float = 0.0
    motor2_prop_kg: float = 0.0  # also carried from the start (part of the dry mass after)
    booster_kg: float = 0.0  # dropped at the first motor's burnout (staging)

    def thrust_and_mass(self, t):
        """Thrust (N) and mass (kg) at flight time t."""
        thrust = self.thrust_n if t < self.burn_s else 0.0
        mass = self.dry_kg + self.prop_kg * max(0.0, 1 - t / self.burn_s)
        if t >= self.burn_s:
            mass -= self.booster_kg
        if self.motor2_at_s is not None:
            since = t - self.motor2_at_s
            if 0 <= since < self.motor2_burn_s:
                thrust += self.motor2_thrust_n
            mass += self.motor2_prop_kg * min(1.0, max(0.0, 1 - since / self.motor2_burn_s))
        return thrust, mass

    def burning_until_s(self):
        """The end of the last burn."""
        if self.motor2_at_s is None:
            return self.burn_s
        return max(self.burn_s, self.motor2_at_s + self.motor2_burn_s)


# A 38 mm minimum-diameter flight to about Mach 1.4 and a subsonic high-power flight.
MACH_ROCKET = Rocket()
SUBSONIC_ROCKET = Rocket(dry_kg=2.0, prop_kg=0.25, thrust_n=600.0, burn_s=1.5, cd=0.5, diameter_m=0.066)
# A motor lit in coast, 3 s after the first burns out: a two-stage minimum-diameter flight to about
# Mach 2 (the booster's case dropped at staging), and a 66 mm sport rocket whose larger air-started
# second motor takes it to about Mach 2.5.
TWO_STAGE_ROCKET = Rocket(dry_kg=3.0, prop_kg=0.6, thrust_n=1200.0, burn_s=1.8, diameter_m=0.054,
                          booster_kg=0.5, motor2_at_s=4.8, motor2_thrust_n=400.0, motor2_burn_s=2.5,
                          motor2_prop_kg=0.3)
AIR_START_ROCKET = Rocket(dry_kg=2.0, prop_kg=0.25, thrust_n=600.0, burn_s=1.5, cd=0.5, diameter_m=0.066,
                          motor2_at_s=4.5, motor2_thrust_n=900.0, motor2_burn_s=2.5, motor2_prop_kg=0.3)


@dataclass
class Faults:
    mach_c: float = 0.0  # static-port error at Mach 1, fraction of pressure (+: reads high)
    mach_sigma: float = 0.1
    transient_at_s: float = None  # flight time (s after ignition) of a pressure transient
    transient_m: float = 0.0  # its altitude amplitude (+: reads higher)
    transient_rise_s: float = 0.2
    transient_decay_s: float = 0.5  # 0: persists
    baro_frozen_at_s: float = None
    baro_frozen_noisy: bool = False  # the frozen reading keeps the part's noise (a stuck conversion)
    baro_lost_at_s: float = None
    accel_bias_mps2: float = 0.0
    accel_tilt_deg: float = 0.0
    accel_range_g: float = 0.0  # 0: no clipping
    accel_frozen_at_s: float = None
    accel_lost_at_s: float = None


@dataclass
class Flight:
    dt_us: np.ndarray
    alt_mm: np.ndarray
    accel_mmps2: np.ndarray
    have: np.ndarray
    time_s: np.ndarray  # from ignition
    true_alt_m: np.ndarray
    true_vel_mps: np.ndarray
    mach: np.ndarray
    apogee_s: float
    apogee_m: float
    max_mach: float = 0.0
    meta: dict = field(default_factory=dict)


def _drag_cd(cd, mach):
    # transonic drag rise (a smooth bump peaking just above Mach 1)
    return cd * (1.0 + 1.2 * math.exp(-((mach - 1.05) / 0.18) ** 2))


def fly(rocket=MACH_ROCKET, faults=None, rate_hz=100, pad_s=3.0, after_apogee_s=40.0, seed=0,
        site_m=200.0, baro_noise_m=0.5, accel_noise_mps2=0.3):
    """Integrate the flight and read it with the faulty sensors (see the module docstring)."""
    faults = Faults() if faults is None else faults
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    area = math.pi * rocket.diameter_m ** 2 / 4
    h = v = 0.0
    t = 0.0
    rows = []
    apogee_s = None
    apogee_m = 0.0
    n_pad = int(pad_s * rate_hz)
    for _ in range(n_pad):
        rows.append((-pad_s + len(rows) * dt, 0.0, 0.0, G, 0.0))
    burns_until_s = rocket.burning_until_s()
    while True:
        thrust, mass = rocket.thrust_and_mass(t)
        p, rho, a_snd = isa(site_m + h)
        mach = abs(v) / a_snd
        if apogee_s is None:
            drag = 0.5 * rho * v * abs(v) * _drag_cd(rocket.cd, mach) * area
            force = thrust - drag
            specific = force / mass  # axial specific force (the accelerometer's quantity)
            acc = specific - G
            if h <= 0 and acc < 0 and t < rocket.burn_s:
                acc, specific = 0.0, G  # still on the pad
        else:
            # under the drogue: descending at descent_mps (the board's decisions do not matter)
            target = -rocket.descent_mps
            acc = max(-G, (target - v) * 2.0)
            specific = acc + G
        rows.append((t, h, v, specific, mach))
        v_new = v + acc * dt
        h += (v + v_new) / 2 * dt
        if apogee_s is None and v > 0 and v_new <= 0 and t >= burns_until_s:
            apogee_s = t + dt * v / (v - v_new)
            apogee_m = h
        v = v_new
        t += dt
        if apogee_s is not None and (t > apogee_s + after_apogee_s or h <= 0):
            break
    arr = np.array(rows)
    time_s, hh, vv, spec, mach = arr.T
    n = len(time_s)
    f = faults
    # barometer
    press = np.array([isa(site_m + x)[0] for x in hh])
    if f.mach_c:
        press *= 1 + f.mach_c * np.exp(-((mach - 1.0) ** 2) / (2 * f.mach_sigma ** 2))
    alt_offset = np.zeros(n)
    if f.transient_at_s is not None:
        since = time_s - f.transient_at_s
        on = since >= 0
        rise = 1 - np.exp(-np.where(on, since, 0) / (f.transient_rise_s / 3))
        decay = np.exp(-np.where(on, since, 0) / f.transient_decay_s) if f.transient_decay_s else 1.0
        alt_offset = np.where(on, f.transient_m * rise * decay, 0.0)
    baro_alt_mm = np.empty(n, dtype=np.int64)
    for i in range(n):
        baro_alt_mm[i] = pressure_to_alt_mm(int(round(press[i] * 16)))
    noise_mm = np.round((alt_offset + rng.normal(0, baro_noise_m, n)) * 1000).astype(np.int64)
    if f.baro_frozen_at_s is not None:
        # the pressure stands still; frozen under its noise the noise goes on, else the reading
        # itself repeats
        i0 = np.searchsorted(time_s, f.baro_frozen_at_s)
        baro_alt_mm[i0:] = baro_alt_mm[i0]
        if not f.baro_frozen_noisy:
            noise_mm[i0:] = noise_mm[i0]
    baro_alt_mm += noise_mm
    have = np.full(n, HAVE_BARO | HAVE_ACCEL)
    if f.baro_lost_at_s is not None:
        have[time_s >= f.baro_lost_at_s] &= HAVE_ACCEL
    # accelerometer: reads the specific force along its tilted axis, with a bias
    tilt = math.cos(math.radians(f.accel_tilt_deg))
    acc_read = spec * tilt + f.accel_bias_mps2 + rng.normal(0, accel_noise_mps2, n)
    if f.accel_range_g:
        lim = f.accel_range_g * G
        acc_read = np.clip(acc_read, -lim, lim)
    accel_mmps2 = np.round(acc_read * 1000).astype(np.int64)
    if f.accel_frozen_at_s is not None:
        i0 = np.searchsorted(time_s, f.accel_frozen_at_s)
        accel_mmps2[i0:] = accel_mmps2[i0]
    if f.accel_lost_at_s is not None:
        have[time_s >= f.accel_lost_at_s] &= HAVE_BARO
    dt_us = np.full(n, 1000000 // rate_hz, dtype=np.int64)
    dt_us[0] = 0
    return Flight(dt_us, baro_alt_mm, accel_mmps2, have, time_s, hh, vv, mach, apogee_s, apogee_m,
                  float(mach.max()))


@dataclass
class Outcome:
    drogue_s: float  # flight time of the drogue (None: never)
    main_s: float
    main_true_m: float  # true altitude when the main fired
    early_s: float  # how early the drogue was, s before true apogee (negative: late)
    events: list
    fc: object


def flight_csv_columns(flight):
    """The flight's readings as flight-CSV columns (docs/FLIGHT_CSV.md): the barometric altitude
    back to the standard atmosphere's pressure, and the axial specific force in m/s^2."""
    return {"time_s": flight.time_s, "pressure_pa": isa_pressure(flight.alt_mm / 1000),
            "accel_mps2": flight.accel_mmps2 / 1000}


def first_bound_miss(flight, slack_mmps=500):
    """Fly the board's code (default configuration) over ``flight``: the first sample before
    apogee whose true velocity lies more than ``slack_mmps`` outside the accelerometer's velocity
    bounds, as (time s, true velocity, lower, upper mm/s), or None. (The simulation's reading holds
    over the interval after its sample, the board integrates it over the interval before: the
    true velocity is taken one sample on.)"""
    fc = FlightComputer(load_config({}))
    arb = fc.arb
    for i in range(len(flight.dt_us)):
        fc.step(int(flight.dt_us[i]), int(flight.alt_mm[i]), int(flight.accel_mmps2[i]), int(flight.have[i]))
        if arb.valid and flight.time_s[i] < flight.apogee_s:
            v = flight.true_vel_mps[i + 1] * 1000
            if not arb.lower_mmps() - slack_mmps <= v <= arb.upper_mmps() + slack_mmps:
                return float(flight.time_s[i]), v, arb.lower_mmps(), arb.upper_mmps()
    return None


def slow_barometer(flight, rate_hz):
    """``flight`` with its barometer read at ``rate_hz`` only: one reading in every 100 / rate_hz
    of its 100 Hz record (the accelerometer keeps every reading)."""
    have = flight.have.copy()
    have[(np.arange(len(have)) % (100 // rate_hz)) != 0] &= HAVE_ACCEL
    return dataclasses.replace(flight, have=have)


def run(flight, sensors="both", **config):
    """Fly the board's code over ``flight``; the drogue and main times and how early the drogue
    was relative to the true apogee."""
    values = {"sensors": sensors}
    values.update(config)
    fc = FlightComputer(load_config(values))
    have_mask = {"both": HAVE_BARO | HAVE_ACCEL, "baro": HAVE_BARO, "accel": HAVE_ACCEL}[sensors]
    drogue = main = None
    main_m = None
    events = []
    for i in range(len(flight.dt_us)):
        fc.step(int(flight.dt_us[i]), int(flight.alt_mm[i]), int(flight.accel_mmps2[i]),
                int(flight.have[i]) & have_mask)
        if fc.events:
            events.append((float(flight.time_s[i]), fc.events, fc.mode, fc.health.flags))
            if fc.events & EV_DROGUE:
                drogue = float(flight.time_s[i])
            if fc.events & EV_MAIN:
                main = float(flight.time_s[i])
                main_m = float(flight.true_alt_m[i])
    early = None if drogue is None else flight.apogee_s - drogue
    return Outcome(drogue, main, main_m, early, events, fc)
