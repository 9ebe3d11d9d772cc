"""Fault benchmark: the flight computer and AltOS's algorithm under sensor faults, six rockets.

    python tools/bench_faults.py                      # the full benchmark (docs/BENCHMARKS.md)
    python tools/bench_faults.py --flights 8 --trajectories 2 --rockets c6_model   # a quick look
    python tools/bench_faults.py --json > faults.json
    python tools/bench_faults.py --boards baro --classes transient_midcoast --methods flight-computer
    python tools/bench_faults.py --resume earlier.jsonl --rows rest.jsonl   # finish an interrupted run

Every rocket of ROCKETS flies ``--trajectories`` dispersed RocketPy trajectories (desktop/sim/trajectory.py,
the dispersions of ``montecarlo --rocket``), each simulated once and cached under ``--cache``. Each
of the ``--flights`` Monte-Carlo flights per class takes trajectory ``f % trajectories`` and its own
sensor record (desktop/sim/sensor_models.py, the rocket's sensor profile, seed drawn from (seed,
rocket, f); the default transonic model is off: static-port errors are a fault class here), then
every fault class (desktop/sim/faults.py) draws its parameters from (seed, rocket, f, class). The
barometer classes also run on a barometer-only board (the same record without its accelerometer).

Methods on each faulted record:

- ``flight-computer``: the exact shared/ code on the board's integer readings, as ``desktop replay``
  feeds it (``desktop.review.replay.readings``, its ground reference and configuration), with the
  rocket's main altitude, and the settings docs/CONFIG.md tells users to take from a simulation
  of the undispersed rocket (``user_settings``): the backup timer at nominal apogee +
  ``BACKUP_MARGIN_S``; ``main_delay_s`` the nominal time from apogee to the main altitude and
  ``main_backup_s`` that less ``MAIN_BACKUP_MARGIN_S``; on barometer-only boards
  ``mach_lockout_s`` the time the nominal flight slows below Mach 0.8 after burnout + 3 s.
- ``altos``: AltOS's published algorithm (desktop/study/altos.py), factory-calibrated accelerometer
  (the part's offset and scale error of the record, as a two-point calibration measures them),
  same main altitude, no apogee delay.

Scores per class, rocket, board and method (error = drogue time - true apogee): drogue more than
``EARLY_S`` before true apogee, no drogue at all, p95 |error|, max |true vertical speed| at the
drogue, p95 |true altitude at the main - set altitude| (rockets with a main).
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import math
import os
import pickle
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from desktop.sim import faults as flt  # noqa: E402
from desktop.sim.trajectory import G0  # noqa: E402

ROCKETS = ("c6_model", "j360_sport", "k400_dual_deploy", "k1000_min_dia", "m1670_3km", "m1670_min_dia")
METHODS = ("flight-computer", "altos")
BOARDS = ("both", "baro")
BACKUP_MARGIN_S = 3.0  # docs/CONFIG.md: backup_drogue_s a few seconds after the predicted apogee
MAIN_BACKUP_MARGIN_S = 3.0  # docs/CONFIG.md: main_backup_s a few seconds before the predicted main
MACH_LOCKOUT_MACH = 0.8  # docs/CONFIG.md: mach_lockout_s when the simulation slows below Mach 0.8,
MACH_LOCKOUT_MARGIN_S = 3.0  # + 3 s
EARLY_S = 0.5  # a drogue more than this before true apogee counts as early
PAD_S = 5.0  # pad time before ignition in every record (the ground reference comes from metadata)
AFTER_MAIN_S = 3.0  # the record ends this long after the descent crosses the main altitude
AFTER_APOGEE_S = 15.0  # a rocket without a main: the record ends this long after apogee
DEFAULT_FLIGHTS = 200
DEFAULT_TRAJECTORIES = 40
DEFAULT_SEED = 1


class BenchError(ValueError):
    """Bad command-line input (one line)."""


def check_choices(choices):
    """BenchError for the first given value that its option does not know (``choices``:
    (option, given values, known values) triples)."""
    for option, given, known in choices:
        for x in given:
            if x not in known:
                raise BenchError(f"unknown {option} {x!r} (known: {', '.join(known)})")


def open_rows(path):
    """The --rows file opened for writing (None without one); BenchError if it cannot be."""
    if not path:
        return None
    try:
        return open(path, "w")
    except OSError as exc:
        raise BenchError(f"--rows {path}: cannot write: {exc.strerror}") from None


# --------------------------------------------------------------------------------------------------
# Trajectories (cached)


def _rocket_path(name: str) -> Path:
    return ROOT / "examples" / "rockets" / f"{name}.toml"


def _cache_key(name: str, seed: int, index: int | None) -> str:
    from desktop.io.rocket_file import load_rocket

    spec = load_rocket(_rocket_path(name))
    h = hashlib.sha1()
    h.update(_rocket_path(name).read_bytes())
    h.update(Path(spec.motor.path).read_bytes())
    h.update(repr((seed, index, AFTER_MAIN_S, AFTER_APOGEE_S)).encode())
    return h.hexdigest()[:16]


def trajectory(name: str, seed: int, index: int | None, cache: Path | None):
    """Dispersed trajectory ``index`` of rocket ``name`` (``None``: the nominal rocket), cut
    AFTER_MAIN_S after the descent crosses the main altitude; from the cache when there."""
    from desktop.io.rocket_file import load_rocket
    from desktop.sim import trajectory as tr
    from desktop.study.rocket_dispersions import apply_draw, draw_flight

    path = None
    if cache is not None:
        path = cache / name / f"{'nominal' if index is None else index}-{_cache_key(name, seed, index)}.pkl"
        if path.exists():
            with open(path, "rb") as f:
                return pickle.load(f)
    spec = load_rocket(_rocket_path(name))
    flown = spec if index is None else apply_draw(spec, draw_flight(spec, seed, index))
    traj = tr.simulate_rocket(flown, after_main_s=AFTER_MAIN_S if flown.main else None)
    tr.forget_motors_except(spec.motor)
    if spec.main is None:
        traj = traj.truncated(traj.apogee_time_s + AFTER_APOGEE_S)
    else:
        traj = traj.ended_after_main(spec.main.deploy_altitude_m, AFTER_MAIN_S)
    traj = dataclasses.replace(traj, thrust_n=None, mass_kg=None)  # not needed: a smaller cache
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp%d" % os.getpid())
        with open(tmp, "wb") as f:
            pickle.dump(traj, f, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(tmp, path)
    return traj


# --------------------------------------------------------------------------------------------------
# One faulted record through both methods


def flight_log(time_s, pressure_pa, accel_mps2, metadata):
    """The FlightLog a flight CSV of this record would give (the writer's rounding), in memory."""
    from desktop.io.flightcsv import FlightLog

    t = np.asarray(time_s, dtype=np.float64)
    time_us = np.rint(t * 1e6).astype(np.int64)
    meta = {k: repr(float(v)) if isinstance(v, (float, np.floating)) else str(v) for k, v in metadata.items()}
    return FlightLog(
        path="<fault benchmark>", metadata=meta, comments=[],
        columns=["time_s", "pressure_pa"] + ([] if accel_mps2 is None else ["accel_mps2"]),
        time_s=time_us / 1e6, time_us=time_us, pressure_pa=np.round(pressure_pa, 2), altitude_m=None,
        accel_mps2=None if accel_mps2 is None else np.round(accel_mps2, 4), extra={},
        line_numbers=np.arange(len(t), dtype=np.int64),
    )


def run_flight_computer(log, overrides: dict) -> tuple[float, float]:
    """(drogue time, main time) of the flight computer on ``log`` (NaN when it did not fire): the
    readings, ground reference and configuration of ``desktop replay``; stops at the main (at the
    drogue on a single-deployment flight: nothing after it is scored)."""
    from desktop.review.replay import config_for, ground_alt_mm, readings
    from shared.flight import EVENT_NAMES, FlightComputer

    config = config_for(log, overrides=overrides)
    dt_us, alt_mm, accel, have = readings(log)
    fc = FlightComputer(config, ground_alt_mm=ground_alt_mm(log))
    ev_drogue = 1 << EVENT_NAMES.index("drogue")
    ev_main = 1 << EVENT_NAMES.index("main")
    stop = ev_main if config.main_deploy_mm else ev_drogue
    step = fc.step
    drogue_i = main_i = -1
    for i, (d, a, f, h) in enumerate(zip(dt_us.tolist(), alt_mm.tolist(), accel.tolist(), have.tolist(),
                                         strict=True)):
        step(d, a, f, h)
        ev = fc.events
        if ev:
            if ev & ev_drogue and drogue_i < 0:
                drogue_i = i
            if ev & ev_main:
                main_i = i
            if ev & stop:
                break
    t = log.time_s
    return (float(t[drogue_i]) if drogue_i >= 0 else math.nan, float(t[main_i]) if main_i >= 0 else math.nan)


def run_altos(log, settings) -> tuple[float, float]:
    from desktop.study.altos import run_altos as altos

    res = altos(log.time_s, log.pressure_pa, log.accel_mps2 if settings.has_accel else None, settings)
    return res.time("drogue"), res.time("main")


def _score(traj, drogue_s, main_s):
    def at(x, arr):
        return float(np.interp(x, traj.time_s, arr)) if math.isfinite(x) else math.nan

    return {"drogue_s": drogue_s, "main_s": main_s, "error_s": drogue_s - traj.apogee_time_s,
            "speed_at_drogue_mps": at(drogue_s, traj.velocity_mps),
            "altitude_at_main_m": at(main_s, traj.altitude_m)}


def board_config(rate_hz: float):
    """The simulated board: the sensor models' defaults with PAD_S on the pad and no transonic
    port error of their own (static-port errors are a fault class here)."""
    from desktop.sim.sensor_models import BoardConfig, TransonicModel

    return BoardConfig(rate_hz=rate_hz, pad_s=PAD_S, transonic=TransonicModel(c=0.0))


def faulted_record(traj, fault, profile: str, record_seed: int, board, base=None):
    """(record, pressure_pa, accel_mps2, accel_range_mps2): the board's record of ``traj`` with
    ``fault``. A fault of the sensor itself reuses ``base`` (the fault-free record) when given."""
    from desktop.sim.sensor_models import make_record

    if fault.on_board_record and base is not None:
        rec = base
    else:
        rec = make_record(flt.apply_to_trajectory(traj, fault), profile, seed=record_seed, board=board)
    pres, acc, clip = flt.apply_to_record(rec.time_s, rec.pressure_pa, rec.accel_mps2, fault)
    return rec, pres, acc, clip


def user_settings(traj, main_m: float | None) -> dict:
    """The settings docs/CONFIG.md tells a user to take from a simulation of the rocket
    (``traj``, the undispersed flight), as configuration overrides: ``backup_drogue_s``,
    ``main_delay_s`` and ``main_backup_s`` (rockets with a main that the simulation reaches) and,
    under the key "baro", ``mach_lockout_s`` for a barometer-only board (rockets that reach Mach
    0.8)."""
    out = {"backup_drogue_s": round(traj.apogee_time_s + BACKUP_MARGIN_S, 1)}
    if main_m is not None:
        below = np.nonzero((traj.time_s > traj.apogee_time_s) & (traj.altitude_m <= main_m))[0]
        if below.size:
            delay_s = float(traj.time_s[below[0]]) - traj.apogee_time_s
            out["main_delay_s"] = round(delay_s, 1)
            out["main_backup_s"] = round(max(delay_s - MAIN_BACKUP_MARGIN_S, 1.0), 1)
    slow = np.nonzero((traj.time_s > traj.burnout_time_s) & (traj.mach < MACH_LOCKOUT_MACH))[0]
    if traj.max_mach >= MACH_LOCKOUT_MACH and slow.size:
        out["baro"] = {"mach_lockout_s": round(float(traj.time_s[slow[0]]) + MACH_LOCKOUT_MARGIN_S, 1)}
    return out


def board_overrides(settings: dict, board: str, main_m: float | None, clip: float | None) -> dict:
    """The flight computer's configuration overrides for ``board``: ``settings``
    (``user_settings``: the common keys, then the board's own), the sensors, the main altitude and
    the accelerometer's full scale (``clip``, m/s^2) when the record is clipped."""
    overrides = {k: v for k, v in settings.items() if k not in BOARDS}
    overrides.update(settings.get(board, {}))
    overrides["sensors"] = board
    if main_m is not None:
        overrides["main_deploy_m"] = main_m
    if clip is not None:
        overrides["accel_range_g"] = clip / G0
    return overrides


def run_methods(rec, pres, acc, clip, board: str, main_m: float | None, settings: dict,
                methods=METHODS) -> dict:
    """{method: (drogue time, main time)} on one faulted record, for a board with both sensors
    ("both") or a barometer only ("baro", the same record without its accelerometer), configured
    by ``board_overrides``; ``methods``: a subset of METHODS."""
    from desktop.study.altos import AltosSettings

    par = rec.parameters
    plus = G0 * (1.0 + par["accel_scale_error"]) + par["accel_bias_mps2"]
    minus = -G0 * (1.0 + par["accel_scale_error"]) + par["accel_bias_mps2"]
    log = flight_log(rec.time_s, pres, acc if board == "both" else None, rec.metadata)
    overrides = board_overrides(settings, board, main_m, clip)
    out = {}
    if "flight-computer" in methods:
        out["flight-computer"] = run_flight_computer(log, overrides)
    if "altos" in methods:
        out["altos"] = run_altos(log, AltosSettings(
            main_deploy_m=main_m if main_m is not None else 250.0, has_accel=board == "both",
            accel_plus_g_mps2=plus, accel_minus_g_mps2=minus))
    return out


def evaluate(task) -> list[dict]:
    """Every class, board and method on the flights of one trajectory; one dict per run."""
    from desktop.io.rocket_file import load_rocket
    from desktop.study.rocket_flight import settings_for

    name, rocket_i, traj_index, flights, seed, cache, user, max_mach, select = task
    boards, only_classes, methods = select
    traj = trajectory(name, seed, traj_index, cache)
    settings = settings_for(_rocket_path(name), seed)
    spec = load_rocket(_rocket_path(name))
    main_m = spec.main.deploy_altitude_m if spec.main is not None else None
    board_cfg = board_config(settings.rate_hz)
    subsonic = max_mach < flt.FAST_ROCKET_MACH
    classes = [c for c in flt.classes_for(max_mach, "both") if c in only_classes]
    out = []
    t_cpu = time.process_time()
    for f in flights:
        record_seed = int(np.random.default_rng([seed, rocket_i, f]).integers(0, 2**63 - 1))
        base = None
        for class_i, kind in enumerate(flt.CLASSES):
            if kind not in classes and kind != "none":  # (the fault-free record is the others' base)
                continue
            rng = np.random.default_rng([seed, rocket_i, f, class_i])
            fault = flt.draw_fault(kind, rng, traj, traj.end_time_s, subsonic=subsonic)
            rec, pres, acc, clip = faulted_record(traj, fault, settings.profile, record_seed, board_cfg, base)
            if kind == "none":
                base = rec
                if kind not in classes:
                    continue
            for board in boards:
                if board == "baro" and kind not in flt.BARO_CLASSES:
                    continue
                results = run_methods(rec, pres, acc, clip, board, main_m, user, methods)
                for method in methods:
                    d, m = results[method]
                    row = {"rocket": name, "class": kind, "board": board, "method": method, "flight": f,
                           "trajectory": traj_index, "true_apogee_s": traj.apogee_time_s,
                           "main_set_m": main_m, "fault": fault.params}
                    row.update(_score(traj, d, m))
                    out.append(row)
    if out:
        out[0]["task_cpu_s"] = time.process_time() - t_cpu
    return out



# --------------------------------------------------------------------------------------------------
# Tables


def _p95(x):
    x = np.asarray([v for v in x if math.isfinite(v)], dtype=float)
    return float(np.percentile(x, 95)) if x.size else math.nan


def aggregate(rows: list[dict]) -> list[dict]:
    """One summary per (class, rocket, board, method), in CLASSES x ROCKETS x BOARDS x METHODS order."""
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["class"], r["rocket"], r["board"], r["method"]), []).append(r)
    out = []
    order = {k: i for i, k in enumerate(flt.CLASSES)}
    for key in sorted(groups, key=lambda k: (order[k[0]], ROCKETS.index(k[1]) if k[1] in ROCKETS else 99,
                                             BOARDS.index(k[2]), METHODS.index(k[3]))):
        g = groups[key]
        err = [r["error_s"] for r in g]
        speed = [abs(r["speed_at_drogue_mps"]) for r in g if math.isfinite(r["speed_at_drogue_mps"])]
        main_err = [abs(r["altitude_at_main_m"] - r["main_set_m"]) for r in g if r["main_set_m"] is not None
                    and math.isfinite(r["altitude_at_main_m"])]
        has_main = g[0]["main_set_m"] is not None
        out.append({
            "class": key[0], "rocket": key[1], "board": key[2], "method": key[3], "flights": len(g),
            "early": int(sum(1 for e in err if math.isfinite(e) and e < -EARLY_S)),
            "missed": int(sum(1 for e in err if not math.isfinite(e))),
            "p95_abs_error_s": _p95([abs(e) for e in err]),
            "max_speed_at_drogue_mps": max(speed) if speed else math.nan,
            "mains": len(main_err) if has_main else None,
            "p95_main_error_m": _p95(main_err) if has_main else None,
        })
    return out


def _fmt(x, spec):
    if x is None:
        return "-"
    if isinstance(x, float) and not math.isfinite(x):
        return "-"
    return format(x, spec)


def markdown(summary: list[dict]) -> list[str]:
    lines = []
    by_class: dict = {}
    for s in summary:
        by_class.setdefault(s["class"], []).append(s)
    for kind, rows in by_class.items():
        lines += [f"#### {kind}", "",
                  "| rocket | board | method | flights | drogue > 0.5 s early | no drogue | p95 \\|err\\| s "
                  "| max \\|v\\| at drogue m/s | mains | p95 \\|main - set\\| m |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for s in rows:
            bold = "**" if s["method"] == "flight-computer" and (s["early"] or s["missed"]) else ""
            lines.append(
                f"| {s['rocket']} | {s['board']} | {s['method']} | {s['flights']} | "
                f"{bold}{s['early']}{bold} | "
                f"{bold}{s['missed']}{bold} | {_fmt(s['p95_abs_error_s'], '.3f')} | "
                f"{_fmt(s['max_speed_at_drogue_mps'], '.1f')} | {_fmt(s['mains'], 'd')} | "
                f"{_fmt(s['p95_main_error_m'], '.1f')} |")
        lines.append("")
    return lines


def overview(summary: list[dict]) -> list[str]:
    """Totals over the rockets: early and missed drogues per class, board and method."""
    tot: dict = {}
    for s in summary:
        k = (s["class"], s["board"], s["method"])
        t = tot.setdefault(k, [0, 0, 0])
        t[0] += s["flights"]
        t[1] += s["early"]
        t[2] += s["missed"]
    lines = ["| class | board | flight-computer: early / missed of flights | altos: early / missed |",
             "|---|---|---|---|"]
    seen = []
    for (kind, board, _m) in tot:
        if (kind, board) in seen:
            continue
        seen.append((kind, board))
        fc = tot.get((kind, board, "flight-computer"), [0, 0, 0])
        al = tot.get((kind, board, "altos"), [0, 0, 0])
        lines.append(f"| {kind} | {board} | {fc[1]} / {fc[2]} of {fc[0]} | {al[1]} / {al[2]} of {al[0]} |")
    return lines


# --------------------------------------------------------------------------------------------------


def _clean(x):
    """JSON-ready: NaN and infinities become null."""
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def _write_rows(f, rows):
    if f is not None:
        for r in rows:
            f.write(json.dumps(_clean(r)) + "\n")
        f.flush()


def _read_rows(path):
    """The runs of a --rows file (JSON lines)."""
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def _init_worker():
    import warnings

    warnings.simplefilter("ignore")
    import rocketpy  # noqa: F401  (once per process)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--flights", type=int, default=DEFAULT_FLIGHTS,
                    help=f"Monte-Carlo flights per class and rocket (default {DEFAULT_FLIGHTS})")
    ap.add_argument("--trajectories", type=int, default=DEFAULT_TRAJECTORIES,
                    help="RocketPy trajectories per rocket, shared by the flights "
                         f"(default {DEFAULT_TRAJECTORIES})")
    ap.add_argument("--seed", type=int, default=DEFAULT_SEED, help=f"seed (default {DEFAULT_SEED})")
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--rockets", nargs="+", default=list(ROCKETS), help="rockets (default: all six)")
    ap.add_argument("--classes", nargs="+", default=list(flt.CLASSES),
                    help="fault classes (default: all; docs/FAULTS.md)")
    ap.add_argument("--boards", nargs="+", default=list(BOARDS), help="boards (default: both baro)")
    ap.add_argument("--methods", nargs="+", default=list(METHODS),
                    help="methods (default: flight-computer altos)")
    ap.add_argument("--cache", default=str(ROOT / "out" / "fault_cache"),
                    help="trajectory cache directory (default out/fault_cache; 'none' for no cache)")
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    ap.add_argument("--rows", metavar="FILE", help="also write every run here as it finishes (JSON lines)")
    ap.add_argument("--resume", metavar="ROWS", help="skip the trajectories an earlier, interrupted run "
                    "already finished (its --rows file)")
    ap.add_argument("--summarize", metavar="ROWS", nargs="+",
                    help="print the tables of --rows files (a finished or interrupted run; a later "
                         "file's runs replace an earlier one's of the same rocket, class, board, method "
                         "and flight) and exit")
    args = ap.parse_args(argv)
    if args.summarize:
        runs = {}
        try:
            for path in args.summarize:
                for r in _read_rows(path):
                    runs[(r["rocket"], r["class"], r["board"], r["method"], r["flight"])] = r
        except (OSError, ValueError, KeyError) as exc:
            print(f"error: {path}: cannot read the rows: {exc}", file=sys.stderr)
            return 2
        rows = list(runs.values())
        for r in rows:
            for k in ("error_s", "speed_at_drogue_mps", "altitude_at_main_m"):
                if r[k] is None:
                    r[k] = math.nan
        summary = aggregate(rows)
        if args.json:
            print(json.dumps(_clean({"summary": summary}), indent=1))
            return 0
        print(f"{len(rows)} runs from {', '.join(args.summarize)}")
        print()
        for line in overview(summary) + [""] + markdown(summary):
            print(line)
        return 0
    try:
        check_choices((("rocket", args.rockets, ROCKETS), ("class", args.classes, flt.CLASSES),
                       ("board", args.boards, BOARDS), ("method", args.methods, METHODS)))
        if args.flights < 1 or args.trajectories < 1 or args.workers < 1:
            raise BenchError("--flights, --trajectories and --workers must be at least 1")
    except BenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    done = set()
    if args.resume:
        try:
            done = {(r["rocket"], r["trajectory"]) for r in _read_rows(args.resume)}
        except (OSError, ValueError, KeyError) as exc:
            print(f"error: --resume {args.resume}: cannot read the rows: {exc}", file=sys.stderr)
            return 2
    try:
        rows_file = open_rows(args.rows)  # (after the resume's read: it may be the same file)
    except BenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    cache = None if args.cache == "none" else Path(args.cache)
    trajectories = min(args.trajectories, args.flights)
    t0 = time.perf_counter()
    import warnings

    warnings.simplefilter("ignore")
    nominal = {}
    from desktop.io.rocket_file import load_rocket

    for name in args.rockets:
        traj = trajectory(name, args.seed, None, cache)
        spec = load_rocket(_rocket_path(name))
        main_m = spec.main.deploy_altitude_m if spec.main is not None else None
        nominal[name] = {"apogee_s": traj.apogee_time_s, "apogee_m": traj.apogee_m, "max_mach": traj.max_mach,
                         "settings": user_settings(traj, main_m)}
    # trajectory by trajectory across the rockets: an interrupted run still covers every rocket
    tasks = []
    for j in range(trajectories):
        for rocket_i, name in enumerate(ROCKETS):
            if name not in args.rockets or (name, j) in done:
                continue
            nm = nominal[name]
            flights = list(range(j, args.flights, trajectories))
            tasks.append((name, rocket_i, j, flights, args.seed, cache, nm["settings"], nm["max_mach"],
                          (args.boards, args.classes, args.methods)))
    rows = []
    from tqdm import tqdm

    bar = tqdm(total=len(tasks), unit="trajectory", file=sys.stderr, disable=None)
    try:
        if args.workers == 1:
            for task in tasks:
                r = evaluate(task)
                rows += r
                _write_rows(rows_file, r)
                bar.update(1)
        else:
            import multiprocessing as mp

            ctx = mp.get_context("fork")
            with ctx.Pool(args.workers, initializer=_init_worker) as pool:
                for r in pool.imap_unordered(evaluate, tasks, chunksize=1):
                    rows += r
                    _write_rows(rows_file, r)
                    bar.update(1)
    finally:
        bar.close()
        if rows_file is not None:
            rows_file.close()
    wall = time.perf_counter() - t0
    summary = aggregate(rows)
    settings = {"flights_per_class": args.flights, "trajectories_per_rocket": trajectories, "seed": args.seed,
                "workers": args.workers, "pad_s": PAD_S, "early_s": EARLY_S,
                "backup_margin_s": BACKUP_MARGIN_S, "rockets": nominal, "runs": len(rows),
                "wall_s": round(wall, 1)}
    if args.json:
        print(json.dumps(_clean({"settings": settings, "summary": summary}), indent=1))
        return 0
    print(f"{args.flights} flights per class, {trajectories} trajectories per rocket, seed {args.seed}, "
          f"{len(rows)} runs in {wall:.0f} s wall on {args.workers} workers")
    print()
    print("| rocket | nominal apogee | max Mach | backup_drogue_s | main_delay_s | main_backup_s | "
          "mach_lockout_s (baro) |")
    print("|---|---|---|---|---|---|---|")
    for name, nm in nominal.items():
        st = nm["settings"]
        print(f"| {name} | {nm['apogee_m']:.0f} m at {nm['apogee_s']:.2f} s | {nm['max_mach']:.2f} | "
              f"{st['backup_drogue_s']:g} | {st.get('main_delay_s', '-')} | {st.get('main_backup_s', '-')} | "
              f"{st.get('baro', {}).get('mach_lockout_s', '-')} |")
    print()
    for line in overview(summary):
        print(line)
    print()
    for line in markdown(summary):
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
