"""The seed paper's simulation study (its chapter 5), reproduced and extended: the computation.

("Seed" here is the paper, "Digital Detection of Rocket Apogee", whose flight model is
desktop/sim/seed_model.py; the random seed is ``seed``.) Simulates N flights of the paper's model,
runs every comparison detector (``desktop.study.baselines.METHODS``: boxcar, Butterworth, elliptic
and the paper's float Kalman filter, each with the paper's three-falling-samples rule and a
velocity rule) and every integer detector of ``desktop.study.detect.METHODS`` when that module
exists, and collects one row per method (desktop/study/metrics.py):

- mean, signed mean, median, 95th percentile and max of the timing error (detection time minus
  the true apogee time, the argmax of the 1 ms truth), over the flights with a detection;
- mean |true velocity| at the detection instant (m/s, the 1 ms truth);
- flights detected more than 1 s early, and flights with no detection.

Parameter modes: ``montecarlo`` draws each flight's parameters; ``paper`` flies the paper's
default flight (160 m/s^2, 15 s) every time, only the noise changing, by default with no pad (the
paper exactly). Output: desktop/study/seed_report.py (text, flight CSV), seed_plots.py (figures);
the command: desktop/study/montecarlo_cli.py.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import asdict

import numpy as np

from desktop.sim import seed_model as sm
from desktop.study import baselines
from desktop.study.metrics import metrics

PARAMETER_MODES = ("montecarlo", "paper")  # drawn parameters, or the paper's default flight
DEFAULT_PAD_S = {"montecarlo": 2.0, "paper": 0.0}
CHUNK_FLIGHTS = 2000


def detect_methods() -> dict:
    """``desktop.study.detect.METHODS`` when that module exists, else {} (other import errors raise)."""
    try:
        import desktop.study.detect as detect
    except ModuleNotFoundError as e:
        if e.name in ("desktop.study.detect",):
            return {}
        raise
    return dict(getattr(detect, "METHODS", {}))


def all_methods(include_detect: bool = True) -> dict:
    """Every method of the study, name -> callable(time_s, altitude_m, accel_mps2)."""
    methods = dict(baselines.METHODS)
    if include_detect:
        for name, fn in detect_methods().items():
            methods[name if name not in methods else f"detect:{name}"] = fn
    return methods


def simulate_flights(mode: str, seed: int, flight_indices, pad_s: float, **kw) -> sm.FlightBatch:
    """Flights of the study: drawn parameters (``montecarlo``) or the paper's default (``paper``)."""
    if mode == "paper":
        return sm.simulate(seed, flight_indices, params=sm.FlightParams.paper_default(), pad_s=pad_s, **kw)
    if mode == "montecarlo":
        return sm.simulate(seed, flight_indices, pad_s=pad_s, **kw)
    raise ValueError(f"unknown parameter mode {mode!r}")


class StudyResult:
    """Per-flight detections of every method, the truth, and the table."""

    def __init__(self, parameters, flight_index, true_apogee_s, true_apogee_m, detections,
                 velocities, elapsed_s):
        self.parameters = parameters
        self.flight_index = flight_index
        self.true_apogee_s = true_apogee_s
        self.true_apogee_m = true_apogee_m
        self.detections = detections      # name -> (n_flights,) detection times, NaN when none
        self.velocities = velocities      # name -> (n_flights,) 1 ms truth velocity at detection
        self.elapsed_s = elapsed_s        # name -> seconds spent in the method; "simulate" too
        self.table = {name: metrics(d, true_apogee_s, velocities[name]) for name, d in detections.items()}

    def to_json(self) -> dict:
        def clean(x):
            return None if isinstance(x, float) and not math.isfinite(x) else x

        return {
            "seed": self.parameters["seed"],
            "parameters": self.parameters,
            "methods": {n: {k: clean(v) for k, v in m.items()} for n, m in self.table.items()},
            "timing_s": {k: round(v, 4) for k, v in self.elapsed_s.items()},
        }


def run_study(n_flights: int, seed: int, *, mode: str = "montecarlo", pad_s: float | None = None,
              methods: dict | None = None, chunk: int = CHUNK_FLIGHTS, progress: bool = False) -> StudyResult:
    """Simulate flights 0..n_flights-1 of ``seed`` and run every method on them (in chunks of
    ``chunk`` flights; every method works flight by flight, so chunking does not change a result)."""
    if pad_s is None:
        pad_s = DEFAULT_PAD_S[mode]
    if methods is None:
        methods = all_methods()
    n_flights = int(n_flights)
    if n_flights < 1:
        raise ValueError("need at least one flight")
    det = {name: np.full(n_flights, np.nan) for name in methods}
    vel = {name: np.full(n_flights, np.nan) for name in methods}
    apo_t = np.empty(n_flights)
    apo_m = np.empty(n_flights)
    elapsed = {"simulate": 0.0, **{name: 0.0 for name in methods}}
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n_flights * (1 + len(methods)), unit="flight-step", file=sys.stderr,
                   desc="montecarlo", leave=False)
    batch = None
    try:
        for c0 in range(0, n_flights, chunk):
            c1 = min(n_flights, c0 + chunk)
            t0 = time.perf_counter()
            batch = simulate_flights(mode, seed, np.arange(c0, c1), pad_s)
            elapsed["simulate"] += time.perf_counter() - t0
            apo_t[c0:c1] = batch.true_apogee_time_s
            apo_m[c0:c1] = batch.true_apogee_m
            if bar is not None:
                bar.update(c1 - c0)
            for name, fn in methods.items():
                t0 = time.perf_counter()
                d = np.asarray(fn(batch.time_s, batch.altitude_m, batch.accel_mps2), dtype=np.float64)
                elapsed[name] += time.perf_counter() - t0
                if d.shape != (c1 - c0,):
                    raise ValueError(f"method {name!r} returned shape {d.shape}, expected ({c1 - c0},)")
                det[name][c0:c1] = d
                vel[name][c0:c1] = batch.true_velocity_at(d)
                if bar is not None:
                    bar.update(c1 - c0)
    finally:
        if bar is not None:
            bar.close()
    parameters = {
        "flights": n_flights,
        "seed": int(seed),
        "params": mode,
        "pad_s": float(pad_s),
        "t_length_s": batch.t_length_s,
        "ignition_time_s": batch.ignition_time_s,
        "sample_period_s": float(batch.time_s[1] - batch.time_s[0]),
        "ranges": asdict(sm.DEFAULT_RANGES) if mode == "montecarlo" else None,
        "baselines": {
            "boxcar_window": baselines.BOXCAR_WINDOW,
            "butterworth": {"order": baselines.BUTTER_ORDER, "cutoff_hz": baselines.BUTTER_CUTOFF_HZ},
            "elliptic": {"order": baselines.ELLIP_ORDER, "rp_db": baselines.ELLIP_RP_DB,
                         "rs_db": baselines.ELLIP_RS_DB, "cutoff_hz": baselines.ELLIP_CUTOFF_HZ},
            "lockout_s_after_launch": baselines.LOCKOUT_S,
            "launch_threshold_mps2": baselines.LAUNCH_THRESHOLD_MPS2,
        },
    }
    return StudyResult(parameters, np.arange(n_flights), apo_t, apo_m, det, vel, elapsed)
