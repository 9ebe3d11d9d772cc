"""Does the desktop replay reproduce the board's own decisions? ``python -m desktop replay --check LOG``.

A board log (``flight.log``, decoded by ``desktop/io/logdecode.py``) holds, for every sample, what
``FlightComputer.step()`` was given and what it decided on the board: state, events, pyro output
levels (``flags``) and the filter state. The check feeds the same integer readings through
``shared/`` on the desktop and compares every sample, in order; the first sample that differs
is the answer (exit status 1), a log whose every sample matches exits 0, a log that cannot be read
exits 2. The comparison itself is ``desktop.io.logdecode.differences``.
"""

import sys
import tempfile
from pathlib import Path


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
    from desktop.io.logdecode import LogDecodeError, differences
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
