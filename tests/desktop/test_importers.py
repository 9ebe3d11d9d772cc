"""Importers (desktop/io/importers.py, desktop/io/altos_csv.py): AltosUI CSV exports of every
Altus Metrum board family, written from the documented layouts (tests/support/altos_export.py)
and filled with a real TeleMetrum flight, import to the samples of the same flight converted by
hand (tests/data/flights/altos/), and replay to the same events."""

from dataclasses import dataclass

import numpy as np
import pytest

from desktop.cli import main
from desktop.io.flightcsv import FlightCSVError, read_flight_csv
from desktop.io.importers import detect_format, read_flight
from desktop.review.replay import config_for, replay
from tests.support import altos_export

FLIGHT = "tests/data/flights/altos/2012-04-07-serial-882-flight-001.csv"
LAYOUTS = ["v5"] + ["v6-" + f for f in altos_export.FAMILIES]
HEAD_ROWS = 120  # 0.3 s of pad and 0.9 s of boost


@pytest.fixture(scope="module")
def source():
    return read_flight_csv(FLIGHT)


@dataclass
class Head:
    """The first rows of a flight (what altos_export needs): the pad and the start of the boost."""

    time_s: np.ndarray
    pressure_pa: np.ndarray
    accel_mps2: np.ndarray
    extra: dict

    def __len__(self):
        return len(self.time_s)


@pytest.fixture(scope="module")
def head(source):
    n = HEAD_ROWS
    return Head(source.time_s[:n], source.pressure_pa[:n], source.accel_mps2[:n],
                {"altos_state": source.extra["altos_state"][:n]})


def _export(tmp_path, source, layout):
    path = tmp_path / f"{layout}.csv"
    if layout == "v5":
        altos_export.write_v5(path, source)
    else:
        altos_export.write_v6(path, source, layout[3:])
    return path


@pytest.mark.parametrize("layout", LAYOUTS)
def test_altos_export_imports_to_the_flight_samples(tmp_path, source, layout):
    path = _export(tmp_path, source, layout)
    assert detect_format(path) == "altos"
    log = read_flight(path)
    # one row per sensor sample: the repeated and the temperature/voltage rows are dropped
    assert np.array_equal(log.time_us, source.time_us)
    assert np.array_equal(log.pressure_pa, source.pressure_pa)
    assert list(log.extra["altos_state"]) == list(source.extra["altos_state"])
    if layout in ("v6-EasyMini", "v6-TeleMini"):
        assert log.accel_mps2 is None  # these boards have no accelerometer
    else:
        assert np.allclose(log.accel_mps2, source.accel_mps2, atol=1e-3)


@pytest.mark.parametrize("layout, board", [("v5", "TeleMetrum-v1.2"), ("v6-TeleMetrum", "TeleMetrum"),
                                           ("v6-TeleMega", "TeleMega"), ("v6-TeleMega-telemetry", "TeleMega"),
                                           ("v6-EasyMega", "EasyMega"),
                                           ("v6-EasyMini", "EasyMini or TeleMini (no accelerometer)")])
def test_board_family_and_configuration(tmp_path, head, layout, board):
    log = read_flight(_export(tmp_path, head, layout))
    assert log.metadata["board"] == board
    if layout == "v5":  # the version-5 comment block carries the board's configuration
        assert log.metadata_float("main_deploy_m") == 250
        assert log.metadata["firmware"] == "1.0.3"


@pytest.mark.slow
@pytest.mark.parametrize("layout", ["v5", "v6-TeleMega"])
def test_imported_flight_replays_like_the_converted_one(tmp_path, source, layout):
    log = read_flight(_export(tmp_path, source, layout))
    ours = replay(log, config_for(log))
    ref = replay(source, config_for(source))
    assert [(e.event, e.index) for e in ours.events] == [(e.event, e.index) for e in ref.events]
    assert ours.first("drogue") is not None and ours.first("main") is not None


@pytest.mark.slow
def test_replay_command_reads_an_altos_export(tmp_path, source, capsys):
    path = _export(tmp_path, source, "v6-TeleMetrum")
    assert main(["replay", str(path)]) == 0
    out = capsys.readouterr().out
    assert "drogue" in out and "main" in out


def test_import_command_writes_a_flight_csv(tmp_path, source, capsys):
    path = _export(tmp_path, source, "v6-EasyMega")
    out = tmp_path / "flight.csv"
    assert main(["import", str(path), "-o", str(out)]) == 0
    assert "pad -> boost -> coast -> drogue -> main" in capsys.readouterr().out
    log = read_flight_csv(out)
    assert len(log) == len(source) and log.metadata["board"] == "EasyMega"
    assert "drogue_sense_v" in log.extra and "igniter_a_sense_v" in log.extra


def _lines(path):
    return path.read_text().splitlines()


@pytest.mark.parametrize("edit, message", [
    (lambda ls: ls[:2] + [ls[3], ls[2]] + ls[4:], "time goes back"),
    (lambda ls: ls[:3] + [ls[3] + ",1"] + ls[4:], "row has"),
    (lambda ls: ls[:3] + [ls[3].replace(".", ",", 1)] + ls[4:], "decimal comma"),
    (lambda ls: [ls[0].replace("pressure", "press")] + ls[1:], "no 'pressure' column"),
])
def test_bad_altos_exports_are_one_line_errors(tmp_path, head, edit, message):
    path = _export(tmp_path, head, "v6-EasyMega")
    path.write_text("\n".join(edit(_lines(path))) + "\n")
    with pytest.raises(FlightCSVError, match=message) as err:
        read_flight(path)
    assert "\n" not in str(err.value)


def test_pressure_not_in_pa_is_refused(tmp_path, head):
    path = _export(tmp_path, head, "v6-EasyMega")
    lines = _lines(path)
    cells = lines[3].split(",")
    cells[7] = " 844.71"  # hPa
    lines[3] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(FlightCSVError, match="not a pressure in Pa"):
        read_flight(path)


def test_an_implausible_acceleration_is_refused(tmp_path, head):
    path = _export(tmp_path, head, "v6-EasyMega")
    lines = _lines(path)
    cells = lines[3].split(",")
    cells[6] = " 1e30"  # acceleration, m/s^2
    lines[3] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(FlightCSVError, match="'acceleration': 1e30 m/s\\^2 is implausible"):
        read_flight(path)


def test_altos_missing_value_is_an_empty_cell(tmp_path, head):
    path = _export(tmp_path, head, "v6-EasyMega")
    lines = _lines(path)
    cells = lines[5].split(",")
    cells[6] = altos_export.MISSING  # acceleration
    lines[5] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    log = read_flight(path)
    assert np.isnan(log.accel_mps2).sum() == 1


def test_unknown_format_and_cli_errors(tmp_path, capsys):
    other = tmp_path / "other.csv"
    other.write_text("Time,Alt,Velocity\n0,0,0\n")
    assert detect_format(other) == "flight-csv"  # the flight-CSV reader names the problem
    with pytest.raises(FlightCSVError, match="no 'time_s' column"):
        read_flight(other)
    assert main(["import", str(other), "-o", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1
    assert "unknown format" in err and "no 'time_s' column" in err
    assert main(["import", FLIGHT, "-o", str(tmp_path / "x.csv")]) == 2
    assert "already a flight CSV" in capsys.readouterr().err
    assert main(["replay", str(other)]) == 2
