"""The flight log format (device/flightlog.py) and its decoder (desktop/io/logdecode.py) on CPython.

``make_log`` writes a log the way the board does (LogBuffer through a FlightComputer run) so the
decoder's checks can be exercised without MicroPython: bit-identical replay, a truncated last
block (power lost while writing), a damaged block, and the ring's pad behaviour.
"""

import json
import struct

import numpy as np
import pytest

from desktop.errors import InputFileError
from desktop.io.logdecode import LogDecodeError, board_config, check_log, read_log, to_columns, write_csv
from device import flightlog as fl
from device.status import digits_pattern
from shared.altitude import pressure_to_alt_mm
from shared.config import load_config
from shared.flight import EV_IGNITION, EV_LAUNCH, FlightComputer
from tests.support.decoded_replay import check_replay
from tests.support.fault_flight import AIR_START_ROCKET, fly
from tools.synthetic_flight import make_flight


def _pressure_q4(alt_mm):
    return int(round(101325.0 * (1 - 2.25577e-5 * alt_mm / 1000) ** 5.25588 * 16))


def make_log(path, rate_hz=50, seed=3, ram_kb=512, header_extra=None, flight=None):
    """Write a board-format log of a synthetic flight (or of ``flight``: arrays of altitude in mm,
    specific force in mm/s^2 and ``have``, at ``rate_hz``); returns (FlightComputer, LogBuffer)."""
    if flight is None:
        _dts, alts, accs, _truth, _apogee = make_flight(rate_hz=rate_hz, seed=seed, pad_s=3, after_apogee_s=4)
        specific = [a + 9807 for a in accs]
        haves = [3 if i % 2 == 0 else 2 for i in range(len(alts))]  # barometer at half the rate
    else:
        alts, specific, haves = flight
    config = load_config({})
    fc = FlightComputer(config)
    log = fl.LogBuffer(ram_kb * 1024)
    period = 1000000 // rate_hz
    header = {"format": fl.FORMAT_VERSION, "firmware": "test", "board": {"board": "test"},
              "config": config.values, "sample_hz": rate_hz}
    header.update(header_extra or {})
    with open(path, "wb") as f:
        f.write(fl.file_header(json.dumps(header)))
        for i in range(len(alts)):
            q4 = _pressure_q4(int(alts[i]))
            acc = int(specific[i])
            have = int(haves[i])
            fc.step(period, pressure_to_alt_mm(q4), acc, have)
            kf = fc.kf
            # pyro output levels, as device/flightloop.py logs them
            flags = (fl.FLAG_PYRO_DROGUE if fc.pyro_drogue else 0) | (
                fl.FLAG_PYRO_MAIN if fc.pyro_main else 0)
            log.record(period, q4, acc, kf.alt_q4, kf.vel_q4, kf.acc_q4, have, fc.state,
                       fc.events & fl.EVENTS_MASK, flags, 1500, 100)
        log.write_all(f)
        log.write_text(f, fl.KIND_SUMMARY, json.dumps({"reason": "test", "max_agl_mm": fc.max_agl_mm}))
    return fc, log


def test_record_layout():
    assert struct.calcsize(fl.REC_FMT) == fl.REC_SIZE == 32
    assert struct.calcsize(fl.BLK_FMT) == 24 <= fl.BLK_HDR
    assert fl.BLK_HDR + fl.BLOCK_RECORDS * fl.REC_SIZE == fl.BLOCK_SIZE
    assert len(fl.REC_FIELDS) == len(fl.REC_FMT) - 1


def test_log_replays_bit_identically(tmp_path):
    fc, _log = make_log(tmp_path / "flight.log")
    log = read_log(tmp_path / "flight.log")
    assert not log.problems and log.summary["reason"] == "test"
    csv, cfg = write_csv(log, tmp_path / "flight.csv")
    n, problems = check_replay(csv, cfg)
    assert not problems and n == len(log.records)
    assert check_log(log, board_config(log)) == (n, [])  # the records themselves, without the CSV
    text = csv.read_text()
    assert "ground_pressure_pa" not in text  # the board calibrated on its pad: so must the replay
    row = [x for x in text.splitlines() if x[:1].isdigit() or x[:1] == "-"][0].split(",")
    assert len(row[1].split(".")[1]) == 4  # Pa x 16 written exactly


def test_log_of_a_staged_flight_keeps_the_ignition(tmp_path):
    # the record's event byte has no room for it: the decoder restores it where the logged state
    # goes back to boost (docs/DESIGN.md D19), and the replay agrees on every row
    flight = fly(AIR_START_ROCKET, after_apogee_s=3.0)
    fc, _log = make_log(tmp_path / "flight.log", rate_hz=100,
                        flight=(flight.alt_mm, flight.accel_mmps2, flight.have))
    log = read_log(tmp_path / "flight.log")
    cols, _meta = to_columns(log)
    ignitions = np.flatnonzero(cols["board_events"] & EV_IGNITION)
    assert len(ignitions) == 1
    # the log's time counts from the launch, which the board sees 0.09 s after the first motor
    # lit, and the ignition takes the launch's 0.1 s of boost too
    launch = np.flatnonzero(cols["board_events"] & EV_LAUNCH)[0]
    since_launch_s = cols["time_s"][ignitions[0]] - cols["time_s"][launch]
    assert abs(since_launch_s - AIR_START_ROCKET.motor2_at_s) <= 0.02, since_launch_s
    assert check_log(log, board_config(log))[1] == []


def test_truncated_last_block_loses_only_that_block(tmp_path):
    make_log(tmp_path / "flight.log")
    data = (tmp_path / "flight.log").read_bytes()
    full = read_log(tmp_path / "flight.log")
    (tmp_path / "cut.log").write_bytes(data[:-fl.BLOCK_SIZE - 700])  # power lost mid-write
    log = read_log(tmp_path / "cut.log")
    assert any("truncated" in p for p in log.problems)
    assert len(log.records) == len(full.records) - (len(full.records) % fl.BLOCK_RECORDS or fl.BLOCK_RECORDS)
    csv, cfg = write_csv(log, tmp_path / "cut.csv")
    assert not check_replay(csv, cfg)[1]  # what is left still replays exactly


def test_damaged_block_is_detected(tmp_path):
    make_log(tmp_path / "flight.log")
    data = bytearray((tmp_path / "flight.log").read_bytes())
    start = data.index(struct.pack("<I", fl.BLK_MAGIC)) + fl.BLOCK_SIZE  # the second block
    data[start + fl.BLK_HDR + 5 * fl.REC_SIZE + 3] ^= 0x40  # one bit of one record
    (tmp_path / "bad.log").write_bytes(bytes(data))
    log = read_log(tmp_path / "bad.log")
    assert any("CRC mismatch" in p for p in log.problems)
    assert any("samples 63..125 missing" in p for p in log.problems)
    assert any("sequence 2 after 0" in p for p in log.problems)


def test_two_logs_joined_in_one_file_decode_as_the_first(tmp_path):
    # two flight logs joined into one file (cat a.log b.log): the second's blocks, numbered from 0
    # again, repeated the first's sample numbers, and the flight CSV writer stopped on a time that
    # went backwards (a traceback). The decoder stops at the sequence that goes back, and says so
    make_log(tmp_path / "flight.log")
    data = (tmp_path / "flight.log").read_bytes()
    (tmp_path / "joined.log").write_bytes(data + data)
    full, log = read_log(tmp_path / "flight.log"), read_log(tmp_path / "joined.log")
    assert np.array_equal(log.records, full.records)
    assert any("another log starts here" in p for p in log.problems)
    csv, cfg = write_csv(log, tmp_path / "joined.csv")
    assert not check_replay(csv, cfg)[1]


def test_the_check_of_a_damaged_log_stops_at_its_first_gap(tmp_path, capsys):
    # a block lost in flight: past the gap the replay lacks the board's inputs and its filter
    # parts from the board's, which is no difference of the replay's. The check compares the rows
    # before the gap, and names the gap
    from desktop.review.logcheck import run_check

    make_log(tmp_path / "flight.log")
    data = (tmp_path / "flight.log").read_bytes()
    first = data.index(struct.pack("<I", fl.BLK_MAGIC))
    cut = first + 5 * fl.BLOCK_SIZE  # the sixth block: in the boost
    (tmp_path / "gap.log").write_bytes(data[:cut] + data[cut + fl.BLOCK_SIZE:])
    log = read_log(tmp_path / "gap.log")
    assert check_log(log, board_config(log))[1]  # past the gap the filter parts from the board's
    assert run_check(tmp_path / "gap.log") == 0
    lo = 5 * fl.BLOCK_RECORDS
    out = capsys.readouterr().out
    assert f"before the log's first gap (samples {lo}..{lo + fl.BLOCK_RECORDS - 1} missing" in out


def test_flipped_bit_in_the_header_costs_only_the_header(tmp_path):
    make_log(tmp_path / "flight.log")
    full = read_log(tmp_path / "flight.log")
    data = bytearray((tmp_path / "flight.log").read_bytes())
    data[len(fl.FILE_MAGIC) + 8 + 20] ^= 0x04  # one bit of the header's JSON
    (tmp_path / "bad.log").write_bytes(bytes(data))
    log = read_log(tmp_path / "bad.log")
    assert any("header damaged" in p for p in log.problems)
    assert len(log.records) == len(full.records) and log.blocks == full.blocks
    assert np.array_equal(log.records, full.records)


def test_lost_block_is_reported_and_keeps_its_time(tmp_path):
    # a block lost from the middle of the flight: every gap is reported, and the rows after it keep
    # their time (from the sample index), so the apogee's time does not move
    make_log(tmp_path / "flight.log")
    full = read_log(tmp_path / "flight.log")
    data = (tmp_path / "flight.log").read_bytes()
    first = data.index(struct.pack("<I", fl.BLK_MAGIC))
    cut = first + 5 * fl.BLOCK_SIZE  # the sixth block
    (tmp_path / "gap.log").write_bytes(data[:cut] + data[cut + fl.BLOCK_SIZE:])
    log = read_log(tmp_path / "gap.log")
    lo = 5 * fl.BLOCK_RECORDS
    assert any(f"samples {lo}..{lo + fl.BLOCK_RECORDS - 1} missing" in p for p in log.problems)
    from desktop.io.logdecode import to_columns

    cols_full, _ = to_columns(full)
    cols, _ = to_columns(log)
    t_full = dict(zip(full.sample.tolist(), np.round(cols_full["time_s"] * 1e6).astype(int).tolist(),
                      strict=True))
    t_gap = dict(zip(log.sample.tolist(), np.round(cols["time_s"] * 1e6).astype(int).tolist(), strict=True))
    assert all(t_gap[k] == t_full[k] for k in t_gap)


def test_not_a_log(tmp_path):
    (tmp_path / "x.log").write_bytes(b"hello")
    with pytest.raises(LogDecodeError, match="not a flight log"):
        read_log(tmp_path / "x.log")
    with pytest.raises(InputFileError, match="flight log not found"):
        read_log(tmp_path / "missing.log")


def test_cli_logdecode_errors_one_line(tmp_path, capsys):
    from desktop.cli import main

    (tmp_path / "x.log").write_bytes(b"hello")
    assert main(["logdecode", str(tmp_path / "x.log"), "--out", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a flight log" in err


def _fill(log, n, start_value=0):
    for i in range(n):
        log.record(20000, start_value + i, 0, 0, 0, 0, 3, 0, 0, 0, 0, 0)


def test_ring_keeps_pad_records_from_keep_from():
    log = fl.LogBuffer(6 * fl.BLOCK_SIZE)  # six blocks of RAM
    log.keep_from = 8 * fl.BLOCK_RECORDS + 5  # the flight computer in use started there
    _fill(log, 10 * fl.BLOCK_RECORDS)  # ten blocks on the pad: the oldest are reused
    assert log.discarded == 4 and log.count == 6 and log.cur == -1
    log.freeze()  # launch: blocks wholly before keep_from go
    assert log.count == 2  # blocks 8 and 9
    assert log.slot_first[log.head] == 8 * fl.BLOCK_RECORDS
    _fill(log, 5 * fl.BLOCK_RECORDS)  # frozen: four more blocks fit, then records are dropped
    assert log.count == 6 and log.dropped == fl.BLOCK_RECORDS
    assert not log.incomplete


def test_ring_flags_an_overrun_pad():
    log = fl.LogBuffer(4 * fl.BLOCK_SIZE)
    log.keep_from = 0  # the flight computer in use started at sample 0: nothing may be reused
    _fill(log, 6 * fl.BLOCK_RECORDS)
    assert log.incomplete


def test_file_size_cap(tmp_path):
    log = fl.LogBuffer(8 * fl.BLOCK_SIZE)
    log.max_blocks = 2
    _fill(log, 4 * fl.BLOCK_RECORDS)
    with open(tmp_path / "f.log", "wb") as f:
        log.write_all(f)
    assert log.written == 2 and log.over_cap == 2


def test_record_is_allocation_free_in_design():
    """record() packs into the preallocated buffer: the same bytes the decoder reads."""
    log = fl.LogBuffer(4 * fl.BLOCK_SIZE)
    log.record(20000, 1564321, -9807, 1, -2, 3, 3, 2, 5, 1, -150, 65535)
    rec = struct.unpack_from(fl.REC_FMT, log.buf, log.cur * fl.BLOCK_SIZE + fl.BLK_HDR)
    assert rec == (20000, 1564321, -9807, 1, -2, 3, 3, 2, 5, 1, -150, 65535)


@pytest.mark.parametrize("value, beeps", [
    (1203, [1, 2, "0", 3]),
    (480, [4, 8, "0"]),
    (0, ["0"]),
])
def test_altitude_digits_pattern(value, beeps):
    steps = digits_pattern(value)
    on = steps[0::2]
    gaps = steps[1::2]
    # split into digits at the long gaps
    digits, count = [], 0
    for d_on, gap in zip(on, gaps, strict=True):
        if d_on == 500:
            digits.append("0")
        else:
            count += 1
        if gap >= 1000:
            if count:
                digits.append(count)
            count = 0
    assert digits == beeps
    assert gaps[-1] == 3000


def test_decode_uses_the_final_flight_computer(tmp_path):
    """Blocks logged under an earlier pad flight computer are not rows; filter columns are blank
    for the rows logged while the final one was still the shadow."""
    path = tmp_path / "f.log"
    config = load_config({})
    with open(path, "wb") as f:
        f.write(fl.file_header(json.dumps({"format": 1, "config": config.values})))
        log = fl.LogBuffer(16 * fl.BLOCK_SIZE)
        fcs = [FlightComputer(config), None]
        starts = [0, 0]
        for i in range(6 * fl.BLOCK_RECORDS):
            if i == 2 * fl.BLOCK_RECORDS:
                fcs[1] = FlightComputer(config)
                starts[1] = i
            if i == 4 * fl.BLOCK_RECORDS:  # handover
                fcs = [fcs[1], None]
                starts = [starts[1], 0]
                log.fc_start = starts[0]
            q4 = _pressure_q4(300000 + (i % 7))
            for fc in fcs:
                if fc is not None:
                    fc.step(20000, pressure_to_alt_mm(q4), 9807, 3)
            kf = fcs[0].kf
            log.record(20000, q4, 9807, kf.alt_q4, kf.vel_q4, kf.acc_q4, 3, fcs[0].state, fcs[0].events,
                       0, 0, 0)
        log.write_all(f)
    decoded = read_log(path)
    assert decoded.fc_start == 2 * fl.BLOCK_RECORDS
    csv, cfg = write_csv(decoded, tmp_path / "f.csv")
    from desktop.io.flightcsv import read_flight_csv

    rows = read_flight_csv(csv)
    assert len(rows) == 4 * fl.BLOCK_RECORDS
    blank = np.isnan(rows.extra["board_alt_q4"])
    assert blank[:2 * fl.BLOCK_RECORDS].all() and not blank[2 * fl.BLOCK_RECORDS:].any()
    assert not check_replay(csv, cfg)[1]
