"""One flight of the rocket Monte-Carlo: the study's settings, the dispersed flight simulated into
the board's record, and every method run on it.

RocketPy flies the dispersed rocket (desktop/study/rocket_dispersions.py, desktop/sim/trajectory.py),
the sensor models turn it into the board's record (desktop/sim/sensor_models.py: noise, offsets,
bias, scale error, transonic static-port error, timing, all drawn from the flight's record seed),
and every method runs on that record:

- ``flight-computer``: the exact shared/ code through ``desktop.review.replay.replay`` (the record as
  the flight CSV would give it; the flight configuration of ``--config`` or the defaults, with the
  part's ``accel_range_g``, and the deployment plan: the rocket's [main] height, or no main, unless
  ``--main-altitude`` or the configuration sets it); its drogue event, i.e. the state machine's
  decision, is the detection. The simulated main parachute opens where the flight computer is
  configured to fire it.
- the comparison methods of desktop/study/rocket_comparison.py.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from desktop.study.rocket_comparison import COMPARISON_METHODS, baseline_inputs, comparison_methods
from desktop.study.rocket_dispersions import DEFAULT_DISPERSIONS, Dispersions, apply_draw, draw_flight

METHODS = ("flight-computer",) + COMPARISON_METHODS
DEFAULT_PROFILE = "bmp390+lsm6dso"


def main_deploy_plan_m(spec, config_values=None, main_deploy_m=None) -> float:
    """The main deployment height of the study (m AGL; 0: no main): ``main_deploy_m`` if given,
    else the flight configuration's, else the rocket's [main] height, else 0 (it has no main)."""
    if main_deploy_m is not None:
        return float(main_deploy_m)
    if config_values and "main_deploy_m" in config_values:
        return float(config_values["main_deploy_m"])
    return float(spec.main.deploy_altitude_m) if spec.main is not None else 0.0


@dataclass(frozen=True)
class StudySettings:
    """What a rocket study flies: the rocket file, the study seed, the board and the deployment plan."""

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


_ROCKET_SPECS: dict = {}


def rocket_spec(path):
    """The rocket file's description, read once per process."""
    from desktop.io.rocket_file import load_rocket

    key = str(path)
    if key not in _ROCKET_SPECS:
        _ROCKET_SPECS[key] = load_rocket(path)
    return _ROCKET_SPECS[key]


def simulate_flight(settings: StudySettings, index: int):
    """(draw, trajectory, board record) of flight ``index``."""
    from desktop.io.flightcsv import NO_MAIN
    from desktop.sim import trajectory as tr
    from desktop.sim.sensor_models import BoardConfig, make_record

    spec = rocket_spec(settings.rocket)
    draw = draw_flight(spec, settings.seed, index, settings.dispersions)
    flown = apply_draw(spec, draw, settings.main_deploy_m)
    try:
        traj = tr.simulate_rocket(flown, after_main_s=settings.after_main_s if flown.main else None)
    finally:
        tr.forget_motors_except(spec.motor)
    traj = traj.ended_after_main(settings.main_deploy_m, settings.after_main_s)
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
