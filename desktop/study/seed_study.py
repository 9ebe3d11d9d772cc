"""``python -m desktop montecarlo``: the seed's simulation study (its chapter 5), reproduced and
extended.

Simulates N flights with the seed's model (``desktop.sim.seed_model``), runs every comparison detector
(``desktop.study.baselines.METHODS``: boxcar, Butterworth, elliptic and the seed's float Kalman filter,
each with the seed's three-falling-samples rule and a velocity rule) and every integer detector of
``desktop.study.detect.METHODS`` when that module exists, and prints one row per method:

- mean, signed mean, median, 95th percentile and max of the timing error (detection time minus
  the true apogee time, the argmax of the 1 ms truth), over the flights with a detection;
- mean |true velocity| at the detection instant (m/s, the 1 ms truth);
- flights detected more than 1 s early, and flights with no detection.

Examples::

    python -m desktop montecarlo --flights 200 --seed 1
    python -m desktop montecarlo --flights 10000 --seed 1 --json
    python -m desktop montecarlo --flights 200 --seed 1 --plots out/
    python -m desktop montecarlo --seed 1 --export-csv flight7.csv --flight 7
    python -m desktop montecarlo --params seed --seed 1 --export-csv seed.csv --flight 0
    python -m desktop montecarlo --rocket examples/rockets/k400_dual_deploy.toml --flights 200 --seed 1

``--rocket`` runs the Monte-Carlo over a rocket design instead (desktop/study/rocket_study.py):
dispersed RocketPy flights, the sensor models, the flight computer and the comparison methods.

``--params seed`` flies the seed's default flight (160 m/s^2, 15 s) every time, only the noise
changing; its default pad is 0 s, the seed exactly. The Monte-Carlo default pad is 2 s.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import asdict

import numpy as np

from desktop.errors import UsageError
from desktop.io.files import check_output_file, make_output_dir
from desktop.sim import seed_model as sm
from desktop.study import baselines
from desktop.study.metrics import metrics, table_lines
from desktop.study.seed_plots import write_plots

DEFAULT_PAD_S = {"montecarlo": 2.0, "seed": 0.0}
PAD_S_RANGE = (0.0, 600.0)  # s; the simulated board's range (desktop.sim.sensor_models.BoardConfig)
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
    """Flights of the study: drawn parameters (``montecarlo``) or the seed's default (``seed``)."""
    if mode == "seed":
        return sm.simulate(seed, flight_indices, params=sm.FlightParams.seed_default(), pad_s=pad_s, **kw)
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


def format_table(result: StudyResult) -> str:
    p = result.parameters
    title = (f"{p['flights']} flights, seed {p['seed']}, params {p['params']}, pad {p['pad_s']:g} s, "
             f"flight {p['t_length_s']:g} s; error = detection - true apogee (s)")
    return "\n".join(table_lines(title, result.table))


# --------------------------------------------------------------------------------------------------
# Flight-CSV export


def export_csv(path, mode: str, seed: int, flight_index: int, pad_s: float) -> sm.FlightBatch:
    """Write flight ``flight_index`` of the study (same seed, mode and pad) as a flight CSV."""
    from desktop.io.flightcsv import write_flight_csv

    batch = simulate_flights(mode, seed, [flight_index], pad_s)
    columns, meta = sm.flight_csv_columns(batch, 0)
    meta["params"] = mode
    comments = (
        "Simulated with the seed study's flight model (desktop/sim/seed_model.py), "
        "python -m desktop montecarlo",
        "accel_mps2 is specific force: the floor-quantised kinematic acceleration + 9.81",
    )
    write_flight_csv(path, columns, meta, comments)
    return batch


# --------------------------------------------------------------------------------------------------
# CLI


def register(subparsers):
    p = subparsers.add_parser(
        "montecarlo",
        help="the seed's Monte-Carlo study: simulate flights, compare apogee detectors",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--flights", type=int, default=200, help="number of flights (default 200)")
    p.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    p.add_argument("--params", choices=("montecarlo", "seed"), default="montecarlo",
                   help="drawn parameters (default) or the seed's default flight every time")
    p.add_argument("--pad-s", type=float, default=None,
                   help="seconds at rest before ignition (default 2 for montecarlo, 0 for seed; with "
                        "--rocket: the rocket file's [board] pad_s)")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.add_argument("--plots", metavar="DIR", help="write the figures (PNG) to DIR")
    p.add_argument("--no-detect", action="store_true",
                   help="leave out desktop.study.detect's integer detectors")
    p.add_argument("--export-csv", metavar="PATH",
                   help="write flight --flight as a flight CSV and exit (no study)")
    p.add_argument("--flight", type=int, default=0, help="flight index for --export-csv (default 0)")
    r = p.add_argument_group(
        "Monte-Carlo over a rocket design (desktop/study/rocket_study.py, docs/SIMULATION.md)")
    r.add_argument("--rocket", metavar="ROCKET.toml",
                   help="fly dispersed RocketPy flights of this rocket instead of the seed's model")
    r.add_argument("--workers", type=int, metavar="K", help="processes (default: all cores)")
    r.add_argument("--sensors", metavar="PROFILE",
                   help="sensor profile BARO+ACCEL (default: the rocket file's [board] sensors)")
    r.add_argument("--max-wind-mps", type=float, metavar="V",
                   help="wind speed drawn uniformly in 0..V m/s (default 9)")
    r.add_argument("--config", metavar="CONFIG.json",
                   help="flight configuration of the flight computer (docs/CONFIG.md), as replay --config")
    r.add_argument("--main-altitude", type=float, metavar="M",
                   help="main deployment altitude, m AGL, 0 for no main (default: the configuration's, "
                        "else the rocket file's [main], else no main)")
    p.set_defaults(func=main)
    return p


def check_common_options(args) -> None:
    """UsageError for an option out of range, before any computation (both studies)."""
    if args.flights < 1:
        raise UsageError(f"--flights {args.flights} must be >= 1")
    if args.flight < 0:
        raise UsageError(f"--flight {args.flight} must be >= 0")
    if args.pad_s is not None and not PAD_S_RANGE[0] <= args.pad_s <= PAD_S_RANGE[1]:
        raise UsageError(f"--pad-s {args.pad_s:g} is out of range (allowed {PAD_S_RANGE[0]:g} to "
                         f"{PAD_S_RANGE[1]:g} s)")
    if args.export_csv:
        check_output_file(args.export_csv, "flight CSV")
    if args.plots:
        make_output_dir(args.plots, "plots folder")


def main(args) -> int:
    check_common_options(args)
    if getattr(args, "rocket", None):
        from desktop.study import rocket_study as rocket_montecarlo

        return rocket_montecarlo.main(args)
    for flag in ("workers", "sensors", "max_wind_mps", "config", "main_altitude"):
        if getattr(args, flag, None) is not None:
            raise UsageError(f"--{flag.replace('_', '-')} needs --rocket")
    pad_s = DEFAULT_PAD_S[args.params] if args.pad_s is None else args.pad_s
    if args.export_csv:
        batch = export_csv(args.export_csv, args.params, args.seed, args.flight, pad_s)
        print(f"wrote {args.export_csv}: flight {args.flight} of seed {args.seed} ({args.params}, pad "
              f"{pad_s:g} s), true apogee {batch.true_apogee_m[0]:.1f} m at "
              f"{batch.true_apogee_time_s[0]:.3f} s", file=sys.stderr if args.json else sys.stdout)
        return 0
    progress = (not args.json) and sys.stderr.isatty()
    result = run_study(args.flights, args.seed, mode=args.params, pad_s=pad_s,
                       methods=all_methods(include_detect=not args.no_detect), progress=progress)
    if args.json:
        print(json.dumps(result.to_json(), indent=2))
    else:
        print(format_table(result))
        total = sum(result.elapsed_s.values())
        print(f"compute: {args.flights} flights in {total:.2f} s, simulation and detectors "
              f"({args.flights / max(total, 1e-9):.0f} flights/s)")
    if args.plots:
        for path in write_plots(result, args.plots, args.seed):
            print(f"wrote {path}", file=sys.stderr)
    return 0
