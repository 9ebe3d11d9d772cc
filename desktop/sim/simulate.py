"""`python -m desktop simulate`: a realistic board record from a rocket TOML or an OpenRocket export.

    python -m desktop simulate examples/rockets/j360_sport.toml --out flight.csv --seed 1 --plot flight.png
    python -m desktop simulate --openrocket export.csv --out flight.csv --site-altitude 1400

The truth trajectory comes from RocketPy (desktop/sim/trajectory.py) or the export
(desktop/io/openrocket.py); the sensor models (desktop/sim/sensor_models.py) turn it into the flight CSV the
board would have written, with truth columns and metadata. See docs/SIMULATION.md.
"""

from __future__ import annotations

import argparse
import math
import time

from desktop.errors import UsageError
from desktop.io.files import check_output_file

DEFAULT_PROFILE = "bmp390+lsm6dso"

_EPILOG = """\
examples:
  python -m desktop simulate examples/rockets/j360_sport.toml --out flight.csv
  python -m desktop simulate examples/rockets/k1000_min_dia.toml --out f.csv --seed 7 \\
      --sensors ms5611+adxl375 --rate-hz 50 --pad-s 60 --plot f.png
  python -m desktop simulate --openrocket examples/openrocket/sample_export.csv --out f.csv \\
      --site-altitude 150
  python -m desktop simulate --list-sensors
  python -m desktop simulate examples/rockets/m1670_3km.toml --benchmark 100 --jobs 2

sensor profiles are BARO+ACCEL: baro one of bmp388, bmp390, ms5611; accel one of adxl375 (+-200 g),
mpu6050 (+-16 g), lsm6dso (+-16 g); or 'ideal' (no noise, lag, offsets or clipping).
Defaults: the rocket file's [board] section, else bmp390+lsm6dso at 100 Hz with a 20 s pad.
Errors are one line on stderr, exit status 2.
"""


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "simulate",
        help="simulate a flight (RocketPy from a rocket TOML, or an OpenRocket export) and write the "
             "board's flight CSV",
        description="Simulate a flight and write what the board would record: static pressure and axial "
                    "specific force at the board's sample rate, with the part's noise, resolution, lag, "
                    "offsets and clipping, sample jitter and dropped samples, a pad period, plus truth "
                    "columns (true_altitude_m, true_velocity_mps) and metadata.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("rocket", nargs="?", metavar="ROCKET.toml", help="rocket description (examples/rockets/)")
    p.add_argument("--openrocket", metavar="EXPORT.csv",
                   help="use an OpenRocket 'Export data' CSV as the truth trajectory instead of a "
                        "rocket file")
    p.add_argument("--out", metavar="FLIGHT.csv", help="flight CSV to write")
    p.add_argument("--seed", type=int, default=0, help="random seed: same seed, same record (default 0)")
    p.add_argument("--sensors", metavar="PROFILE",
                   help=f"sensor profile BARO+ACCEL (default {DEFAULT_PROFILE})")
    p.add_argument("--rate-hz", type=float, metavar="R", help="board sample rate, 20 to 100 Hz (default 100)")
    p.add_argument("--pad-s", type=float, metavar="S", help="seconds on the pad before launch (default 20)")
    p.add_argument("--site-altitude", type=float, metavar="M",
                   help="launch site altitude above sea level, m (OpenRocket exports only; default: from the "
                        "export's air pressure, else 0)")
    p.add_argument("--after-main-s", type=float, metavar="S",
                   help="end the record S seconds after the main deploys (default: to landing)")
    p.add_argument("--dof", type=int, choices=(6, 3), default=6,
                   help="RocketPy model: 6 (default) or 3 degrees of freedom (point mass with "
                        "weathercocking: faster, except near-vertical launches)")
    p.add_argument("--plot", metavar="OUT.png", help="also draw truth and record to this image")
    p.add_argument("--list-sensors", action="store_true", help="list the sensor parts and their figures")
    p.add_argument("--benchmark", type=int, metavar="N",
                   help="time N whole flights (trajectory + record) of ROCKET.toml with random wind and "
                        "inclination, and report flights per minute")
    p.add_argument("--jobs", type=int, default=1, metavar="J", help="processes for --benchmark (default 1)")
    p.set_defaults(func=run)


def run(args) -> int:
    from desktop.io.flightcsv import NO_MAIN

    if args.list_sensors:
        _list_sensors()
        return 0
    if args.benchmark is not None:
        if not args.rocket or args.openrocket:
            raise UsageError("--benchmark needs a ROCKET.toml")
        if args.benchmark < 1 or args.jobs < 1:
            raise UsageError("--benchmark and --jobs need positive counts")
        return _benchmark(args)
    if bool(args.rocket) == bool(args.openrocket):
        raise UsageError("give either ROCKET.toml or --openrocket EXPORT.csv (one of them)")
    if not args.out:
        raise UsageError("--out FLIGHT.csv is required")
    if args.rocket and args.site_altitude is not None:
        raise UsageError(
            "--site-altitude applies to --openrocket exports; a rocket file has [site] elevation_m"
        )
    if args.site_altitude is not None and not -500.0 <= args.site_altitude <= 5000.0:
        raise UsageError(f"--site-altitude {args.site_altitude:g} is out of range (allowed -500 to 5000 m)")
    if args.after_main_s is not None and args.after_main_s < 0:
        raise UsageError("--after-main-s must be >= 0")
    check_output_file(args.out, "flight CSV")
    if args.plot:
        check_output_file(args.plot, "plot")

    from desktop.sim.sensor_models import BoardConfig, parse_profile  # scipy: seconds to import

    board_defaults: dict = {}
    main_plan = None  # the rocket's main deployment height, NO_MAIN, or None (not known)
    if args.rocket:
        from desktop.io.rocket_file import load_rocket
        from desktop.sim.trajectory import simulate_rocket

        spec = load_rocket(args.rocket)
        board_defaults = spec.board
        profile = parse_profile(args.sensors or board_defaults.get("sensors", DEFAULT_PROFILE))
        board = _board(args, board_defaults, BoardConfig)
        traj = simulate_rocket(spec, after_main_s=args.after_main_s, dof=args.dof)
        main_plan = spec.main.deploy_altitude_m if spec.main is not None else NO_MAIN
    else:
        from desktop.io.openrocket import read_openrocket

        profile = parse_profile(args.sensors or DEFAULT_PROFILE)
        board = _board(args, board_defaults, BoardConfig)
        traj = read_openrocket(args.openrocket, site_altitude_m=args.site_altitude)
        if args.after_main_s is not None and traj.main_time_s is not None:
            traj = traj.truncated(traj.main_time_s + args.after_main_s)

    from desktop.sim.sensor_models import make_record, write_record

    record = make_record(traj, profile, seed=args.seed, board=board)
    if main_plan is not None:
        # the deployment plan travels with the record: replay and studies fly the same plan
        record.metadata["main_deploy_m"] = main_plan
    write_record(args.out, record)
    if args.plot:
        plot_record(record, args.plot)
    plan = ("" if main_plan is None else "; no main" if main_plan == NO_MAIN
            else f"; main planned at {main_plan:g} m AGL")
    print(f"wrote {args.out}: {len(record.time_s)} rows at {board.rate_hz:g} Hz, {profile.name}, "
          f"seed {args.seed}; {traj.summary()}{plan}")
    return 0


def _board(args, defaults, BoardConfig):
    rate = args.rate_hz if args.rate_hz is not None else defaults.get("rate_hz", 100.0)
    pad = args.pad_s if args.pad_s is not None else defaults.get("pad_s", 20.0)
    board = BoardConfig(rate_hz=rate, pad_s=pad)
    try:
        board.validate()
    except ValueError as e:  # BoardConfig's own range check: here it is an option out of range
        raise UsageError(str(e)) from None
    return board


def _list_sensors() -> None:
    from desktop.sim.sensor_models import ACCEL_PARTS, BARO_PARTS, G0

    print("barometers (noise RMS, resolution, ODR, lag time constant, offset bound):")
    for p in BARO_PARTS.values():
        print(f"  {p.name:8s} {p.noise_pa:5.2f} Pa  {p.resolution_pa:6.3f} Pa  {p.odr_hz:5.0f} Hz  "
              f"{p.lag_s * 1000:5.1f} ms  +-{p.offset_pa:5.0f} Pa   {p.setting}")
    print("accelerometers (full scale, LSB, noise RMS, bandwidth, offset bound, scale tolerance):")
    for p in ACCEL_PARTS.values():
        fs = "   inf" if math.isinf(p.full_scale_mps2) else f"{p.full_scale_mps2 / G0:6.1f}"
        print(f"  {p.name:8s} +-{fs} g  {p.resolution_mps2 * 1000:7.2f} mm/s2  {p.noise_rms_mps2:6.3f} m/s2  "
              f"{p.bandwidth_hz:6.0f} Hz  +-{p.offset_mps2:5.2f} m/s2  +-{p.scale_error * 100:4.1f} %   "
              f"{p.setting}")


# --------------------------------------------------------------------------------------------------
# Benchmark


def _bench_one(task):
    path, seed, dof = task
    import numpy as np

    from desktop.io.rocket_file import load_rocket
    from desktop.sim.sensor_models import make_record
    from desktop.sim.trajectory import simulate_rocket

    rng = np.random.default_rng(seed)
    spec = load_rocket(path)
    spec = spec.replace(wind_speed_mps=float(rng.uniform(0, 8)), wind_from_deg=float(rng.uniform(0, 360)),
                        inclination_deg=float(rng.uniform(84, 90)))
    t0 = time.perf_counter()
    traj = simulate_rocket(spec, after_main_s=5.0, dof=dof)
    t1 = time.perf_counter()
    make_record(traj, spec.board.get("sensors", DEFAULT_PROFILE), seed=seed)
    t2 = time.perf_counter()
    return t1 - t0, t2 - t1, traj.apogee_m


def _bench_init():
    import rocketpy  # noqa: F401  (import once per worker process)


def _benchmark(args) -> int:
    import multiprocessing as mp

    t_start = time.perf_counter()
    tasks = [(args.rocket, args.seed + i, args.dof) for i in range(args.benchmark)]
    from desktop.io.rocket_file import load_rocket

    load_rocket(args.rocket)  # validate first: a one-line error, not a worker traceback
    if args.jobs == 1:
        _bench_init()
        t_ready = time.perf_counter()
        results = [_bench_one(t) for t in tasks]
    else:
        ctx = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else mp.get_context()
        with ctx.Pool(args.jobs, initializer=_bench_init) as pool:
            pool.apply(time.sleep, (0,))  # wait until a worker is ready
            t_ready = time.perf_counter()
            results = pool.map(_bench_one, tasks, chunksize=1)
    t_end = time.perf_counter()
    traj_s = sum(r[0] for r in results)
    rec_s = sum(r[1] for r in results)
    apogees = [r[2] for r in results]
    n = len(results)
    print(f"{n} flights ({args.dof} DOF) on {args.jobs} process(es): {t_end - t_ready:.1f} s after start-up "
          f"({60 * n / (t_end - t_ready):.0f} flights/minute; {60 * n / (t_end - t_start):.0f} including "
          f"{t_ready - t_start:.1f} s start-up)")
    print(f"per flight: trajectory {traj_s / n:.3f} s, sensor record {rec_s / n:.3f} s; apogee "
          f"{min(apogees):.0f} to {max(apogees):.0f} m")
    return 0


# --------------------------------------------------------------------------------------------------
# Plot


def plot_record(record, path) -> None:
    """Truth and sensor record: altitude, specific force, Mach; labelled axes with units."""
    from desktop.figures import pyplot, save_png
    from desktop.sim.trajectory import isa_altitude

    plt = pyplot()
    traj = record.trajectory
    c = record.columns
    t = c["time_s"]
    ground = float(record.metadata.get("ground_pressure_pa", traj.ground_pressure_pa))
    baro_alt = isa_altitude(c["pressure_pa"]) - isa_altitude(ground)
    fig, axes = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    ax = axes[0]
    ax.plot(traj.time_s, traj.altitude_m, "-", lw=1.2, color="k", label="truth")
    ax.plot([t[0], 0], [0, 0], "-", lw=1.2, color="k")
    ax.plot(t, baro_alt, ".", ms=2, color="tab:orange",
            label="from the recorded pressure (ISA, ground from pad)")
    ax.set_ylabel("altitude above site (m)")
    ax.legend(loc="upper right", fontsize=8)
    ax = axes[1]
    ax.plot(traj.time_s, traj.accel_mps2, "-", lw=1.0, color="k", label="truth")
    ax.plot(t, c["accel_mps2"], ".", ms=2, color="tab:blue",
            label=f"recorded ({record.metadata['sensor_profile']})")
    ax.set_ylabel("specific force along axis (m/s²)")
    ax.legend(loc="upper right", fontsize=8)
    ax = axes[2]
    ax.plot(traj.time_s, traj.mach, "-", color="k", label="truth")
    ax.axhspan(0.9, 1.3, color="tab:red", alpha=0.1, label="transonic error window (Mach 0.9 to 1.3)")
    ax.set_ylabel("Mach number (-)")
    ax.set_xlabel("time since ignition / launch (s)")
    ax.legend(loc="upper right", fontsize=8)
    events = [("apogee", traj.apogee_time_s), ("burnout", traj.burnout_time_s),
              ("drogue", traj.drogue_time_s), ("main", traj.main_time_s)]
    for a in axes:
        for _name, te in events:
            if te is not None:
                a.axvline(te, color="grey", lw=0.6, ls="--")
        a.grid(alpha=0.3)
    for name, te in events:
        if te is not None:
            axes[0].annotate(name, (te, axes[0].get_ylim()[1]), fontsize=7, rotation=90, va="top", ha="right")
    fig.suptitle(f"{traj.rocket}: seed {record.metadata['seed']}, apogee {traj.apogee_m:.0f} m at "
                 f"{traj.apogee_time_s:.2f} s, max Mach {traj.max_mach:.2f}", fontsize=10)
    save_png(plt, fig, path, dpi=110)
