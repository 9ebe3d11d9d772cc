"""Monte-Carlo over a rocket design: ``python -m desktop montecarlo --rocket ROCKET.toml``.

Each flight i of seed S draws, from ``numpy.random.default_rng([S, i])`` in a fixed order, the
dispersions of ``Dispersions`` (motor total impulse and burn time, drag, dry mass, wind, rail
inclination and heading) and a sensor-record seed; RocketPy flies the dispersed rocket
(desktop/sim/trajectory.py), the sensor models turn it into the board's record (desktop/sim/sensor_models.py:
noise, offsets, bias, scale error, transonic static-port error, timing, all drawn from that seed),
and every method runs on that record:

- ``flight-computer``: the exact shared/ code through ``desktop.review.replay.replay`` (the record as the
  flight CSV would give it; the flight configuration of ``--config`` or the defaults, with the
  part's ``accel_range_g``, and the deployment plan: the rocket's [main] height, or no main, unless
  ``--main-altitude`` or the configuration sets it); its drogue event, i.e. the state machine's
  decision, is the detection. The simulated main parachute opens where the flight computer is
  configured to fire it.
- ``seed-kalman/seed``: the seed's float Kalman filter with gains from the seed's recursion at the
  record's (median) sample period, and the seed's three-falling-samples rule.
- ``boxcar/seed``: moving average over the seed study's 2.0 s (40 samples at 20 Hz; the same
  duration in samples at the board's rate), seed rule.
- ``butterworth/seed``: 4th order, 1 Hz, designed at the record's rate, seed rule.

The comparison methods get the barometric altitude (``shared.altitude``, relative to the pad
pressure in the metadata) and the axial accelerometer, with a missing reading (an empty cell) held
from the previous sample, and the seed study's lockout (1 s after the first sample above 30 m/s^2).

Flight i depends only on (seed, i): results are the same whatever the number of worker processes.
Docs: docs/SIMULATION.md ("Monte-Carlo over a rocket design").
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from desktop.errors import UsageError
from desktop.io.config_file import config_file_values
from desktop.sim.seed_model import SEED_PAPER_G0_MPS2
from desktop.study import baselines
from desktop.study.metrics import METRIC_KEYS, format_cell, metrics, table_lines

METHODS = ("flight-computer", "seed-kalman/seed", "boxcar/seed", "butterworth/seed")
DEFAULT_PROFILE = "bmp390+lsm6dso"
BOXCAR_SECONDS = baselines.BOXCAR_WINDOW * baselines.SEED_T_S  # 40 samples at 20 Hz = 2.0 s
_MD_HEADERS = ("mean \\|err\\| s", "mean err s", "median \\|err\\| s", "p95 \\|err\\| s", "max \\|err\\| s",
               "mean \\|v\\| m/s", ">1 s early", "none")


def main_deploy_plan_m(spec, config_values=None, main_deploy_m=None) -> float:
    """The main deployment height of the study (m AGL; 0: no main): ``main_deploy_m`` if given,
    else the flight configuration's, else the rocket's [main] height, else 0 (it has no main)."""
    if main_deploy_m is not None:
        return float(main_deploy_m)
    if config_values and "main_deploy_m" in config_values:
        return float(config_values["main_deploy_m"])
    return float(spec.main.deploy_altitude_m) if spec.main is not None else 0.0


@dataclass(frozen=True)
class Dispersions:
    """Half-widths of the uniform draws (docs/SIMULATION.md explains each range)."""

    impulse: float = 0.03  # total impulse, fraction
    burn_time: float = 0.03  # burn time, fraction (thrust scaled so the impulse is as drawn)
    cd: float = 0.10  # drag coefficient (every point of the table), fraction
    dry_mass: float = 0.03  # dry mass and inertia, fraction
    max_wind_mps: float = 9.0  # wind speed uniform in 0..max, direction uniform
    inclination_deg: float = 2.0  # rail inclination: nominal +- this (at most 90), heading uniform


DEFAULT_DISPERSIONS = Dispersions()
MAX_WIND_LIMIT_MPS = 30.0  # --max-wind-mps above this is outside what a launch would fly in


@dataclass(frozen=True)
class FlightDraw:
    index: int
    impulse_scale: float
    burn_time_scale: float
    cd_scale: float
    dry_mass_scale: float
    wind_speed_mps: float
    wind_from_deg: float
    inclination_deg: float
    heading_deg: float
    record_seed: int

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def draw_flight(spec, seed: int, index: int, disp: Dispersions = DEFAULT_DISPERSIONS) -> FlightDraw:
    """The dispersions of flight ``index``: ``default_rng([seed, index])``, always the same draws in
    the same order."""
    rng = np.random.default_rng([int(seed), int(index)])
    u = rng.random(8)
    incl = spec.inclination_deg + (2.0 * u[6] - 1.0) * disp.inclination_deg
    u = [float(x) for x in u]
    return FlightDraw(
        index=int(index),
        impulse_scale=1.0 + (2.0 * u[0] - 1.0) * disp.impulse,
        burn_time_scale=1.0 + (2.0 * u[1] - 1.0) * disp.burn_time,
        cd_scale=1.0 + (2.0 * u[2] - 1.0) * disp.cd,
        dry_mass_scale=1.0 + (2.0 * u[3] - 1.0) * disp.dry_mass,
        wind_speed_mps=u[4] * disp.max_wind_mps,
        wind_from_deg=u[5] * 360.0,
        inclination_deg=min(90.0, float(incl)),
        heading_deg=u[7] * 360.0,
        record_seed=int(rng.integers(0, 2**63 - 1)),
    )


def apply_draw(spec, draw: FlightDraw, main_deploy_m: float | None = None):
    """The dispersed rocket. The thrust curve's times are scaled by the burn-time factor and its
    thrust by impulse/burn-time (propellant mass unchanged); the main parachute, if any, opens where
    the flight computer is configured to fire it (``main_deploy_m``; 0: never, no main)."""
    eng = spec.motor
    b, i = draw.burn_time_scale, draw.impulse_scale
    motor = dataclasses.replace(eng, time_s=tuple(t * b for t in eng.time_s),
                                thrust_n=tuple(f * i / b for f in eng.thrust_n))
    changes = dict(
        motor=motor,
        dry_mass_kg=spec.dry_mass_kg * draw.dry_mass_scale,
        inertia_lateral_kgm2=spec.inertia_lateral_kgm2 * draw.dry_mass_scale,
        inertia_roll_kgm2=spec.inertia_roll_kgm2 * draw.dry_mass_scale,
        wind_speed_mps=draw.wind_speed_mps,
        wind_from_deg=draw.wind_from_deg,
        inclination_deg=draw.inclination_deg,
        heading_deg=draw.heading_deg,
    )
    if spec.cd_table is None:
        changes["cd"] = spec.cd * draw.cd_scale
    else:
        changes["cd_table"] = tuple((m, c * draw.cd_scale) for m, c in spec.cd_table)
    if spec.main is not None and main_deploy_m is not None:
        changes["main"] = (dataclasses.replace(spec.main, deploy_altitude_m=float(main_deploy_m))
                           if main_deploy_m else None)
    return spec.replace(**changes)


# --------------------------------------------------------------------------------------------------
# One flight


@dataclass(frozen=True)
class StudySettings:
    rocket: str
    seed: int
    profile: str
    rate_hz: float
    pad_s: float
    main_deploy_m: float  # 0: no main
    dispersions: Dispersions = DEFAULT_DISPERSIONS
    after_main_s: float = 5.0  # record ends this long after the main crosses main_deploy_m
    # the flight configuration (``--config``) as (key, value) pairs; main_deploy_m is the field above
    config: tuple = ()


def settings_for(rocket_path, seed: int, profile: str | None = None, pad_s: float | None = None,
                 rate_hz: float | None = None, dispersions: Dispersions = DEFAULT_DISPERSIONS,
                 main_deploy_m: float | None = None, config_values: dict | None = None) -> StudySettings:
    """Study settings: the rocket file's [board] defaults and deployment plan unless given;
    ``config_values``: a flight configuration (docs/CONFIG.md), validated here."""
    from desktop.io.rocket_file import load_rocket
    from desktop.sim.sensor_models import BoardConfig, parse_profile
    from shared.config import load_config

    spec = load_rocket(rocket_path)
    board = spec.board
    prof = parse_profile(profile or board.get("sensors", DEFAULT_PROFILE)).name
    s = StudySettings(
        rocket=str(rocket_path), seed=int(seed), profile=prof,
        rate_hz=float(rate_hz if rate_hz is not None else board.get("rate_hz", 100.0)),
        pad_s=float(pad_s if pad_s is not None else board.get("pad_s", 20.0)),
        main_deploy_m=main_deploy_plan_m(spec, config_values, main_deploy_m),
        dispersions=dispersions,
        config=tuple(sorted((k, v) for k, v in (config_values or {}).items() if k != "main_deploy_m")),
    )
    load_config(dict(s.config, main_deploy_m=s.main_deploy_m))  # one-line ConfigError if invalid
    BoardConfig(rate_hz=s.rate_hz, pad_s=s.pad_s).validate()
    return s


_SPEC_CACHE: dict = {}


def _spec(path):
    from desktop.io.rocket_file import load_rocket

    key = str(path)
    if key not in _SPEC_CACHE:
        _SPEC_CACHE[key] = load_rocket(path)
    return _SPEC_CACHE[key]


def simulate_flight(settings: StudySettings, index: int):
    """(draw, trajectory, board record) of flight ``index``."""
    from desktop.io.flightcsv import NO_MAIN
    from desktop.sim import trajectory as tr
    from desktop.sim.sensor_models import BoardConfig, make_record

    spec = _spec(settings.rocket)
    draw = draw_flight(spec, settings.seed, index, settings.dispersions)
    flown = apply_draw(spec, draw, settings.main_deploy_m)
    try:
        traj = tr.simulate_rocket(flown, after_main_s=settings.after_main_s if flown.main else None)
    finally:
        # the dispersed motor is used once: keep the cache of desktop/sim/trajectory.py small
        nominal = (spec.motor.time_s, spec.motor.thrust_n)
        for key in [k for k in tr._MOTOR_CACHE if k[1:3] != nominal]:
            del tr._MOTOR_CACHE[key]
    # end the record a few seconds after the descent crosses the main altitude (the rest of the
    # descent costs replay time and decides nothing)
    after = traj.time_s > traj.apogee_time_s
    below = np.flatnonzero(after & (traj.altitude_m <= settings.main_deploy_m))
    if below.size and settings.main_deploy_m:
        traj = traj.truncated(float(traj.time_s[below[0]]) + settings.after_main_s)
    board = BoardConfig(rate_hz=settings.rate_hz, pad_s=settings.pad_s)
    record = make_record(traj, settings.profile, seed=draw.record_seed, board=board)
    record.metadata.update({f"draw_{k}": round(v, 6) if isinstance(v, float) else v
                            for k, v in draw.as_dict().items() if k != "record_seed"})
    record.metadata["study_seed"] = settings.seed
    record.metadata["main_deploy_m"] = settings.main_deploy_m if settings.main_deploy_m else NO_MAIN
    return draw, traj, record


def record_log(record):
    """The FlightLog that writing ``record`` as a flight CSV and reading it back would give (the
    writer's rounding: time to 1 us, pressure to 0.01 Pa, acceleration to 0.1 mm/s^2), in memory."""
    from desktop.io.flightcsv import FlightLog

    t = np.asarray(record.time_s, dtype=np.float64)
    time_us = np.array([round(float(x) * 1e6) for x in t], dtype=np.int64)

    def fixed(values, decimals):
        return np.array([math.nan if math.isnan(x) else float(f"{x:.{decimals}f}")
                         for x in np.asarray(values, dtype=np.float64).tolist()])

    meta = {}
    for k, v in record.metadata.items():
        meta[k] = repr(float(v)) if isinstance(v, (float, np.floating)) else str(v)
    n = len(t)
    return FlightLog(
        path=f"<{record.metadata.get('rocket', 'rocket')}, seed {record.metadata.get('seed')}>",
        metadata=meta, comments=list(record.comments),
        columns=["time_s", "pressure_pa", "accel_mps2"],
        time_s=time_us / 1e6, time_us=time_us,
        pressure_pa=fixed(record.pressure_pa, 2), altitude_m=None,
        accel_mps2=fixed(record.accel_mps2, 4), extra={}, line_numbers=np.arange(n, dtype=np.int64),
    )


def _hold(x: np.ndarray) -> np.ndarray:
    """Missing readings (NaN) hold the previous one (the first valid one before any)."""
    x = np.asarray(x, dtype=np.float64)
    ok = ~np.isnan(x)
    if ok.all():
        return x
    if not ok.any():
        return np.zeros_like(x)
    idx = np.where(ok, np.arange(len(x)), 0)
    np.maximum.accumulate(idx, out=idx)
    idx[: int(np.argmax(ok))] = int(np.argmax(ok))
    return x[idx]


def baseline_inputs(log, replay_result=None):
    """(time_s, altitude_m, accel_mps2) for the comparison methods: the barometric altitude the
    board computes (``shared.altitude`` on Pa x 16) above the pad pressure of the metadata, and the
    axial accelerometer; missing readings held. ``replay_result`` (of the same log, whose ground
    reference is the metadata's) saves converting the pressures again: its ``raw_agl_m`` is the same."""
    from desktop.review.replay import ground_alt_mm, readings

    if replay_result is not None and log.metadata_float("ground_pressure_pa") is not None:
        alt_m = np.asarray(replay_result.raw_agl_m, dtype=np.float64)
    else:
        _dt, alt_mm, _acc, _have = readings(log)
        alt = alt_mm.astype(np.float64)
        alt[np.isnan(log.pressure_pa)] = np.nan
        ground = ground_alt_mm(log)
        if ground is None:
            ground = float(np.nanmedian(alt[: max(1, len(alt) // 20)]))
        alt_m = (alt - ground) / 1000.0
    return log.time_s, _hold(alt_m), _hold(log.accel_mps2)


def boxcar_window(time_s) -> int:
    """Samples in the seed study's 2.0 s boxcar at this record's sample period."""
    return max(1, int(round(BOXCAR_SECONDS / baselines.sample_period_s(time_s))))


def comparison_methods(time_s, altitude_m, accel_mps2) -> dict:
    """Detection time (s, NaN if none) of each comparison method on one flight's record."""
    t = np.asarray(time_s, dtype=np.float64)
    alt = np.asarray(altitude_m, dtype=np.float64)
    acc = np.asarray(accel_mps2, dtype=np.float64)
    armed = baselines.armed_mask(t, acc)
    period = baselines.sample_period_s(t)
    T = round(period, 4)  # as baselines' seed-kalman methods: gains for the (rounded) period
    s = baselines.seed_kalman(alt, acc - SEED_PAPER_G0_MPS2, T)[0][0]
    out = {"seed-kalman/seed": float(baselines.detect_seed_rule(t, s, armed)[0])}
    box = baselines.boxcar(alt, window=boxcar_window(t))
    out["boxcar/seed"] = float(baselines.detect_seed_rule(t, box, armed)[0])
    but = baselines.butterworth(alt, 1.0 / period)
    out["butterworth/seed"] = float(baselines.detect_seed_rule(t, but, armed)[0])
    return out


def flight_computer_config(log, settings: StudySettings):
    """The study's flight configuration for ``log``, with the deployment plan of its metadata."""
    from desktop.review.replay import config_for

    return config_for(log, overrides=dict(settings.config))


def evaluate_flight(settings: StudySettings, index: int, detail: bool = False) -> dict:
    """Simulate flight ``index`` and run every method on its record. Returns a JSON-ready dict
    (with ``detail``, also the trajectory, record, log and replay under ``"_detail"``)."""
    from desktop.review.replay import replay
    from shared.flight import COAST, ERR_ACCEL_CLIPPED

    t0 = time.perf_counter()
    draw, traj, record = simulate_flight(settings, index)
    t1 = time.perf_counter()
    log = record_log(record)
    config = flight_computer_config(log, settings)
    res = replay(log, config)
    t2 = time.perf_counter()
    t_b, alt_b, acc_b = baseline_inputs(log, res)
    det = {"flight-computer": math.nan}
    det.update(comparison_methods(t_b, alt_b, acc_b))
    t3 = time.perf_counter()

    def ev(name):
        e = res.first(name)
        return (e.time_s, e.index) if e is not None else (math.nan, -1)

    drogue_t, drogue_i = ev("drogue")
    main_t, main_i = ev("main")
    det["flight-computer"] = drogue_t
    burnout = float(traj.burnout_time_s)
    pyro_times = [e.time_s for e in res.events if e.event in ("drogue", "main")]
    coast_idx = np.flatnonzero(res.state == COAST)
    true_v = {n: (float(np.interp(d, traj.time_s, traj.velocity_mps)) if math.isfinite(d) else math.nan)
              for n, d in det.items()}
    fc = {
        "launch_s": ev("launch")[0],
        "burnout_s": ev("burnout")[0],
        "apogee_s": ev("apogee")[0],
        "drogue_s": drogue_t,
        "main_s": main_t,
        "first_coast_s": float(log.time_s[coast_idx[0]]) if coast_idx.size else math.nan,
        "velocity_at_drogue_mps": float(res.vel_mps[drogue_i]) if drogue_i >= 0 else math.nan,
        "agl_at_drogue_m": float(res.agl_m[drogue_i]) if drogue_i >= 0 else math.nan,
        "true_altitude_at_drogue_m": (float(np.interp(drogue_t, traj.time_s, traj.altitude_m))
                                      if drogue_i >= 0 else math.nan),
        "true_altitude_at_main_m": (float(np.interp(main_t, traj.time_s, traj.altitude_m))
                                    if main_i >= 0 else math.nan),
        "fired_before_burnout": bool(any(t < burnout for t in pyro_times)),
        "pyro_before_launch": bool(any(t < 0.0 for t in pyro_times)),
        "accel_clipped": bool(res.errors & ERR_ACCEL_CLIPPED),
        "errors": int(res.errors),
    }
    out = {
        "index": int(index),
        "draw": draw.as_dict(),
        "true_apogee_s": float(traj.apogee_time_s),
        "true_apogee_m": float(traj.apogee_m),
        "true_burnout_s": burnout,
        "max_mach": float(traj.max_mach),
        "transonic_c": float(record.parameters["transonic_c"]),
        "accel_bias_mps2": float(record.parameters["accel_bias_mps2"]),
        "accel_scale_error": float(record.parameters["accel_scale_error"]),
        "baro_offset_pa": float(record.parameters["baro_offset_pa"]),
        "samples": int(len(log)),
        "detections": det,
        "true_velocity_at_detection": true_v,
        "flight_computer": fc,
        "timing_s": {"simulate": t1 - t0, "replay": t2 - t1, "comparison": t3 - t2},
    }
    if detail:
        out["_detail"] = {"trajectory": traj, "record": record, "log": log, "replay": res,
                          "baseline_inputs": (t_b, alt_b, acc_b)}
    return out


# --------------------------------------------------------------------------------------------------
# The study


def _import_rocketpy():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import rocketpy  # noqa: F401  (once per process: ~1.2 s)


def _worker_init():
    import warnings

    warnings.simplefilter("ignore")  # a worker process prints nothing but its results
    _import_rocketpy()


def _worker(task):
    settings, index = task
    return evaluate_flight(settings, index)


class RocketStudyResult:
    def __init__(self, settings: StudySettings, flights: list, speed: dict, name: str):
        self.settings = settings
        self.flights = flights
        self.speed = speed
        self.name = name
        apo = np.array([f["true_apogee_s"] for f in flights])
        self.table = {}
        for m in METHODS:
            d = np.array([f["detections"][m] for f in flights], dtype=np.float64)
            v = np.array([f["true_velocity_at_detection"][m] for f in flights], dtype=np.float64)
            self.table[m] = metrics(d, apo, v)
        self.fc_summary = flight_computer_summary(flights, settings.main_deploy_m)

    def errors(self, method: str) -> np.ndarray:
        return np.array([f["detections"][method] - f["true_apogee_s"] for f in self.flights])

    def parameters(self) -> dict:
        s = self.settings
        return {
            "rocket": s.rocket, "name": self.name, "flights": len(self.flights), "seed": s.seed,
            "sensor_profile": s.profile, "rate_hz": s.rate_hz, "pad_s": s.pad_s,
            "main_deploy_m": s.main_deploy_m, "dispersions": dataclasses.asdict(s.dispersions),
            "record_ends_after_main_crossing_s": s.after_main_s,
            "comparison": {
                "boxcar_seconds": BOXCAR_SECONDS,
                "butterworth": {"order": baselines.BUTTER_ORDER, "cutoff_hz": baselines.BUTTER_CUTOFF_HZ},
                "lockout_s_after_launch": baselines.LOCKOUT_S,
                "launch_threshold_mps2": baselines.LAUNCH_THRESHOLD_MPS2,
            },
        }

    def to_json(self, per_flight: bool = True) -> dict:
        out = {
            "seed": self.settings.seed,
            "parameters": self.parameters(),
            "methods": _clean(self.table),
            "flight_computer": _clean(self.fc_summary),
            "speed": _clean(self.speed),
        }
        if per_flight:
            out["flights"] = _clean(self.flights)
        return out


def _clean(x):
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items() if not k.startswith("_")}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return None if not math.isfinite(float(x)) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    return x


def flight_computer_summary(flights: list, main_deploy_m: float) -> dict:
    """The flight computer's extra rows: firings before burnout, main deployments and their
    altitude error (truth at the main event - the configured altitude), pyro events before launch."""
    fc = [f["flight_computer"] for f in flights]
    main_alt = np.array([x["true_altitude_at_main_m"] for x in fc], dtype=np.float64)
    ok = np.isfinite(main_alt)
    err = main_alt[ok] - main_deploy_m
    nan = math.nan
    return {
        "n_flights": len(flights),
        "n_fired_before_burnout": int(sum(x["fired_before_burnout"] for x in fc)),
        "n_pyro_before_launch": int(sum(x["pyro_before_launch"] for x in fc)),
        "n_main": int(ok.sum()),
        "main_deploy_m": float(main_deploy_m),  # 0: no main
        "main_altitude_error_mean_m": float(np.mean(err)) if err.size else nan,
        "main_altitude_error_mean_abs_m": float(np.mean(np.abs(err))) if err.size else nan,
        "main_altitude_error_max_abs_m": float(np.max(np.abs(err))) if err.size else nan,
        "n_accel_clipped": int(sum(x["accel_clipped"] for x in fc)),
    }


def run_rocket_study(settings: StudySettings, n_flights: int, workers: int | None = None,
                     progress: bool = False) -> RocketStudyResult:
    """Flights 0..n_flights-1 over ``workers`` processes (default: all cores; 1: in this process)."""
    import multiprocessing as mp

    n_flights = int(n_flights)
    if n_flights < 1:
        raise ValueError("need at least one flight")
    workers = int(workers or os.cpu_count() or 1)
    workers = max(1, min(workers, n_flights))
    tasks = [(settings, i) for i in range(n_flights)]
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n_flights, unit="flight", file=sys.stderr, desc=Path(settings.rocket).stem,
                   leave=False)
    t_start = time.perf_counter()
    results = []
    try:
        if workers == 1:
            _import_rocketpy()
            t_ready = time.perf_counter()
            for task in tasks:
                results.append(_worker(task))
                if bar is not None:
                    bar.update(1)
        else:
            ctx = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else mp.get_context()
            with ctx.Pool(workers, initializer=_worker_init) as pool:
                pool.apply(time.sleep, (0,))  # a worker is ready (RocketPy imported)
                t_ready = time.perf_counter()
                for r in pool.imap_unordered(_worker, tasks, chunksize=1):
                    results.append(r)
                    if bar is not None:
                        bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    t_end = time.perf_counter()
    results.sort(key=lambda r: r["index"])
    busy = sum(sum(r["timing_s"].values()) for r in results)
    speed = {
        "workers": workers,
        "wall_s": t_end - t_start,
        "startup_s": t_ready - t_start,
        "flights_per_minute": 60.0 * n_flights / max(t_end - t_ready, 1e-9),
        "flights_per_minute_with_startup": 60.0 * n_flights / max(t_end - t_start, 1e-9),
        "per_flight_s": {k: sum(r["timing_s"][k] for r in results) / n_flights
                         for k in ("simulate", "replay", "comparison")},
        "busy_s": busy,
    }
    return RocketStudyResult(settings, results, speed, _spec(settings.rocket).name)


# --------------------------------------------------------------------------------------------------
# Output


def summary_lines(result: RocketStudyResult) -> list[str]:
    s = result.fc_summary
    n = s["n_flights"]
    main = (f"main deployments {s['n_main']}/{n}, truth altitude at the main event - "
            f"{s['main_deploy_m']:g} m: mean {s['main_altitude_error_mean_m']:+.1f} m, mean |err| "
            f"{s['main_altitude_error_mean_abs_m']:.1f} m, max |err| "
            f"{s['main_altitude_error_max_abs_m']:.1f} m" if s["n_main"] else f"main deployments 0/{n}")
    if not s["main_deploy_m"]:
        main += " (no main planned)"
    return [
        f"flight-computer: fired before burnout {s['n_fired_before_burnout']}/{n}; pyro event before "
        f"launch {s['n_pyro_before_launch']}/{n}; {main}; accelerometer clipped on "
        f"{s['n_accel_clipped']}/{n}",
    ]


def format_table(result: RocketStudyResult) -> str:
    p = result.parameters()
    title = (f"{p['name']} ({p['rocket']}): {p['flights']} flights, seed {p['seed']}, "
             f"{p['sensor_profile']} at {p['rate_hz']:g} Hz, pad {p['pad_s']:g} s; "
             "error = detection - true apogee (s)")
    lines = table_lines(title, result.table) + summary_lines(result)
    return "\n".join(lines)


def format_markdown(result: RocketStudyResult) -> str:
    lines = ["| method | " + " | ".join(_MD_HEADERS) + " |", "|---" * (len(_MD_HEADERS) + 1) + "|"]
    for name, m in result.table.items():
        shown = f"**{name}**" if name == "flight-computer" else name
        lines.append(f"| {shown} | " + " | ".join(format_cell(k, m[k]) for k in METRIC_KEYS) + " |")
    return "\n".join(lines)


def speed_line(result: RocketStudyResult) -> str:
    s = result.speed
    pf = s["per_flight_s"]
    return (f"{len(result.flights)} flights on {s['workers']} process(es): {s['wall_s']:.1f} s wall, "
            f"{s['flights_per_minute']:.0f} flights/minute after {s['startup_s']:.1f} s start-up "
            f"({s['flights_per_minute_with_startup']:.0f} including it); per flight: simulation "
            f"{pf['simulate']:.2f} s, replay {pf['replay']:.2f} s, comparison methods "
            f"{pf['comparison']:.2f} s")


def write_plots(result: RocketStudyResult, out_dir, example_index: int = 0) -> list[Path]:
    """Error histograms per method, one example flight, and the flight computer's error against
    the flight's parameters; PNGs in ``out_dir``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    p = result.parameters()
    stem = Path(p["rocket"]).stem
    title = (f"{p['name']}: {p['flights']} flights, seed {p['seed']}, {p['sensor_profile']} at "
             f"{p['rate_hz']:g} Hz")

    # 1. Error histograms.
    errs = {m: result.errors(m) for m in METHODS}
    fig, axes = plt.subplots(len(METHODS), 1, figsize=(10, 2.3 * len(METHODS) + 0.8), squeeze=False)
    for ax, m in zip(axes[:, 0], METHODS, strict=True):
        e = errs[m]
        ok = e[np.isfinite(e)]
        lo = float(np.min(ok)) if ok.size else -1.0
        hi = float(np.max(ok)) if ok.size else 1.0
        pad = max(0.02, 0.05 * (hi - lo))
        ax.hist(ok, bins=np.linspace(lo - pad, hi + pad, 50), color="tab:green" if m == "flight-computer"
                else "tab:blue", alpha=0.85)
        ax.axvline(0, color="k", linewidth=0.8)
        t = result.table[m]
        ax.set_title(f"{m}: mean |err| {t['mean_abs_error_s']:.3f} s, p95 {t['p95_abs_error_s']:.3f} s, "
                     f"mean err {t['mean_error_s']:+.3f} s, none {t['n_no_detection']}", fontsize=9)
        ax.set_ylabel("flights")
        ax.set_xlabel("detection - true apogee (s)")
        ax.grid(alpha=0.3)
    fig.suptitle(f"Timing error per method (each panel its own scale)\n{title}", fontsize=10)
    fig.tight_layout()
    path = out / f"{stem}_error_histograms.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    written.append(path)

    # 2. One example flight (re-simulated in this process: deterministic).
    ex = evaluate_flight(result.settings, example_index, detail=True)
    d = ex["_detail"]
    traj, log, rep = d["trajectory"], d["log"], d["replay"]
    t_b, alt_b, acc_b = d["baseline_inputs"]
    apo = traj.apogee_time_s
    T = round(baselines.sample_period_s(t_b), 4)
    sk = baselines.seed_kalman(alt_b, acc_b - SEED_PAPER_G0_MPS2, T)[0][0]
    box = baselines.boxcar(alt_b, window=boxcar_window(t_b))[0]
    but = baselines.butterworth(alt_b, 1.0 / baselines.sample_period_s(t_b))[0]
    colors = {"flight-computer": "tab:green", "seed-kalman/seed": "tab:blue", "boxcar/seed": "tab:orange",
              "butterworth/seed": "tab:purple"}
    fig, axes = plt.subplots(3, 1, figsize=(11, 11), gridspec_kw={"height_ratios": [1.1, 1.2, 0.9]})
    full, zoom, vel = axes
    for ax in (full, zoom):
        ax.plot(log.time_s, rep.raw_agl_m, ".", color="0.6", markersize=2, label="barometer (raw, above pad)")
        ax.plot(traj.time_s, traj.altitude_m, color="k", linewidth=1.2, label="truth")
        ax.plot(log.time_s, rep.agl_m, color=colors["flight-computer"], linewidth=1.4,
                label="flight computer (filtered)")
        ax.plot(t_b, sk, color=colors["seed-kalman/seed"], linewidth=1.0, label="seed Kalman position")
        ax.plot(t_b, box, color=colors["boxcar/seed"], linewidth=1.0, label=f"boxcar {BOXCAR_SECONDS:g} s")
        ax.plot(t_b, but, color=colors["butterworth/seed"], linewidth=1.0, label="Butterworth 1 Hz")
    for ax in (full, zoom, vel):
        ax.axvline(apo, color="k", linestyle=":", linewidth=1.2, label="true apogee")
        for m in METHODS:
            x = ex["detections"][m]
            if math.isfinite(x):
                ax.axvline(x, color=colors[m], linestyle="--", linewidth=1.2,
                           label=f"{m} ({x - apo:+.3f} s)")
        ax.grid(alpha=0.3)
        ax.set_xlabel("time since ignition (s)")
    full.set_xlim(min(-2.0, float(log.time_s[0])), float(log.time_s[-1]))
    full.set_ylabel("altitude above pad (m)")
    full.set_title("whole record (the pad before ignition at negative times)")
    lo, hi = apo - 3.0, apo + 3.0
    zoom.set_xlim(lo, hi)
    inside = (traj.time_s >= lo) & (traj.time_s <= hi)
    ztop, zbot = float(np.max(traj.altitude_m[inside])), float(np.min(traj.altitude_m[inside]))
    zoom.set_ylim(zbot - 0.3 * (ztop - zbot) - 5, ztop + 0.15 * (ztop - zbot) + 5)
    zoom.set_ylabel("altitude above pad (m)")
    zoom.set_title("around apogee")
    vel.plot(traj.time_s, traj.velocity_mps, color="k", linewidth=1.2, label="truth (vertical)")
    vel.plot(log.time_s, rep.vel_mps, color=colors["flight-computer"], linewidth=1.2,
             label="flight computer velocity estimate")
    vel.set_xlim(lo, hi)
    vel.set_ylim(-35, 35)
    vel.axhline(0, color="k", linewidth=0.6)
    vel.set_ylabel("vertical velocity (m/s)")
    vel.set_title("velocity around apogee")
    handles, labels = zoom.get_legend_handles_labels()
    zoom.legend(handles, labels, loc="lower center", fontsize=8, ncol=2)
    vel.legend(loc="upper right", fontsize=8)
    dr = ex["draw"]
    fig.suptitle(
        f"{p['name']}, flight {example_index} (seed {p['seed']}): apogee {traj.apogee_m:.0f} m at "
        f"{apo:.2f} s, max Mach {traj.max_mach:.2f}, wind {dr['wind_speed_mps']:.1f} m/s, rail "
        f"{dr['inclination_deg']:.1f} deg, transonic c {ex['transonic_c']:+.3f}", fontsize=10)
    fig.tight_layout()
    path = out / f"{stem}_example_flight.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    written.append(path)

    # 3. Flight-computer error against the flight's parameters.
    e = errs["flight-computer"]
    fl = result.flights
    xs = [
        ("max Mach", [f["max_mach"] for f in fl]),
        ("transonic coefficient c (dp = c q w(M))", [f["transonic_c"] for f in fl]),
        ("wind speed (m/s)", [f["draw"]["wind_speed_mps"] for f in fl]),
        ("drag coefficient scale", [f["draw"]["cd_scale"] for f in fl]),
        ("rail inclination (deg)", [f["draw"]["inclination_deg"] for f in fl]),
        ("accelerometer bias (m/s²)", [f["accel_bias_mps2"] for f in fl]),
    ]
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5), sharey=True)
    for ax, (label, x) in zip(axes.flat, xs, strict=True):
        ax.plot(x, e, "o", markersize=3, color="tab:green")
        ax.axhline(0, color="k", linewidth=0.6)
        ax.set_xlabel(label)
        ax.grid(alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel("flight computer: drogue - true apogee (s)")
    fig.suptitle(f"Flight computer timing error against the flight's draws\n{title}", fontsize=10)
    fig.tight_layout()
    path = out / f"{stem}_fc_error_vs_draws.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    written.append(path)
    return written


def export_flight_csv(settings: StudySettings, index: int, path) -> dict:
    """Write the board record of flight ``index`` (drawn parameters in the metadata)."""
    from desktop.sim.sensor_models import write_record

    draw, traj, record = simulate_flight(settings, index)
    write_record(path, record)
    return {"draw": draw.as_dict(), "true_apogee_s": traj.apogee_time_s, "true_apogee_m": traj.apogee_m}


# --------------------------------------------------------------------------------------------------
# CLI (arguments registered by desktop/study/seed_study.py)


def main(args) -> int:
    if args.params != "montecarlo":
        raise UsageError("--params applies to the seed study, not to --rocket")
    if args.workers is not None and args.workers < 1:
        raise UsageError("--workers must be >= 1")
    if args.max_wind_mps is not None and not 0 <= args.max_wind_mps <= MAX_WIND_LIMIT_MPS:
        raise UsageError(f"--max-wind-mps must be 0 to {MAX_WIND_LIMIT_MPS:g} m/s")
    disp = dataclasses.replace(DEFAULT_DISPERSIONS, max_wind_mps=args.max_wind_mps) \
        if args.max_wind_mps is not None else DEFAULT_DISPERSIONS
    config_values = config_file_values(args.config) if args.config else None
    settings = settings_for(args.rocket, args.seed, profile=args.sensors, pad_s=args.pad_s,
                            dispersions=disp, main_deploy_m=args.main_altitude,
                            config_values=config_values)
    if args.export_csv:
        info = export_flight_csv(settings, args.flight, args.export_csv)
        print(f"wrote {args.export_csv}: flight {args.flight} of seed {args.seed}, true apogee "
              f"{info['true_apogee_m']:.1f} m at {info['true_apogee_s']:.3f} s",
              file=sys.stderr if args.json else sys.stdout)
        return 0
    progress = (not args.json) and sys.stderr.isatty()
    result = run_rocket_study(settings, args.flights, workers=args.workers, progress=progress)
    if args.json:
        print(json.dumps(result.to_json(), indent=1))
    else:
        print(format_table(result))
        print(speed_line(result))
    if args.plots:
        for path in write_plots(result, args.plots):
            print(f"wrote {path}", file=sys.stderr)
    return 0
