"""Random rockets: the flight computer on flights nobody tuned it to (a held-out family).

    python tools/bench_family.py                          # 300 rockets, every class (docs/BENCHMARKS.md)
    python tools/bench_family.py --rockets 20 --classes none accel_clipped
    python tools/bench_family.py --json > family.json

The fault benchmark (tools/bench_faults.py) flies six rockets; this draws ``--rockets`` random ones
(seed ``--seed``) and flies each as a 2-D point mass (desktop/sim/point_mass.py: thrust, drag with
the transonic rise, a launch rail, wind), log-uniform over what hobby and high-power rockets span:

- mass 0.08 to 40 kg, thrust-to-weight 4 to 40, burn 0.6 to 7 s (shortened to at most 1,100 m/s
  of ideal velocity), mass over drag area 150 to 4,000 kg/m^2;
- rail 0 to 15 degrees from the vertical, wind 0 to 10 m/s, site 0 to 1,500 m;
- the board: the part profiles of PROFILES in turn (two of them 16 g accelerometers, which a
  30 to 40 g boost clips) at 100 Hz and 50 Hz, configured with its part's range as docs/CONFIG.md
  tells users (``accel_range_g``; unset, the range is learnt from a reading held at the peak).

Each rocket then flies every fault class of desktop/sim/faults.py (parameters drawn from (seed,
rocket, class)) on both boards, as the fault benchmark does, with the settings docs/CONFIG.md tells
users to take from a simulation (the backup timer at apogee + 3 s; ``mach_lockout_s`` on a
barometer-only board that reaches Mach 0.8). Scores per class and board: drogues more than
``EARLY_S`` before the true apogee, flights without one, p95 |drogue - apogee|, and the earliest
drogue with the true vertical speed then. The proof of flight needs the climb held a second
(docs/CONFIG.md): rockets below MIN_APOGEE_M are left out, and barometer-only boards below
MIN_BARO_APOGEE_M (``proof_baro_climb_m``, 100 m, with the second's margin).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from desktop.sim import faults as flt  # noqa: E402
from desktop.sim.trajectory import G0  # noqa: E402
from tools import bench_faults as bench  # noqa: E402

PROFILES = ("ms5611+adxl375", "bmp390+lsm6dso", "bmp388+mpu6050")
RATES_HZ = (100.0, 50.0)
DEFAULT_ROCKETS = 300
DEFAULT_SEED = 1
MIN_APOGEE_M = 50.0  # proof_climb_m (30 m) held a second
MIN_BARO_APOGEE_M = 150.0  # proof_baro_climb_m (100 m) held a second
MAX_IDEAL_DV_MPS = 1100.0


def _log_uniform(rng, lo, hi):
    return math.exp(rng.uniform(math.log(lo), math.log(hi)))


def draw_rocket(rng) -> dict:
    """One rocket's parameters (the ranges of the module docstring)."""
    mass = _log_uniform(rng, 0.08, 40.0)
    thrust_to_weight = _log_uniform(rng, 4.0, 40.0)
    burn = _log_uniform(rng, 0.6, 7.0)
    burn = min(burn, MAX_IDEAL_DV_MPS / (thrust_to_weight * G0))
    mass_per_cda = _log_uniform(rng, 150.0, 4000.0)
    return {"mass_kg": mass, "thrust_n": thrust_to_weight * mass * G0, "burn_s": burn,
            "cda_m2": mass / mass_per_cda, "rail_deg": rng.uniform(0.0, 15.0),
            "wind_mps": rng.uniform(0.0, 10.0), "site_m": rng.uniform(0.0, 1500.0)}


def fly_rocket(task) -> list[dict]:
    """Every class on both boards for rocket ``index`` (one worker's task): a row per run."""
    from desktop.sim.point_mass import point_mass_flight
    from desktop.sim.sensor_models import parse_profile

    seed, index, classes, boards = task
    params = draw_rocket(np.random.default_rng([seed, index]))
    traj = point_mass_flight(**params)
    if traj.apogee_m < MIN_APOGEE_M:
        return []
    profile = PROFILES[index % len(PROFILES)]
    rate_hz = RATES_HZ[(index // len(PROFILES)) % len(RATES_HZ)]
    settings = bench.user_settings(traj, None)
    settings["accel_range_g"] = round(parse_profile(profile).accel.full_scale_mps2 / G0, 1)
    subsonic = traj.max_mach < flt.FAST_ROCKET_MACH
    rows = []
    for kind in classes:  # (each class draws from its own index: the same fault whatever --classes)
        fault = flt.draw_fault(kind, np.random.default_rng([seed, index, flt.CLASSES.index(kind)]), traj,
                               traj.end_time_s, subsonic=subsonic)
        rec, pres, acc, clip = bench.faulted_record(traj, fault, profile, index, bench.board_config(rate_hz))
        for board in boards:
            if board == "baro" and (kind not in flt.BARO_CLASSES or traj.apogee_m < MIN_BARO_APOGEE_M):
                continue
            drogue_s, _ = bench.run_methods(rec, pres, acc, clip, board, None, settings,
                                            methods=("flight-computer",))["flight-computer"]
            fired = math.isfinite(drogue_s)
            rows.append({
                "rocket": index, "class": kind, "board": board, "profile": profile, "rate_hz": rate_hz,
                "apogee_s": traj.apogee_time_s, "apogee_m": traj.apogee_m, "max_mach": traj.max_mach,
                "error_s": drogue_s - traj.apogee_time_s if fired else None,
                "speed_at_drogue_mps": float(np.interp(drogue_s, traj.time_s, traj.velocity_mps))
                if fired else None,
                "params": params, "fault": fault.params})
    return rows


def summarize(rows, early_s) -> list[dict]:
    """Per class and board: runs, early drogues, no drogue, p95 |error|, the earliest drogue."""
    out = []
    for kind in dict.fromkeys(r["class"] for r in rows):
        for board in bench.BOARDS:
            sel = [r for r in rows if r["class"] == kind and r["board"] == board]
            if not sel:
                continue
            errs = np.array([r["error_s"] for r in sel if r["error_s"] is not None])
            fired = [r for r in sel if r["error_s"] is not None]
            worst = min(fired, key=lambda r: r["error_s"], default=None)
            out.append({
                "class": kind, "board": board, "runs": len(sel),
                "early": int(np.sum(errs < -early_s)), "no_drogue": len(sel) - len(errs),
                "p95_s": float(np.percentile(np.abs(errs), 95)) if len(errs) else None,
                "worst_s": worst["error_s"] if worst else None,
                "worst_speed_mps": worst["speed_at_drogue_mps"] if worst else None,
                "worst_rocket": worst["rocket"] if worst else None})
    return out


def main(argv=None) -> int:
    from tqdm import tqdm

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rockets", type=int, default=DEFAULT_ROCKETS,
                    help=f"random rockets (default {DEFAULT_ROCKETS})")
    ap.add_argument("--seed", type=int, default=DEFAULT_SEED, help=f"seed (default {DEFAULT_SEED})")
    ap.add_argument("--classes", nargs="+", default=list(flt.CLASSES),
                    help="fault classes (default: all; docs/FAULTS.md)")
    ap.add_argument("--boards", nargs="+", default=list(bench.BOARDS), help="boards (default: both baro)")
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--json", action="store_true", help="print the summary and every run as JSON")
    ap.add_argument("--rows", metavar="FILE", help="also write every run here (JSON lines)")
    args = ap.parse_args(argv)
    try:
        bench.check_choices((("class", args.classes, flt.CLASSES), ("board", args.boards, bench.BOARDS)))
        if args.rockets < 1 or args.workers < 1:
            raise bench.BenchError("--rockets and --workers must be at least 1")
        out = bench.open_rows(args.rows)
    except bench.BenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    tasks = [(args.seed, i, tuple(args.classes), tuple(args.boards)) for i in range(args.rockets)]
    rows = []
    try:
        with ProcessPoolExecutor(args.workers) as pool:
            for task_rows in tqdm(pool.map(fly_rocket, tasks), total=len(tasks), unit="rocket",
                                  disable=args.json, file=sys.stderr):
                rows.extend(task_rows)
                if out:
                    for r in task_rows:
                        out.write(json.dumps(r) + "\n")
    finally:
        if out:
            out.close()
    summary = summarize(rows, bench.EARLY_S)
    if args.json:
        print(json.dumps({"summary": summary, "runs": rows}))
        return 0
    flown = len({r["rocket"] for r in rows})
    print(f"{flown} of {args.rockets} random rockets above {MIN_APOGEE_M:.0f} m (seed {args.seed}), "
          f"{len(rows)} runs")
    print()
    print(f"| class | board | runs | more than {bench.EARLY_S} s early | no drogue | p95 \\|error\\| s "
          "| earliest drogue s (true speed m/s, rocket) |")
    print("|---|---|---|---|---|---|---|")
    for s in summary:
        worst = ("-" if s["worst_s"] is None else
                 f"{s['worst_s']:+.2f} ({s['worst_speed_mps']:.0f}, #{s['worst_rocket']})")
        p95 = "-" if s["p95_s"] is None else f"{s['p95_s']:.3f}"
        print(f"| {s['class']} | {s['board']} | {s['runs']} | {s['early']} | {s['no_drogue']} | {p95} "
              f"| {worst} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
