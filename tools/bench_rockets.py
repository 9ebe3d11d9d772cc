"""Monte-Carlo over the five example rockets: every method side by side, one markdown table per
rocket, the flight computer's extra rows, flights per minute, and the issue's goals checked.

    python tools/bench_rockets.py                      # 200 flights per rocket, all cores
    python tools/bench_rockets.py --flights 50 --workers 2 --json-dir out/bench
    python tools/bench_rockets.py --rockets k1000_min_dia c6_model

The study is ``python -m desktop montecarlo --rocket ROCKET.toml`` (desktop/study/rocket_*.py);
docs/SIMULATION.md describes the dispersions, docs/BENCHMARKS.md holds the measured tables.
"""

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from desktop.study.rocket_flight import settings_for  # noqa: E402
from desktop.study.rocket_plots import write_plots  # noqa: E402
from desktop.study.rocket_report import format_markdown, speed_line, summary_lines  # noqa: E402
from desktop.study.rocket_study import run_rocket_study  # noqa: E402

ROCKETS = ("c6_model", "j360_sport", "k400_dual_deploy", "k1000_min_dia", "m1670_3km")
SUPERSONIC = ("k1000_min_dia",)
# Goals (issue 7): flight computer mean |err| and p95 |err| (s); the supersonic rocket's own.
GOALS = {"subsonic": (0.05, 0.12), "supersonic": (0.10, 0.25)}
GOAL_FLIGHTS_PER_MINUTE = 100.0


def goal_lines(name: str, result) -> list[str]:
    fc = result.table["flight-computer"]
    s = result.fc_summary
    mean_goal, p95_goal = GOALS["supersonic" if name in SUPERSONIC else "subsonic"]

    def check(ok):
        return "met" if ok else "MISSED"

    clean = (s["n_fired_before_burnout"] == 0 and fc["n_early_1s"] == 0 and fc["n_no_detection"] == 0
             and s["n_pyro_before_launch"] == 0)
    fpm = result.speed["flights_per_minute"]
    return [
        f"- mean |err| {fc['mean_abs_error_s']:.3f} s (goal <= {mean_goal:g}): "
        f"{check(fc['mean_abs_error_s'] <= mean_goal)}; p95 {fc['p95_abs_error_s']:.3f} s "
        f"(goal <= {p95_goal:g}): {check(fc['p95_abs_error_s'] <= p95_goal)}",
        f"- fired before burnout {s['n_fired_before_burnout']}, more than 1 s early {fc['n_early_1s']}, "
        f"none {fc['n_no_detection']}, pyro before launch {s['n_pyro_before_launch']} (goal: all 0): "
        f"{check(clean)}",
        f"- speed {fpm:.0f} flights/minute (goal >= {GOAL_FLIGHTS_PER_MINUTE:g}): "
        f"{check(fpm >= GOAL_FLIGHTS_PER_MINUTE)}",
    ]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--flights", type=int, default=200, help="flights per rocket (default 200)")
    ap.add_argument("--seed", type=int, default=1, help="study seed (default 1)")
    ap.add_argument("--workers", type=int, default=None, help="processes (default: all cores)")
    ap.add_argument("--rockets", nargs="+", choices=ROCKETS, default=list(ROCKETS),
                    help="which example rockets (default: all five)")
    ap.add_argument("--json-dir", metavar="DIR", help="also write each rocket's full JSON result here")
    ap.add_argument("--plots", metavar="DIR", help="also write each rocket's figures here")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    total = 0
    for name in args.rockets:
        path = ROOT / "examples" / "rockets" / f"{name}.toml"
        settings = settings_for(path, args.seed)
        result = run_rocket_study(settings, args.flights, workers=args.workers,
                                     progress=sys.stderr.isatty())
        total += len(result.flights)
        p = result.parameters()
        print(f"### {name}: {p['name']}\n")
        print(f"{p['flights']} flights, seed {p['seed']}, {p['sensor_profile']} at {p['rate_hz']:g} Hz, pad "
              f"{p['pad_s']:g} s, " + (f"main configured at {p['main_deploy_m']:g} m" if p['main_deploy_m']
                                       else "no main") + "; apogee "
              f"{min(f['true_apogee_m'] for f in result.flights):.0f} to "
              f"{max(f['true_apogee_m'] for f in result.flights):.0f} m, max Mach "
              f"{min(f['max_mach'] for f in result.flights):.2f} to "
              f"{max(f['max_mach'] for f in result.flights):.2f}\n")
        print(format_markdown(result))
        print()
        for line in summary_lines(result):
            print(line)
        print(speed_line(result))
        print()
        for line in goal_lines(name, result):
            print(line)
        print(flush=True)
        if args.json_dir:
            out = Path(args.json_dir)
            out.mkdir(parents=True, exist_ok=True)
            (out / f"{name}.json").write_text(json.dumps(result.to_json(), indent=1))
        if args.plots:
            write_plots(result, args.plots)
    wall = time.perf_counter() - t0
    print(f"all rockets: {total} flights in {wall:.0f} s wall ({60 * total / wall:.0f} flights/minute "
          f"including each rocket's worker start-up)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
