"""Does the desktop reproduce the board's own decisions? ``python -m desktop replay --check LOG``.

A board log (``flight.log``, decoded by ``desktop/io/logdecode.py``) holds, for every sample, what
``FlightComputer.step()`` was given and what it decided on the board: state, events, pyro output
levels (``flags``) and the filter state. The check feeds the same integer inputs through
``shared/`` on the desktop, with the configuration the board logged (or ``--config``), and
compares every sample in order (``desktop.io.logdecode.differences``): the first sample that
differs is the answer (exit status 1), a log whose every sample matches exits 0, a log or
configuration that cannot be read exits 2. A damaged log (a block lost: samples missing) is
compared up to its first gap: past it the replay lacks the board's inputs, and a difference there
says nothing about the replay (exit status 0, the gap named).
"""

import numpy as np

from desktop.io.logdecode import board_config, log_differences, read_log


def run_check(log_path, config_path=None):
    """The ``replay --check`` command; returns the exit status."""
    log = read_log(log_path)  # errors reach the CLI: one line, exit status 2
    t_us, found = log_differences(log, board_config(log, config_path))
    samples = log.sample[log.sample >= log.fc_start]
    gaps = np.flatnonzero(np.diff(samples) > 1) + 1  # the first row after each gap
    for row, what in found:
        if len(gaps) and row >= gaps[0]:
            first, last = samples[gaps[0] - 1] + 1, samples[gaps[0]] - 1
            print(f"{log_path}: the replay reproduces the board on all {gaps[0]} samples before the "
                  f"log's first gap (samples {first}..{last} missing: a block lost); past it the "
                  "replay lacks the board's inputs and is not compared")
            return 0
        print(f"{log_path}: sample {row} (t = {t_us[row] / 1e6:.6f} s) differs: {what}")
        return 1
    print(f"{log_path}: the replay reproduces the board on all {len(t_us)} samples "
          "(state, events, pyro outputs, filter state)")
    return 0
