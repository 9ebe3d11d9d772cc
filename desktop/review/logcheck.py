"""Does the desktop replay reproduce the board's own decisions? ``python -m desktop replay --check LOG``.

A board log (``flight.log``, decoded by ``desktop/io/logdecode.py``) holds, for every sample, what
``FlightComputer.step()`` was given and what it decided on the board: state, events, pyro output
levels (``flags``) and the filter state. The check feeds the same integer readings through
``shared/`` on the desktop and compares every sample, in order; the first sample that differs
is the answer (exit status 1), a log whose every sample matches exits 0, a log that cannot be read
exits 2.
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

from shared.flight import EVENT_NAMES, STATE_NAMES, FlightComputer
from shared.logformat import FLAG_PYRO_DROGUE, FLAG_PYRO_MAIN


def _names(events):
    return "+".join(name for bit, name in enumerate(EVENT_NAMES) if events & (1 << bit)) or "none"


def differences(log, config):
    """Yield ``(row, description)`` for every row of a decoded board log (a FlightLog with the
    ``board_*`` columns) whose replay through ``config`` differs from the board: state, events,
    pyro outputs, and the filter state where the board logged it."""
    from desktop.review.replay import ground_alt_mm, readings

    dt_us, alt_mm, accel, have = readings(log)
    fc = FlightComputer(config, ground_alt_mm=ground_alt_mm(log))
    state_b = log.extra["board_state"].astype(np.int64)
    events_b = log.extra["board_events"].astype(np.int64)
    flags_b = log.extra["board_flags"].astype(np.int64)
    filt_b = [log.extra[name] for name in ("board_alt_q4", "board_vel_q4", "board_acc_q4")]
    kf = fc.kf
    for i in range(len(log)):
        fc.step(int(dt_us[i]), int(alt_mm[i]), int(accel[i]), int(have[i]))
        found = []
        if fc.state != state_b[i]:
            found.append(f"state: replay {STATE_NAMES[fc.state]}, board {STATE_NAMES[int(state_b[i])]}")
        if fc.events != events_b[i]:
            found.append(f"events: replay {_names(fc.events)}, board {_names(int(events_b[i]))}")
        pyro_b = (bool(flags_b[i] & FLAG_PYRO_DROGUE), bool(flags_b[i] & FLAG_PYRO_MAIN))
        if (bool(fc.pyro_drogue), bool(fc.pyro_main)) != pyro_b:
            found.append(f"pyro (drogue, main): replay {(int(fc.pyro_drogue), int(fc.pyro_main))}, "
                         f"board {(int(pyro_b[0]), int(pyro_b[1]))}")
        if not np.isnan(filt_b[0][i]):
            board = tuple(int(col[i]) for col in filt_b)
            if (kf.alt_q4, kf.vel_q4, kf.acc_q4) != board:
                found.append(f"filter state: replay {(kf.alt_q4, kf.vel_q4, kf.acc_q4)}, board {board}")
        if found:
            yield i, "; ".join(found)


def load_decoded(log_path, config_path, workdir):
    """Decode ``log_path`` into ``workdir``; returns (FlightLog, FlightConfig)."""
    from desktop.io.flightcsv import read_flight_csv
    from desktop.io.logdecode import read_log, write_csv
    from desktop.review.replay import config_for

    csv_path, cfg_path = write_csv(read_log(log_path), Path(workdir) / "flight.csv")
    log = read_flight_csv(csv_path)
    return log, config_for(log, config_path or cfg_path)


def run_check(log_path, config_path=None):
    """The ``replay --check`` command: exit status 0 (every sample matches), 1 (the first sample that
    differs is printed) or 2 (the log or configuration cannot be read)."""
    from desktop.io.flightcsv import FlightCSVError
    from desktop.io.logdecode import LogDecodeError
    from shared.config import ConfigError

    with tempfile.TemporaryDirectory() as tmp:
        try:
            log, config = load_decoded(log_path, config_path, tmp)
        except (LogDecodeError, FlightCSVError, ConfigError, OSError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        for row, what in differences(log, config):
            print(f"{log_path}: sample {row} (t = {log.time_s[row]:.6f} s) differs: {what}")
            return 1
    print(f"{log_path}: the replay reproduces the board on all {len(log)} samples "
          "(state, events, pyro outputs, filter state)")
    return 0
