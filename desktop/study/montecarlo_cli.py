"""``python -m desktop montecarlo``: compare apogee detectors over many simulated flights.

Two studies behind one command: the seed paper's (desktop/study/seed_study.py, its chapter 5
reproduced and extended) and, with ``--rocket``, the Monte-Carlo over a rocket design
(desktop/study/rocket_study.py: dispersed RocketPy flights, the sensor models, the flight computer
and the comparison methods). This module parses the arguments, checks them, runs the study and
chooses the output (table, ``--json``, ``--plots``, ``--export-csv``).

Examples::

    python -m desktop montecarlo --flights 200 --seed 1
    python -m desktop montecarlo --flights 10000 --seed 1 --json
    python -m desktop montecarlo --flights 200 --seed 1 --plots out/
    python -m desktop montecarlo --seed 1 --export-csv flight7.csv --flight 7
    python -m desktop montecarlo --params paper --seed 1 --export-csv paper.csv --flight 0
    python -m desktop montecarlo --rocket examples/rockets/k400_dual_deploy.toml --flights 200 --seed 1

``--seed`` is the random seed. ``--params paper`` flies the paper's default flight (160 m/s^2,
15 s) every time, only the noise changing; its default pad is 0 s, the paper exactly. The
Monte-Carlo default pad is 2 s. ``--params seed`` is the former name of ``paper``: still accepted,
with a one-line note on stderr.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

from desktop.errors import UsageError
from desktop.io.config_file import config_file_values
from desktop.io.files import check_output_file, make_output_dir
from desktop.study.seed_study import DEFAULT_PAD_S, PARAMETER_MODES

PAD_S_RANGE = (0.0, 600.0)  # s; the simulated board's range (desktop.sim.sensor_models.BoardConfig)
DEPRECATED_PARAMS = {"seed": "paper"}  # former --params name -> current
ROCKET_ONLY_OPTIONS = ("workers", "sensors", "max_wind_mps", "config", "main_altitude")


def register(subparsers):
    p = subparsers.add_parser(
        "montecarlo",
        help="the seed paper's Monte-Carlo study, or one over a rocket design: compare apogee detectors",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--flights", type=int, default=200, help="number of flights (default 200)")
    p.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    p.add_argument("--params", choices=PARAMETER_MODES + tuple(DEPRECATED_PARAMS), default="montecarlo",
                   help="drawn parameters (default) or the seed paper's default flight every time "
                        "(paper; 'seed' is its deprecated former name)")
    p.add_argument("--pad-s", type=float, default=None,
                   help="seconds at rest before ignition (default 2 for montecarlo, 0 for paper; with "
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
                   help="fly dispersed RocketPy flights of this rocket instead of the paper's model")
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
    if args.rocket:
        return rocket_main(args)
    for flag in ROCKET_ONLY_OPTIONS:
        if getattr(args, flag) is not None:
            raise UsageError(f"--{flag.replace('_', '-')} needs --rocket")
    if args.params in DEPRECATED_PARAMS:
        old, args.params = args.params, DEPRECATED_PARAMS[args.params]
        print(f"note: --params {old} is deprecated, use --params {args.params}", file=sys.stderr)
    return paper_main(args)


def paper_main(args) -> int:
    """The seed paper's study (no ``--rocket``)."""
    from desktop.study.seed_plots import write_plots
    from desktop.study.seed_report import export_csv, format_table
    from desktop.study.seed_study import all_methods, run_study

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


def rocket_main(args) -> int:
    """The Monte-Carlo over a rocket design (``--rocket``)."""
    from desktop.study.rocket_dispersions import DEFAULT_DISPERSIONS, MAX_WIND_LIMIT_MPS
    from desktop.study.rocket_flight import settings_for
    from desktop.study.rocket_plots import write_plots
    from desktop.study.rocket_report import export_flight_csv, format_table, speed_line
    from desktop.study.rocket_study import run_rocket_study

    if args.params != "montecarlo":
        raise UsageError("--params applies to the seed paper's study, not to --rocket")
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
