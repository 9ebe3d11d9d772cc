"""Replay a flight CSV through the exact board code (shared/): ``python -m desktop replay``.

Each row becomes one ``FlightComputer.step()`` with integer readings, as on the board: pressure
to altitude through ``shared.altitude`` (Pa x 16 in, mm out), acceleration in mm/s^2, time in
integer microseconds. Events are reported in the file's own time base.
"""

import json
from dataclasses import dataclass, field

import numpy as np

from desktop.errors import OutputPathError
from desktop.io.config_file import config_file_values
from desktop.io.files import check_output_file
from desktop.io.flightcsv import describe_duplicate_times
from desktop.io.importers import read_flight
from desktop.io.pressure_altitude import pressure_to_alt_mm_array
from shared.altitude import pressure_to_alt_mm
from shared.config import ConfigError, load_config
from shared.detector import HAVE_ACCEL, HAVE_BARO
from shared.flight import EV_HEALTH, EV_MODE, EVENT_NAMES, MODE_NAMES, STATE_NAMES, FlightComputer
from shared.health import HEALTH_NAMES


@dataclass
class Event:
    event: str
    index: int
    time_s: float
    altitude_m: float  # filtered altitude above the pad at that sample
    detail: str = ""  # health: the sensors' faults; mode: the sensors decisions rest on

    def as_dict(self):
        out = {"event": self.event, "time_s": round(self.time_s, 6), "altitude_m": round(self.altitude_m, 2)}
        if self.detail:
            out["detail"] = self.detail
        return out


@dataclass
class ReplayResult:
    events: list
    time_s: np.ndarray
    raw_agl_m: np.ndarray  # barometric altitude reading minus the ground reference in use
    agl_m: np.ndarray  # filtered
    vel_mps: np.ndarray
    acc_mps2: np.ndarray  # filtered kinematic acceleration
    state: np.ndarray  # state index per sample (shared.flight.STATE_NAMES)
    pyro_drogue: np.ndarray
    pyro_main: np.ndarray
    pyro_backup_drogue: np.ndarray  # the backup channels (docs/CONFIG.md, "Backup charges")
    pyro_backup_main: np.ndarray
    ground_samples: int
    errors: int
    notes: list = field(default_factory=list)

    def first(self, name):
        """The first event called ``name``, or None."""
        for ev in self.events:
            if ev.event == name:
                return ev
        return None


def readings(log):
    """Integer board readings from a flight log: (dt_us, alt_mm, accel_mmps2, have) arrays."""
    n = len(log)
    alt_mm = np.zeros(n, dtype=np.int64)
    have = np.zeros(n, dtype=np.int64)
    if log.pressure_pa is not None:
        ok = ~np.isnan(log.pressure_pa)
        q4 = np.where(ok, np.round(np.nan_to_num(log.pressure_pa) * 16), 0).astype(np.int64)
        alt_mm = pressure_to_alt_mm_array(q4)
        have |= np.where(ok, HAVE_BARO, 0)
    elif log.altitude_m is not None:
        ok = ~np.isnan(log.altitude_m)
        alt_mm = np.where(ok, np.round(np.nan_to_num(log.altitude_m) * 1000), 0).astype(np.int64)
        have |= np.where(ok, HAVE_BARO, 0)
    accel = np.zeros(n, dtype=np.int64)
    if log.accel_mps2 is not None:
        ok = ~np.isnan(log.accel_mps2)
        accel = np.where(ok, np.round(np.nan_to_num(log.accel_mps2) * 1000), 0).astype(np.int64)
        have |= np.where(ok, HAVE_ACCEL, 0)
    dt_us = np.diff(log.time_us, prepend=log.time_us[0])
    return dt_us, alt_mm, accel, have


def ground_alt_mm(log):
    """Ground altitude (mm) from ``# ground_pressure_pa:`` metadata, or None to measure on the pad."""
    pa = log.metadata_float("ground_pressure_pa")
    if pa is None or log.pressure_pa is None:
        return None
    return pressure_to_alt_mm(int(round(pa * 16)))


def replay(log, config):
    """Run every sample of ``log`` through a FlightComputer with ``config``; return a ReplayResult."""
    dt_us, alt_mm, accel, have = readings(log)
    fc = FlightComputer(config, ground_alt_mm=ground_alt_mm(log))
    n = len(log)
    out = {k: np.zeros(n) for k in ("raw", "agl", "vel", "acc")}
    state = np.zeros(n, dtype=np.int8)
    pyro_d = np.zeros(n, dtype=bool)
    pyro_m = np.zeros(n, dtype=bool)
    pyro_bd = np.zeros(n, dtype=bool)
    pyro_bm = np.zeros(n, dtype=bool)
    events = []
    step = fc.step
    kf = fc.kf
    for i in range(n):
        step(int(dt_us[i]), int(alt_mm[i]), int(accel[i]), int(have[i]))
        out["raw"][i] = (alt_mm[i] - fc.ground_alt_mm) / 1000 if have[i] & HAVE_BARO else np.nan
        out["agl"][i] = fc.agl_mm / 1000
        out["vel"][i] = fc.vel_mmps / 1000
        out["acc"][i] = (kf.acc_q4 >> 4) / 1000
        state[i] = fc.state
        pyro_d[i] = fc.pyro_drogue
        pyro_m[i] = fc.pyro_main
        pyro_bd[i] = fc.pyro_backup_drogue
        pyro_bm[i] = fc.pyro_backup_main
        if fc.events:
            for bit, name in enumerate(EVENT_NAMES):
                if fc.events & (1 << bit):
                    events.append(Event(name, i, float(log.time_s[i]), fc.agl_mm / 1000,
                                        _detail(fc, 1 << bit)))
    notes = []
    duplicates = describe_duplicate_times(log.duplicate_times)
    if duplicates:
        notes.append(duplicates)
    main_m = config.values["main_deploy_m"]
    notes.append("main at %g m AGL" % main_m if main_m else "no main (single deployment)")
    if fc.pad.ground_fixed:
        notes.append("ground reference from metadata ground_pressure_pa")
    else:
        notes.append("ground reference from %d quiet pad samples" % fc.pad.cal_samples)
    return ReplayResult(events, log.time_s, out["raw"], out["agl"], out["vel"], out["acc"], state,
                        pyro_d, pyro_m, pyro_bd, pyro_bm, fc.pad.cal_samples, fc.errors, notes)


def _detail(fc, bit):
    """What a health or mode event changed to."""
    if bit == EV_HEALTH:
        faults = [name for k, name in enumerate(HEALTH_NAMES) if fc.health.flags & (1 << k)]
        return ", ".join(faults) or "healthy"
    if bit == EV_MODE:
        return MODE_NAMES[fc.mode] + (" (barometer excluded)" if fc.baro_excluded else "")
    return ""


def config_for(log, config_path=None, overrides=None):
    """The configuration for replaying ``log``: a JSON file, else the board's own configuration
    when the log is a decoded board log (``# board_config:`` metadata), else defaults; then CLI
    overrides. The sensors setting follows the columns present; the deployment plan (the log's
    ``main_deploy_m`` metadata: a height, or ``none``), the accelerometer's range and the
    barometer's lag and noise class come from the log's metadata when the configuration does not
    set them."""
    values = {}
    if config_path:
        values = config_file_values(config_path)
    elif "board_config" in log.metadata:
        try:
            values = json.loads(log.metadata["board_config"])
        except ValueError as exc:
            raise ConfigError("%s: metadata board_config is not valid JSON: %s" % (log.path, exc)) from None
        if not isinstance(values, dict):
            raise ConfigError("%s: metadata board_config is not a JSON object of settings (got %s)" % (
                log.path, type(values).__name__))
    values = dict(values, **(overrides or {}))
    if "main_deploy_m" not in values and log.main_deploy_m() is not None:
        values["main_deploy_m"] = log.main_deploy_m()
    for key in ("accel_range_g", "baro_lag_ms"):
        if key not in values and log.metadata_float(key) is not None:
            values[key] = log.metadata_float(key)
    if "baro_noise" not in values and "baro_noise" in log.metadata:
        values["baro_noise"] = log.metadata["baro_noise"]
    if "sensors" not in (overrides or {}):
        has_baro = log.pressure_pa is not None or log.altitude_m is not None
        has_accel = log.has_accel
        values["sensors"] = "both" if has_baro and has_accel else ("baro" if has_baro else "accel")
    return load_config(values)


def register(subparsers):
    p = subparsers.add_parser(
        "replay", help="replay a flight CSV through the board's state machine",
        description="Feed every sample of a flight CSV (docs/FLIGHT_CSV.md) through the exact "
                    "shared/ code the board runs, and print the events: launch, burnout, ignition "
                    "(a motor lit in coast), apogee, drogue, main, landed, with their time in the "
                    "file's time base and the filtered altitude above the pad.")
    p.add_argument("file", help="flight CSV, or an export docs/IMPORT.md lists (format detected)")
    p.add_argument("--config", help="flight configuration JSON (docs/CONFIG.md); defaults otherwise")
    p.add_argument("--main-altitude", type=float, metavar="M",
                   help="main deployment altitude, m AGL, 0 for no main (default: the configuration, "
                        "else the file's main_deploy_m metadata, else 250)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="write a plot of the replay")
    p.add_argument("--report", metavar="DIR", help="write the flight review: DIR/report.png (one page) "
                   "and DIR/report.md (summary), with the board's own decisions when the log holds them")
    p.add_argument("--units", choices=("m", "ft"), default="m", help="units of the review (default m)")
    p.add_argument("--check", action="store_true",
                   help="FILE is a board log (flight.log): exit 1 at the first sample whose state, events "
                        "or pyro outputs differ from the desktop replay, 0 when all match")
    p.set_defaults(func=run)


def run(args):
    if args.check:
        from desktop.review.logcheck import run_check

        return run_check(args.file, args.config)
    if args.plot:
        check_output_file(args.plot, "plot")
    if args.report:
        check_output_file(args.report, "report")
    log = read_flight(args.file)
    overrides = {}
    if args.main_altitude is not None:
        overrides["main_deploy_m"] = args.main_altitude
    config = config_for(log, args.config, overrides)
    result = replay(log, config)
    if args.plot:
        from desktop.review.plot import plot_replay

        plot_replay(result, log, config, args.plot)
    if args.report:
        from desktop.review.report import write_report

        try:
            write_report(result, log, config, args.report, args.units)
        except OSError as exc:
            raise OutputPathError(f"{args.report}: cannot write the report: {exc.strerror or exc}") from None
    if args.json:
        print(json.dumps({
            "file": args.file,
            "events": [e.as_dict() for e in result.events],
            "max_altitude_m": round(float(np.nanmax(result.agl_m)), 2),
            "ground_samples": result.ground_samples,
            "errors": result.errors,
            "notes": result.notes,
            "config": config.values,
        }, indent=2))
        return 0
    print("%s: %d samples, %s" % (args.file, len(log), "; ".join(result.notes)))
    if not result.events:
        print("no events")
    for e in result.events:
        print("%-13s t = %9.3f s   altitude %8.1f m AGL%s" % (e.event, e.time_s, e.altitude_m,
                                                          "   " + e.detail if e.detail else ""))
    print("max altitude %.1f m AGL; final state %s" % (float(np.nanmax(result.agl_m)),
                                                        STATE_NAMES[int(result.state[-1])]))
    return 0
