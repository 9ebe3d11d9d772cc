"""Monte-Carlo over a rocket design (``python -m desktop montecarlo --rocket ROCKET.toml``): flights
0..N-1 of a study seed over a pool of processes.

Flight i depends only on (seed, i) (desktop/study/rocket_dispersions.py): results are the same
whatever the number of worker processes. One flight: desktop/study/rocket_flight.py; the table and
summary: desktop/study/rocket_results.py; text, plots and the CLI: rocket_report.py,
rocket_plots.py, montecarlo_cli.py. Docs: docs/SIMULATION.md ("Monte-Carlo over a rocket design").
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from desktop.study.rocket_flight import StudySettings, evaluate_flight, rocket_spec
from desktop.study.rocket_results import RocketStudyResult


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
    return RocketStudyResult(settings, results, speed, rocket_spec(settings.rocket).name)


# --------------------------------------------------------------------------------------------------
