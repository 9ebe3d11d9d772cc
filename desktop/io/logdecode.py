"""Decode a board's flight log (``flight.log``) into a flight CSV: ``python -m desktop logdecode``.

The log format is defined in ``shared/logformat.py``. The decoder checks every block (magic, CRC,
sequence number) and reports every problem and every gap in the samples; a damaged header costs
only the header (the blocks are found by their magic and CRC, and the configuration is reported
unknown). It keeps the records of the flight computer that was in use at the end of the log
(the board starts a fresh one every few seconds on the pad: ``device/flightloop.py``, "pad
epochs"), and writes them as a flight CSV (docs/FLIGHT_CSV.md) that replays through the same
``shared/`` code bit for bit:

- ``time_s``: the sum of the board's integer ``dt_us``, plus one sample period for every sample
  missing from the log (a lost block keeps its time: the replay predicts across the gap), 0 at the
  launch sample (or at the first row without a launch): exact microseconds;
- ``pressure_pa``: the board's Pa x 16 reading divided by 16, written with 4 decimals (exact), empty
  where the sample had no fresh barometer reading;
- ``accel_mps2``: the board's mm/s^2 reading / 1000 (exact at 4 decimals), empty when missing;
- ``board_state``, ``board_events``, ``board_flags``, ``board_alt_q4``, ``board_vel_q4``,
  ``board_acc_q4``: what the board decided (the filter columns are empty for the first rows, logged
  while this flight computer was still the pad's "shadow"; ``board_events`` holds the backup
  channels' events too, restored from their output flags by ``board_events``), ``temp_c``,
  ``board_work_us``.

It also writes the board's configuration next to the CSV (``FLIGHT.config.json``): replay with
``python -m desktop replay FLIGHT.csv --config FLIGHT.config.json``. ``--check`` steps the
board's own integer inputs, record by record, through ``shared/`` with the board's configuration
and compares every sample's state, events and pyro outputs (and filter state where logged) with
the board's (``differences``; ``python -m desktop replay --check LOG`` stops at the first one).
"""

import json
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from desktop.errors import DesktopError
from desktop.io.files import check_output_file, read_bytes
from desktop.io.pressure_altitude import pressure_to_alt_mm_array
from shared import logformat as fl
from shared.flight import (
    BOOST,
    COAST,
    EV_BACKUP_DROGUE,
    EV_BACKUP_MAIN,
    EV_IGNITION,
    EVENT_NAMES,
    FAST,
    PAD,
    STATE_NAMES,
    FlightComputer,
)

_REC_DTYPE = np.dtype([
    ("dt_us", "<u4"), ("pressure_q4_pa", "<i4"), ("accel_mmps2", "<i4"), ("alt_q4", "<i4"),
    ("vel_q4", "<i4"), ("acc_q4", "<i4"), ("have", "u1"), ("state", "u1"), ("events", "u1"),
    ("flags", "u1"), ("temp_cdeg", "<i2"), ("work_us", "<u2"),
])
assert _REC_DTYPE.itemsize == fl.REC_SIZE
HAVE_BARO = 1
HAVE_ACCEL = 2
EV_LAUNCH = 1


class LogDecodeError(DesktopError):
    """A log that cannot be decoded; one line naming the file and the problem."""


@dataclass
class DecodedLog:
    path: str
    header: dict
    records: np.ndarray  # structured, one per sample kept (sample order)
    sample: np.ndarray  # board sample index of each record
    fc_start_of_block: np.ndarray  # fc_start of the block each record came from
    fc_start: int  # the flight computer whose decisions the records end with
    summary: dict | None
    notes: list = field(default_factory=list)  # note blocks (JSON)
    problems: list = field(default_factory=list)  # bad/truncated blocks, gaps
    blocks: int = 0
    after_resume: int = 0  # records after a reset in flight (not decoded into rows)

    @property
    def config(self):
        return self.header.get("config", {})


def read_log(path):
    """Parse and check a board log file; InputFileError if it cannot be read, LogDecodeError if it
    is not a flight log."""
    data = read_bytes(path, "flight log")
    if not data.startswith(fl.FILE_MAGIC):
        raise LogDecodeError(f"{path}: not a flight log (no {fl.FILE_MAGIC!r} magic)")
    problems = []
    header, off = _read_header(data)
    if header is None:
        # a damaged header costs the configuration, not the blocks: they are found by their magic
        # and CRC (a replay then uses the default configuration: say so)
        problems.append("header damaged (length or CRC): blocks read without it; configuration unknown")
        header = {"format": fl.FORMAT_VERSION}
        off = _next_block(data, len(fl.FILE_MAGIC))
    elif header.get("format") != fl.FORMAT_VERSION:
        raise LogDecodeError(f"{path}: log format {header.get('format')!r}, this decoder reads "
                             f"{fl.FORMAT_VERSION}")
    notes = []
    summary = None
    recs, samples, fcs = [], [], []
    nblocks = 0
    last_seq = None
    resumed_at = None
    resumed_sample = None
    while off < len(data):
        block = data[off:off + fl.BLOCK_SIZE]
        index = nblocks
        off += fl.BLOCK_SIZE
        nblocks += 1
        if len(block) < fl.BLOCK_SIZE:
            problems.append(f"block {index}: truncated ({len(block)} of {fl.BLOCK_SIZE} bytes): power lost "
                            "while writing")
            break
        magic, seq, first, nrec, kind, fc_start, _crc = struct.unpack_from(fl.BLK_FMT, block, 0)
        if magic != fl.BLK_MAGIC:
            problems.append(f"block {index}: bad magic")
            resync = _next_block(data, off - fl.BLOCK_SIZE + 1)
            if resync < len(data):  # blocks continue at another offset: follow them
                off = resync
            continue
        if not fl.block_crc_ok(block):
            problems.append(f"block {index} (seq {seq}): CRC mismatch, skipped")
            continue
        if last_seq is not None and seq <= last_seq:
            # blocks are numbered from 0 in each log: another log's blocks follow (files joined)
            problems.append(f"block {index}: sequence {seq} after {last_seq}: another log starts here "
                            "(files joined?); only the first is decoded")
            break
        if last_seq is not None and seq != last_seq + 1:
            problems.append(f"block {index}: sequence {seq} after {last_seq}")
        last_seq = seq
        if kind == fl.KIND_DATA:
            if nrec > fl.BLOCK_RECORDS:
                problems.append(f"block {index}: {nrec} records")
                continue
            r = np.frombuffer(block, dtype=_REC_DTYPE, count=nrec, offset=fl.BLK_HDR)
            recs.append(r)
            samples.append(np.arange(first, first + nrec, dtype=np.int64))
            fcs.append(np.full(nrec, fc_start, dtype=np.int64))
        else:
            body = bytes(block[fl.BLK_HDR:fl.BLK_HDR + nrec])
            try:
                obj = json.loads(body.decode())
            except ValueError:
                what = "summary" if kind == fl.KIND_SUMMARY else "note"
                problems.append(f"block {index}: unreadable {what}")
                continue
            if kind == fl.KIND_SUMMARY:
                summary = obj
            else:
                obj["_at_record"] = sum(len(r) for r in recs)
                notes.append(obj)
                if obj.get("resumed") and resumed_at is None:
                    resumed_at = obj["_at_record"]
                    resumed_sample = obj.get("sample")
    if not recs:
        raise LogDecodeError(f"{path}: no data blocks" + (f" ({problems[0]})" if problems else ""))
    records = np.concatenate(recs)
    sample = np.concatenate(samples)
    fcb = np.concatenate(fcs)
    after_resume = 0
    if resumed_at:  # the rows of the first session only
        problems.append("the board was reset in flight and resumed at sample %s: rows stop there (a "
                        "replay cannot reproduce a restored state)" % resumed_sample)
        after_resume = len(records) - resumed_at
        records, sample, fcb = records[:resumed_at], sample[:resumed_at], fcb[:resumed_at]
    elif resumed_at == 0:  # nothing of the first session reached flash (it was still in RAM)
        problems.append("no records before the reset reached flash: the rows are the resumed session's, "
                        "which a replay from the start cannot reproduce")
    order = np.argsort(sample, kind="stable")
    records, sample, fcb = records[order], sample[order], fcb[order]
    gaps = np.flatnonzero(np.diff(sample) > 1)
    for g in gaps:  # every gap: the rows' time keeps it (to_columns)
        problems.append(f"samples {sample[g] + 1}..{sample[g + 1] - 1} missing "
                        f"({sample[g + 1] - sample[g] - 1} samples)")
    log = DecodedLog(str(path), header, records, sample, fcb, int(fcb[-1]), summary, notes, problems, nblocks)
    log.after_resume = after_resume
    return log


def _read_header(data):
    """The header dict and the offset after it, or (None, 0) when its length or CRC is bad."""
    off = len(fl.FILE_MAGIC)
    if len(data) < off + 8:
        return None, 0
    hlen, hcrc = struct.unpack_from(fl.FILE_HDR_FMT, data, off)
    off += 8
    text = data[off:off + hlen]
    if len(text) != hlen or (fl.crc32(text) & 0xFFFFFFFF) != hcrc:
        return None, 0
    try:
        return json.loads(text.decode()), off + hlen
    except ValueError:
        return None, 0


def _next_block(data, start):
    """Offset of the first block at or after ``start`` whose magic and CRC are right (or the end)."""
    magic = struct.pack("<I", fl.BLK_MAGIC)
    off = data.find(magic, start)
    while off >= 0:
        block = data[off:off + fl.BLOCK_SIZE]
        if len(block) == fl.BLOCK_SIZE and fl.block_crc_ok(block):
            return off
        off = data.find(magic, off + 1)
    return len(data)


def final_rows(log):
    """(records, owned, time_us) of the final flight computer's rows: ``owned`` is False on the
    rows logged while it was still the pad's shadow (their filter fields are the previous one's);
    ``time_us`` is the sum of the board's ``dt_us`` plus one period per missing sample, 0 at the
    launch sample (or the first row)."""
    keep = log.sample >= log.fc_start
    r = log.records[keep]
    if not len(r):
        raise LogDecodeError(f"{log.path}: no records from sample {log.fc_start} on")
    own = log.fc_start_of_block[keep] == log.fc_start
    dt = r["dt_us"].astype(np.int64)
    # time from the sample indices: a missing sample (a lost block) took one period, so a gap
    # stays a gap in time (the replay's filter predicts across it), never silently closed
    period = int(log.header.get("period_us") or 0)
    if not period:
        sample_hz = log.header.get("sample_hz")
        period = 1000000 // int(sample_hz) if sample_hz else int(np.median(dt[1:])) if len(dt) > 1 else 0
    missing = np.concatenate([[0], np.diff(log.sample[keep]) - 1])
    t_us = np.cumsum(np.concatenate([[0], dt[1:]]) + missing * period)
    launch = np.flatnonzero(r["events"] & EV_LAUNCH)
    if len(launch):
        t_us = t_us - t_us[launch[0]]
    return r, own, t_us


# a backup channel's event is not in the record's event byte: its output flag rises with it
_BACKUP_FLAGS = ((fl.FLAG_PYRO_BACKUP_DROGUE, EV_BACKUP_DROGUE), (fl.FLAG_PYRO_BACKUP_MAIN, EV_BACKUP_MAIN))


def board_events(events, flags, states):
    """The flight computer's events per record: the record's event byte, each backup channel's
    event on the record where its output flag rises, and an ignition in coast on the record where
    the state goes from fast or coast back to boost (shared/logformat.py). Old logs never set
    those flags: their events are the byte."""
    out = np.asarray(events).astype(np.int64)
    flags = np.asarray(flags).astype(np.int64)
    for flag, event in _BACKUP_FLAGS:
        on = flags & flag != 0
        rise = on & ~np.concatenate([[False], on[:-1]])
        out = out | np.where(rise, event, 0)
    states = np.asarray(states).astype(np.int64)
    before = np.concatenate([[PAD], states[:-1]])
    out = out | np.where((states == BOOST) & ((before == FAST) | (before == COAST)), EV_IGNITION, 0)
    return out


def to_columns(log):
    """The flight-CSV columns (dict) and metadata for the rows of the final flight computer."""
    r, own, t_us = final_rows(log)
    keep = log.sample >= log.fc_start
    have = r["have"]
    q4 = r["pressure_q4_pa"].astype(np.int64)
    pressure = np.empty(len(r), dtype=object)
    for i in range(len(r)):
        if have[i] & HAVE_BARO:
            whole, frac = divmod(int(q4[i]), 16)
            pressure[i] = f"{whole}.{frac * 625:04d}"  # q4 / 16 exactly (1/16 = 0.0625)
        else:
            pressure[i] = None
    accel = np.where(have & HAVE_ACCEL, r["accel_mmps2"] / 1000.0, np.nan)

    def owned(name):
        out = np.empty(len(r), dtype=object)
        out[:] = [int(v) if o else None for v, o in zip(r[name], own, strict=True)]
        return out

    cols = {
        "time_s": t_us / 1e6,
        "pressure_pa": pressure,
        "accel_mps2": accel,
        "board_state": r["state"].astype(np.int64),
        "board_events": board_events(r["events"], r["flags"], r["state"]),
        "board_flags": r["flags"].astype(np.int64),
        "board_alt_q4": owned("alt_q4"),
        "board_vel_q4": owned("vel_q4"),
        "board_acc_q4": owned("acc_q4"),
        "temp_c": r["temp_cdeg"] / 100.0,
        "board_work_us": r["work_us"].astype(np.int64),
    }
    h = log.header
    meta = {
        "source": "apogee-fc board log %s" % Path(log.path).name,
        "firmware": h.get("firmware", "?"),
        "board": (h.get("board") or {}).get("board", "?"),
        "sample_hz": h.get("sample_hz", "?"),
        "board_sample_first": int(log.sample[keep][0]),
        "board_fc_start": log.fc_start,
        "board_config": json.dumps(h.get("config", {}), sort_keys=True, separators=(",", ":")),
    }
    if log.config.get("main_deploy_m") is not None:
        meta["main_deploy_m"] = log.config["main_deploy_m"]
    if log.summary:
        for key in ("missed_deadlines", "worst_dt_us", "worst_work_us", "baro_errors", "accel_errors",
                    "log_dropped"):
            if key in log.summary:
                meta["board_" + key] = log.summary[key]
    return cols, meta


def write_csv(log, out_csv, config_out=None):
    from desktop.io.flightcsv import write_flight_csv

    cols, meta = to_columns(log)
    comments = ["decoded from a board flight log; replay with the config file written next to it"]
    if log.problems:
        comments.append("log problems: " + "; ".join(log.problems)[:500])
    write_flight_csv(out_csv, cols, metadata=meta, comments=comments)
    if config_out is None:
        config_out = Path(out_csv).with_suffix(".config.json")
    Path(config_out).write_text(json.dumps(log.config, indent=2, sort_keys=True) + "\n")
    return Path(out_csv), Path(config_out)


def _names(events):
    return "+".join(name for bit, name in enumerate(EVENT_NAMES) if events & (1 << bit)) or "none"


_PYRO_FLAGS = (fl.FLAG_PYRO_DROGUE, fl.FLAG_PYRO_MAIN, fl.FLAG_PYRO_BACKUP_DROGUE, fl.FLAG_PYRO_BACKUP_MAIN)


def differences(inputs, board, config, ground_alt_mm=None):
    """Yield ``(row, description)`` for every row whose step through a FlightComputer with
    ``config`` differs from what the board logged: state, events, pyro outputs, and the filter
    state where the board logged it (not NaN).

    ``inputs``: the integer ``(dt_us, alt_mm, accel_mmps2, have)`` arrays the board's step was
    given; ``board``: arrays ``state``, ``events`` (``board_events``), ``flags``, ``alt_q4``,
    ``vel_q4``, ``acc_q4``."""
    dt_us, alt_mm, accel, have = inputs
    fc = FlightComputer(config, ground_alt_mm=ground_alt_mm)
    kf = fc.kf
    filt_b = (board["alt_q4"], board["vel_q4"], board["acc_q4"])
    for i in range(len(dt_us)):
        fc.step(int(dt_us[i]), int(alt_mm[i]), int(accel[i]), int(have[i]))
        found = []
        state_b, events_b, flags_b = int(board["state"][i]), int(board["events"][i]), int(board["flags"][i])
        if fc.state != state_b:
            found.append(f"state: replay {STATE_NAMES[fc.state]}, board {STATE_NAMES[state_b]}")
        if fc.events != events_b:
            found.append(f"events: replay {_names(fc.events)}, board {_names(events_b)}")
        pyro_b = tuple(int(flags_b & f != 0) for f in _PYRO_FLAGS)
        pyro = (int(fc.pyro_drogue), int(fc.pyro_main), int(fc.pyro_backup_drogue), int(fc.pyro_backup_main))
        if pyro != pyro_b:
            found.append(f"pyro (drogue, main, backup drogue, backup main): replay {pyro}, board {pyro_b}")
        if not np.isnan(filt_b[0][i]):
            logged = tuple(int(col[i]) for col in filt_b)
            if (kf.alt_q4, kf.vel_q4, kf.acc_q4) != logged:
                found.append(f"filter state: replay {(kf.alt_q4, kf.vel_q4, kf.acc_q4)}, board {logged}")
        if found:
            yield i, "; ".join(found)


def board_config(log, config_path=None):
    """The configuration the board flew (the log header's), or the JSON file ``config_path``."""
    from desktop.io.config_file import config_file_values
    from shared.config import load_config

    return load_config(config_file_values(config_path) if config_path else log.config)


def log_differences(log, config):
    """``differences`` of a decoded board log's final flight computer, straight from its records.

    Returns (time_us per row, generator of (row, description))."""
    r, own, t_us = final_rows(log)
    q4 = r["pressure_q4_pa"].astype(np.int64)
    have = r["have"].astype(np.int64)
    alt_mm = np.where(have & HAVE_BARO, pressure_to_alt_mm_array(q4), 0)
    inputs = (r["dt_us"].astype(np.int64), alt_mm, r["accel_mmps2"].astype(np.int64), have)
    board = {name: r[name].astype(np.int64) for name in ("state", "flags")}
    board["events"] = board_events(r["events"], r["flags"], r["state"])
    for name in ("alt_q4", "vel_q4", "acc_q4"):
        board[name] = np.where(own, r[name], np.nan)
    return t_us, differences(inputs, board, config)


MAX_PROBLEMS_SHOWN = 10  # rows that differ, described one a line; the rest are not listed


def first_problems(found) -> list[str]:
    """One line for each of the first MAX_PROBLEMS_SHOWN (row, description) of ``found``."""
    problems = []
    for row, what in found:
        problems.append(f"row {row}: {what}")
        if len(problems) == MAX_PROBLEMS_SHOWN:
            break
    return problems


def check_log(log, config):
    """(rows compared, at most MAX_PROBLEMS_SHOWN descriptions of the rows that differ) of a
    decoded board log."""
    t_us, found = log_differences(log, config)
    return len(t_us), first_problems(found)


def register(subparsers):
    p = subparsers.add_parser(
        "logdecode", help="decode a board flight log (flight.log) into a flight CSV",
        description="Check and decode the binary flight log the board writes (shared/logformat.py) into "
                    "a flight CSV (docs/FLIGHT_CSV.md) and the board's configuration (JSON), so that "
                    "'python -m desktop replay FLIGHT.csv --config FLIGHT.config.json' reproduces the "
                    "board's decisions sample for sample.")
    p.add_argument("file", help="the board's log (flight.log, pulled with tools/deploy.py pull)")
    p.add_argument("--out", required=True, metavar="FLIGHT.csv", help="flight CSV to write")
    p.add_argument("--config-out", metavar="CONFIG.json", help="where to write the board's configuration "
                   "(default: next to the CSV, FLIGHT.config.json)")
    p.add_argument("--check", action="store_true",
                   help="replay the CSV and compare with the board's decisions")
    p.add_argument("--json", action="store_true", help="print the decode report as JSON")
    p.set_defaults(func=run)


def run(args):
    check_output_file(args.out, "flight CSV")
    if args.config_out:
        check_output_file(args.config_out, "configuration file")
    log = read_log(args.file)
    csv_path, cfg_path = write_csv(log, args.out, args.config_out)
    report = {
        "file": args.file,
        "blocks": log.blocks,
        "records": int(len(log.records)),
        "rows_written": int(np.count_nonzero(log.sample >= log.fc_start)),
        "fc_start": log.fc_start,
        "problems": log.problems,
        "summary": log.summary,
        "csv": str(csv_path),
        "config": str(cfg_path),
        "replay": f"python -m desktop replay {csv_path} --config {cfg_path}",
    }
    if args.check:
        n, problems = check_log(log, board_config(log))
        report["check"] = {"samples": n, "identical": not problems, "differences": problems}
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        print(f"{args.file}: {log.blocks} blocks, {len(log.records)} records; "
              f"{report['rows_written']} rows written to {csv_path} "
              f"(flight computer from sample {log.fc_start})")
        for prob in log.problems:
            print(f"  problem: {prob}")
        if log.summary:
            s = log.summary
            print(f"  board: {s.get('reason')}, max altitude {s.get('max_agl_mm', 0) / 1000:.1f} m, "
                  f"{s.get('missed_deadlines')} missed deadlines, worst work {s.get('worst_work_us')} us")
        print(f"  config: {cfg_path}")
        print(f"  replay: {report['replay']}")
        if args.check:
            c = report["check"]
            if c["identical"]:
                print(f"  check: replay reproduces the board's decisions on all {c['samples']} samples")
            else:
                print("  check: DIFFERENT: " + "; ".join(c["differences"]))
    if args.check and not report["check"]["identical"]:
        return 1
    return 0
