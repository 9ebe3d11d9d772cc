"""The decoded board log's flight CSV through the desktop replay: the CSV holds everything the
board's step was given, so replaying it reproduces the board's decisions sample for sample."""

from desktop.io.flightcsv import read_flight_csv
from desktop.io.logdecode import differences, first_problems
from desktop.review.replay import config_for, ground_alt_mm, readings


def check_replay(csv_path, config_path):
    """(rows compared, at most 10 descriptions of rows whose replay differs from the board's
    ``board_*`` columns) of a CSV written by ``logdecode``."""
    log = read_flight_csv(csv_path)
    board = {name: log.extra["board_" + name] for name in ("state", "events", "flags", "alt_q4", "vel_q4",
                                                           "acc_q4")}
    found = differences(readings(log), board, config_for(log, config_path), ground_alt_mm(log))
    return len(log), first_problems(found)
