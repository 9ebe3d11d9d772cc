"""Our flight computer inside RocketPy, closed loop: a parachute trigger backed by shared/.

A RocketPy user flies the board's exact decision code (``shared.flight.FlightComputer``) in their own
simulation: a late or early drogue changes the descent. One ``FlightComputerTrigger`` serves both
parachutes; ``trigger.drogue`` and ``trigger.main`` are the two trigger callables::

    from desktop.sim.rocketpy_trigger import FlightComputerTrigger, add_board_sensors

    baro, accel = add_board_sensors(rocket, "ms5611+adxl375", rate_hz=100, seed=1)
    fc = FlightComputerTrigger(baro, accel, config={"main_deploy_m": 250, "accel_range_g": 200})
    rocket.add_parachute("drogue", cd_s=0.35, trigger=fc.drogue, sampling_rate=100, lag=1.0)
    rocket.add_parachute("main", cd_s=3.0, trigger=fc.main, sampling_rate=100, lag=1.5)
    flight = Flight(rocket=rocket, environment=env, rail_length=3, inclination=85, heading=90)
    fc.finish()             # steps the readings measured after the last trigger call
    fc.events               # launch, burnout, apogee, drogue, main, landed (the board's time base)
    fc.write_csv("fc.csv")  # what the board saw, as a flight CSV: replay it with python -m desktop replay

How it works:

- RocketPy 1.13 calls each parachute's trigger at the parachute's sampling rate with (pressure,
  height above ground, state vector, sensors[, u_dot]) and no time. The trigger reads the
  ``measured_data`` of the Barometer and the Accelerometer attached to the rocket ((t, value) and
  (t, ax, ay, az) tuples) and steps the flight computer once per new sensor timestamp, in time order
  (the readings of one timestamp together; a timestamp already stepped, as RocketPy repeats at a
  phase change, is skipped). The drogue and the main triggers of one time step therefore share the
  steps. Timing: with ``Flight(..., time_overshoot=False)`` RocketPy stops at every sensor and
  trigger time, measures the sensors first, then calls the triggers: the parachute is triggered at
  the very sample of the board's decision (tested). With RocketPy's default ``time_overshoot=True``
  (4 to 5 times faster) a node's trigger runs before that node's sensors are measured, so the
  parachute is triggered at the next trigger call after the decision, one sample later; and RocketPy
  1.13 skips the sensor and trigger nodes of the solver step in which the rail exit or the apogee
  happens (it restarts the node list from the interpolated event), a gap of 20 to 130 ms in the
  readings just before apogee on the example rockets, which the board bridges by prediction.
- Units, as the board's drivers deliver them: pressure in Pa x 16 (rounded) through
  ``shared.altitude.pressure_to_alt_mm``; specific force along the rocket's axis in mm/s^2 (+9807
  at rest nose up). RocketPy's accelerometer (sensor z along the rocket's axis, the default
  orientation) with ``consider_gravity=True`` reads (a - g z_hat) . b in RocketPy 1.13: -9.7 m/s^2
  at rest on a rail at 85 degrees, about -2 g in free fall, where a real accelerometer reads
  (a + g z_hat) . b: +9.7 and 0 (RocketPy PR #1175 fixes the sign). ``rocketpy_gravity_sign()``
  measures which convention the installed RocketPy uses, and the trigger adds the missing
  (1 - sign) g (z_hat . b), with b from the state vector's attitude quaternion at the trigger call
  (at most one sample after the reading: the axis turns by well under a degree in 10 ms). With
  ``consider_gravity=False`` it adds g (z_hat . b).
- RocketPy starts at ignition; a board has been sitting on the pad. The trigger first feeds
  ``pad_s`` seconds (at the sensors' rate) of the first readings, at negative times, so the flight
  computer calibrates its ground reference and 1 g as on a pad.
- The trigger returns True for the drogue once the board has fired the drogue pyro channel, and for
  the main once it has fired the main (RocketPy then opens the parachute after its ``lag``).

Every step is recorded (unless ``record=False``): ``write_csv`` gives the flight CSV of exactly the
integer readings the board used, so ``python -m desktop replay`` on it reproduces its decisions.
See docs/SIMULATION.md ("Our firmware inside RocketPy").
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

from shared.altitude import pressure_to_alt_mm
from shared.config import Config, load_config
from shared.detector import HAVE_ACCEL, HAVE_BARO
from shared.flight import EVENT_NAMES, FlightComputer
from shared.physics import G0_MPS2 as G0

__all__ = [
    "FlightComputerTrigger",
    "rocketpy_gravity_sign",
    "board_sensors",
    "add_board_sensors",
    "config_for_profile",
    "fly_closed_loop",
    "ClosedLoopFlight",
]


@dataclass
class TriggerEvent:
    event: str
    index: int  # step index (pad samples included)
    time_s: float  # the sensors' time base (0 = ignition)
    altitude_m: float  # the flight computer's filtered altitude above the pad


class _ConstantGravity:
    def __init__(self, g):
        self.g = g

    def get_value_opt(self, _z):
        return self.g


class _Environment:
    def __init__(self, g):
        self.gravity = _ConstantGravity(g)


_GRAVITY_SIGN = None
LOW_NOISE_PA = 20.0  # below this RMS per reading a barometer is "low" noise (as sensor_models declares)


def _has_setting(key) -> bool:
    from shared.config import CHOICES, SCHEMA

    return key in SCHEMA or key in CHOICES


def baro_noise_pa(barometer) -> float:
    """RMS white noise of one RocketPy barometer reading (noise_density x sqrt(sampling_rate))."""
    var = float(getattr(barometer, "noise_variance", 1.0) or 0.0)
    return float(barometer.noise_density) * math.sqrt(float(barometer.sampling_rate)) * math.sqrt(var)


def rocketpy_gravity_sign() -> int:
    """What the installed RocketPy's ``Accelerometer(consider_gravity=True)`` reads on its z axis at
    rest, nose up: +1 for +g (a real accelerometer), -1 for -g (RocketPy 1.13). Measured once."""
    global _GRAVITY_SIGN
    if _GRAVITY_SIGN is None:
        from rocketpy.mathutils.vector_matrix import Vector
        from rocketpy.sensors import Accelerometer

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            acc = Accelerometer(sampling_rate=1.0, consider_gravity=True, name="gravity probe")
        u = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        acc.measure(0.0, u=u, u_dot=[0.0] * 13, relative_position=Vector([0.0, 0.0, 0.0]),
                    environment=_Environment(G0))
        z = acc.measurement[2]
        if abs(abs(z) - G0) > 1e-6:
            raise RuntimeError(f"RocketPy's accelerometer reads {z!r} at rest: expected +-{G0}")
        _GRAVITY_SIGN = 1 if z > 0 else -1
    return _GRAVITY_SIGN


def axis_vertical_component(state) -> float:
    """z_hat . b: the vertical component of the rocket's axis, from the attitude quaternion
    (e0, e1, e2, e3) = state[6:10] (1 nose up, 0 horizontal)."""
    e1, e2 = float(state[7]), float(state[8])
    return 1.0 - 2.0 * (e1 * e1 + e2 * e2)


class FlightComputerTrigger:
    """One flight computer behind RocketPy's drogue and main parachute triggers (module docstring).

    ``barometer``: a ``rocketpy.sensors.Barometer`` attached to the rocket (required).
    ``accelerometer``: a ``rocketpy.sensors.Accelerometer`` attached with its z axis along the
    rocket's axis (the default orientation), or None for a barometer-only board.
    ``config``: a ``shared.config.Config`` or a dict of settings (docs/CONFIG.md); ``sensors``
    follows the sensors given, ``accel_range_g`` the accelerometer's range and ``baro_noise`` the
    barometer's noise (``low`` below 20 Pa RMS per reading, as ``sensor_models`` declares its
    records), unless set.
    """

    def __init__(self, barometer, accelerometer=None, config=None, pad_s: float = 5.0,
                 gravity_mps2: float = G0, record: bool = True):
        if barometer is None:
            raise ValueError("FlightComputerTrigger needs a barometer")
        self.barometer = barometer
        self.accelerometer = accelerometer
        if accelerometer is not None:
            normal = [float(x) for x in accelerometer.normal_vector]
            if abs(normal[2] - 1.0) > 1e-9:
                raise ValueError("the accelerometer's z axis must lie along the rocket's axis (orientation "
                                 f"(0, 0, 0)); its normal vector is {normal}")
            consider = bool(getattr(accelerometer, "consider_gravity", False))
            self.gravity_factor = (1 - rocketpy_gravity_sign()) if consider else 1
        else:
            self.gravity_factor = 0
        if not isinstance(config, Config):
            values = dict(config or {})
            values.setdefault("sensors", "both" if accelerometer is not None else "baro")
            if accelerometer is not None and "accel_range_g" not in values:
                top = max(abs(float(x)) for x in accelerometer.measurement_range)
                values["accel_range_g"] = round(top / G0, 1) if math.isfinite(top) else 0
            if "baro_noise" not in values and _has_setting("baro_noise"):
                values["baro_noise"] = "low" if baro_noise_pa(barometer) < LOW_NOISE_PA else "standard"
            config = load_config(values)
        self.config = config
        self.fc = FlightComputer(config)
        self.g = float(gravity_mps2)
        rates = [barometer.sampling_rate] + ([accelerometer.sampling_rate] if accelerometer else [])
        self.pad_period_us = int(round(1e6 / max(rates)))
        self.pad_samples = max(0, int(round(pad_s * 1e6 / self.pad_period_us)))
        self.record = record
        self.rows_time_us: list[int] = []
        self.rows_p_q4: list[int | None] = []
        self.rows_accel_mm: list[int | None] = []
        self.events: list[TriggerEvent] = []
        self.steps = 0  # flight steps (one per new sensor timestamp), pad samples not counted
        self.duplicates = 0  # readings at a timestamp already stepped (skipped)
        self.calls = 0
        self._ib = 0
        self._ia = 0
        self._last_us = None
        self._state = None
        self._index = 0

    # RocketPy calls these (signature (pressure, height, state, sensors): 4 arguments).
    def drogue(self, pressure, height, state, sensors):
        """Drogue trigger: True once the board has fired the drogue channel."""
        self._update(state)
        return self.fc.drogue_fired_ms >= 0

    def main(self, pressure, height, state, sensors):
        """Main trigger: True once the board has fired the main channel."""
        self._update(state)
        return self.fc.main_fired_ms >= 0

    def finish(self, state=None):
        """Step the readings measured after the last trigger call (the flight's end)."""
        self._update(self._state if state is None else state, count_call=False)

    # ----------------------------------------------------------------------------------------------

    def _data(self, sensor):
        data = sensor.measured_data
        if data and isinstance(data[0], list):
            raise ValueError(f"sensor {sensor.name!r} is attached to the rocket more than once")
        return data

    def _update(self, state, count_call=True):
        if count_call:
            self.calls += 1
        if state is not None:
            self._state = state
        bd = self._data(self.barometer)
        ad = self._data(self.accelerometer) if self.accelerometer is not None else None
        if self._last_us is None:
            if not bd or (ad is not None and not ad):
                return
            self._feed_pad(bd[0], ad[0] if ad is not None else None)
        nb = len(bd)
        na = len(ad) if ad is not None else 0
        if nb < self._ib or na < self._ia:
            raise RuntimeError("the sensors' data was reset (a new Flight?): use one trigger per flight")
        while self._ib < nb or self._ia < na:
            tb = round(bd[self._ib][0] * 1e6) if self._ib < nb else None
            ta = round(ad[self._ia][0] * 1e6) if self._ia < na else None
            t_us = tb if ta is None else (ta if tb is None else min(ta, tb))
            p = a = None
            if tb == t_us:
                p = bd[self._ib][1]
                self._ib += 1
            if ta == t_us:
                a = ad[self._ia][3]
                self._ia += 1
            if t_us <= self._last_us:
                self.duplicates += 1
                continue
            self._step(t_us, p, a)
            self.steps += 1

    def _feed_pad(self, baro_row, accel_row):
        t0 = round(min(baro_row[0], accel_row[0] if accel_row is not None else math.inf) * 1e6)
        p = baro_row[1]
        a = accel_row[3] if accel_row is not None else None
        self._last_us = t0 - (self.pad_samples + 1) * self.pad_period_us
        for k in range(self.pad_samples, 0, -1):
            self._step(t0 - k * self.pad_period_us, p, a)

    def specific_force_mps2(self, reading_z: float, state) -> float:
        """The axial specific force (+g at rest nose up) from RocketPy's accelerometer z reading."""
        if self.gravity_factor == 0 or state is None:
            return float(reading_z)
        return float(reading_z) + self.gravity_factor * self.g * axis_vertical_component(state)

    def _step(self, t_us, pressure_pa, accel_z):
        have = 0
        alt_mm = 0
        p_q4 = None
        acc_mm = None
        if pressure_pa is not None and math.isfinite(pressure_pa):
            p_q4 = int(round(pressure_pa * 16))
            alt_mm = pressure_to_alt_mm(p_q4)
            have |= HAVE_BARO
        if accel_z is not None and math.isfinite(accel_z):
            acc_mm = int(round(self.specific_force_mps2(accel_z, self._state) * 1000))
            have |= HAVE_ACCEL
        dt_us = 0 if self._index == 0 else t_us - self._last_us
        fc = self.fc
        fc.step(dt_us, alt_mm, acc_mm if acc_mm is not None else 0, have)
        if fc.events:
            for bit, name in enumerate(EVENT_NAMES):
                if fc.events & (1 << bit):
                    self.events.append(TriggerEvent(name, self._index, t_us / 1e6, fc.agl_mm / 1000))
        if self.record:
            self.rows_time_us.append(t_us)
            self.rows_p_q4.append(p_q4)
            self.rows_accel_mm.append(acc_mm)
        self._last_us = t_us
        self._index += 1

    # ----------------------------------------------------------------------------------------------

    def first(self, name):
        for e in self.events:
            if e.event == name:
                return e
        return None

    @property
    def drogue_time_s(self):
        e = self.first("drogue")
        return None if e is None else e.time_s

    @property
    def main_time_s(self):
        e = self.first("main")
        return None if e is None else e.time_s

    def columns(self) -> dict:
        """The recorded readings as flight-CSV columns (exactly the integers the board used:
        pressure = Pa x 16 / 16, acceleration = mm/s^2 / 1000; empty where a sensor had no reading)."""
        import numpy as np

        nan = float("nan")
        return {
            "time_s": np.array(self.rows_time_us, dtype=np.int64) / 1e6,
            "pressure_pa": np.array([nan if q is None else q / 16 for q in self.rows_p_q4]),
            "accel_mps2": np.array([nan if a is None else a / 1000 for a in self.rows_accel_mm]),
        }

    def write_csv(self, path, metadata=None) -> None:
        """Write what the board saw as a flight CSV (docs/FLIGHT_CSV.md)."""
        from desktop.io.flightcsv import write_flight_csv

        if not self.record:
            raise ValueError("this trigger was created with record=False")
        meta = {
            "source": "desktop/sim/rocketpy_trigger.py: RocketPy sensor readings as the closed-loop flight "
                      "computer stepped them",
            "sensor_profile": f"rocketpy {self.barometer.name}+"
                              f"{self.accelerometer.name if self.accelerometer else 'none'}",
            "pad_s": round(self.pad_samples * self.pad_period_us / 1e6, 6),
        }
        if self.config.values.get("accel_range_g"):
            meta["accel_range_g"] = self.config.values["accel_range_g"]
        if "baro_noise" in self.config.values:
            meta["baro_noise"] = self.config.values["baro_noise"]
        meta["main_deploy_m"] = self.config.values["main_deploy_m"]
        meta.update(metadata or {})
        cols = self.columns()
        if self.accelerometer is None:
            del cols["accel_mps2"]
        write_flight_csv(path, cols, metadata=meta, comments=[
            "Closed loop: the flight computer (shared/) flew inside RocketPy and these are its readings",
            "the first pad_s seconds repeat the first readings (RocketPy starts at ignition)",
        ])


# --------------------------------------------------------------------------------------------------
# Sensors from the project's part profiles


def board_sensors(profile: str = "bmp390+lsm6dso", rate_hz: float = 100.0, seed: int = 0):
    """(Barometer, Accelerometer) configured from a part profile (``sensor_models``'s
    ``rocketpy_kwargs()``), both sampled at the board's ``rate_hz`` with the part's RMS noise per
    reading, a constant offset drawn in +- the part's offset (barometer) or zero-g offset
    (accelerometer), and noise generators seeded from ``seed``. The accelerometer has
    ``consider_gravity=True``; scale error, lag and the transonic port error are not modelled
    (RocketPy's sensors have no such terms)."""
    import numpy as np
    from rocketpy.sensors import Accelerometer, Barometer

    from desktop.sim.sensor_models import parse_profile

    prof = parse_profile(profile)
    rng = np.random.default_rng([int(seed), 7])
    u_off, u_bias = rng.random(2)
    s_baro, s_acc = (int(x) for x in rng.integers(0, 2**63 - 1, size=2))
    bk = prof.baro.rocketpy_kwargs()
    bk.update(sampling_rate=float(rate_hz), noise_density=prof.baro.noise_pa / math.sqrt(rate_hz),
              constant_bias=(2.0 * u_off - 1.0) * prof.baro.offset_pa, seed=s_baro)
    ak = prof.accel.rocketpy_kwargs()
    ak.update(sampling_rate=float(rate_hz), noise_density=prof.accel.noise_rms_mps2 / math.sqrt(rate_hz),
              constant_bias=(2.0 * u_bias - 1.0) * prof.accel.offset_mps2, seed=s_acc)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Barometer(**bk), Accelerometer(consider_gravity=True, **ak)


def add_board_sensors(rocket, profile: str = "bmp390+lsm6dso", rate_hz: float = 100.0, seed: int = 0,
                      position=None):
    """``board_sensors`` attached to ``rocket`` at ``position`` (default: the dry centre of mass, in
    the rocket's own coordinates). Returns (barometer, accelerometer)."""
    baro, accel = board_sensors(profile, rate_hz, seed)
    pos = rocket.center_of_dry_mass_position if position is None else position
    rocket.add_sensor(baro, pos)
    rocket.add_sensor(accel, pos)
    return baro, accel


def config_for_profile(profile: str, **settings) -> Config:
    """A flight configuration for a part profile: its accelerometer range, plus ``settings``."""
    from desktop.sim.sensor_models import parse_profile

    prof = parse_profile(profile)
    top = prof.accel.full_scale_mps2
    values = {"accel_range_g": round(top / G0, 1) if math.isfinite(top) else 0}
    if _has_setting("baro_noise"):
        values["baro_noise"] = "low" if prof.baro.noise_pa < LOW_NOISE_PA else "standard"
    values.update(settings)
    return load_config(values)


# --------------------------------------------------------------------------------------------------
# A rocket TOML flown closed loop


@dataclass
class ClosedLoopFlight:
    flight: object  # rocketpy.Flight
    trigger: FlightComputerTrigger
    barometer: object
    accelerometer: object
    spec: object

    def rocketpy_event_s(self, name: str):
        """When RocketPy triggered parachute ``name`` (None if never)."""
        for t, chute in self.flight.parachute_events:
            if chute.name == name:
                return float(t)
        return None


def fly_closed_loop(rocket, profile: str | None = None, rate_hz: float | None = None, seed: int = 0,
                    config=None, pad_s: float = 5.0, max_time: float = 900.0,
                    time_overshoot: bool = False) -> ClosedLoopFlight:
    """Fly a rocket TOML (path or ``RocketSpec``) in RocketPy with the flight computer deciding both
    parachutes. Sensors: ``profile`` (default the file's [board] sensors) at ``rate_hz`` (default the
    file's rate). ``config``: dict of settings (main_deploy_m defaults to the file's [main]
    deploy_altitude_m, or 0, no main, when it has none). ``time_overshoot=False`` (RocketPy stops
    at every sample: the parachute triggers at the sample of the decision) unless told; see the
    module docstring."""
    from desktop.io.rocket_file import load_rocket
    from desktop.sim.trajectory import build_rocketpy

    is_path = isinstance(rocket, (str, bytes)) or hasattr(rocket, "__fspath__")
    spec = load_rocket(rocket) if is_path else rocket
    if spec.drogue is None:
        raise ValueError(f"{spec.path}: the rocket has no [drogue] parachute for the flight computer to fire")
    board = spec.board
    profile = profile or board.get("sensors", "bmp390+lsm6dso")
    rate_hz = float(rate_hz or board.get("rate_hz", 100.0))
    env, rkt = build_rocketpy(spec.replace(drogue=None, main=None))
    baro, accel = add_board_sensors(rkt, profile, rate_hz, seed)
    values = {"main_deploy_m": spec.main.deploy_altitude_m if spec.main is not None else 0}  # 0: no main
    if isinstance(config, Config):
        cfg = config
    else:
        values.update(config or {})
        cfg = config_for_profile(profile, **values)
    trig = FlightComputerTrigger(baro, accel, cfg, pad_s=pad_s)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rkt.add_parachute("drogue", cd_s=spec.drogue.cd_s_m2, trigger=trig.drogue, sampling_rate=rate_hz,
                          lag=spec.drogue.lag_s)
        if spec.main is not None:
            rkt.add_parachute("main", cd_s=spec.main.cd_s_m2, trigger=trig.main, sampling_rate=rate_hz,
                              lag=spec.main.lag_s)
        import rocketpy

        flight = rocketpy.Flight(rocket=rkt, environment=env, rail_length=spec.rail_length_m,
                                 inclination=spec.inclination_deg, heading=spec.heading_deg,
                                 max_time=max_time, time_overshoot=time_overshoot)
    trig.finish()
    return ClosedLoopFlight(flight, trig, baro, accel, spec)
