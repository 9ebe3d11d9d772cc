"""``python -m desktop sil``: the unchanged firmware on the MicroPython unix port writes a
flight.log that ``logdecode`` decodes and ``replay --check`` matches sample for sample; and the
shipped example log (examples/logs/) checks out without any interpreter."""

import json

import pytest

from desktop.cli import main
from desktop.io.flightcsv import write_flight_csv
from desktop.io.importers import read_flight
from desktop.io.logdecode import read_log, to_columns
from desktop.review.replay import config_for, replay
from shared.flight import EV_IGNITION, EV_LAUNCH
from tests.support.fault_flight import AIR_START_ROCKET, flight_csv_columns, fly

EXAMPLE = "examples/logs/sil_flight.log"
ALTOS = "tests/data/flights/altos/2012-04-07-serial-882-flight-001.csv"
PERIOD_S = 0.02  # pico.json: 50 Hz
DESCENT_PERIOD_S = 0.1  # AltOS logs after apogee


def test_example_log_decodes_and_checks(tmp_path, capsys):
    log = read_log(EXAMPLE)
    assert log.summary["reason"] == "landed" and not log.problems
    assert main(["replay", "--check", EXAMPLE]) == 0
    assert "reproduces the board on all" in capsys.readouterr().out
    assert main(["logdecode", EXAMPLE, "--out", str(tmp_path / "f.csv"), "--check"]) == 0


def test_check_exits_1_at_the_first_differing_sample(tmp_path, capsys):
    cfg = tmp_path / "cfg.json"
    cfg.write_text(json.dumps({"main_deploy_m": 350}))  # the board flew with 250
    assert main(["replay", "--check", EXAMPLE, "--config", str(cfg)]) == 1
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and "differs: state: replay main, board drogue" in out[0]
    assert ("pyro (drogue, main, backup drogue, backup main): replay (0, 1, 0, 0), board (0, 0, 0, 0)"
            in out[0])


@pytest.mark.parametrize("bad", ["README.md", "missing.log"])
def test_check_exits_2_on_bad_input(bad, capsys):
    path = "examples/logs/" + bad
    assert main(["replay", "--check", path]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1


@pytest.mark.micropython
@pytest.mark.slow
def test_simulated_flight_log_matches_sample_for_sample(tmp_path, capsys):
    out = tmp_path / "board"
    assert main(["sil", "--out", str(out), "--seed", "2", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["reason"] == "landed" and len(report["drogue_pulses_s"]) == 1
    assert main(["replay", "--check", str(out / "flight.log")]) == 0
    assert main(["logdecode", str(out / "flight.log"), "--out", str(tmp_path / "f.csv")]) == 0


@pytest.mark.micropython
@pytest.mark.slow
def test_recorded_altos_flight_through_the_firmware(tmp_path, capsys):
    out = tmp_path / "board"
    assert main(["sil", "--out", str(out), "--flight", ALTOS, "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert main(["replay", "--check", str(out / "flight.log")]) == 0
    # the firmware fires where the desktop replay of the same recording does: the drogue within
    # three periods of the 50 Hz board (the ascent is recorded at 100 Hz, and the sensor
    # arbitration's windows end on the board's own samples), the main within 2.5 periods of the
    # 10 Hz descent recording (the board filters the held readings at 50 Hz)
    log = read_flight(ALTOS)
    desktop = replay(log, config_for(log))
    assert abs(report["drogue_pulses_log_s"][0] - desktop.first("drogue").time_s) <= 3 * PERIOD_S
    assert abs(report["main_pulses_log_s"][0] - desktop.first("main").time_s) <= 2.5 * DESCENT_PERIOD_S


@pytest.mark.micropython
@pytest.mark.slow
def test_staged_flight_through_the_firmware(tmp_path, capsys):
    # an air-started second motor (docs/DESIGN.md D19): the firmware goes back to boost when it
    # lights, fires the drogue at apogee, and its log restores the ignition that the record's
    # event byte has no room for
    fl = fly(AIR_START_ROCKET, after_apogee_s=5.0)
    flight = tmp_path / "staged.csv"
    write_flight_csv(flight, flight_csv_columns(fl))
    out = tmp_path / "board"
    assert main(["sil", "--out", str(out), "--flight", str(flight), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert main(["replay", "--check", str(out / "flight.log")]) == 0
    cols, _meta = to_columns(read_log(out / "flight.log"))
    events, t = cols["board_events"], cols["time_s"]
    (lit_s,) = t[events & EV_IGNITION != 0] - t[events & EV_LAUNCH != 0][0]  # (from the launch)
    assert abs(lit_s - AIR_START_ROCKET.motor2_at_s) <= 0.15
    # the drogue where the desktop replay of the same recording fires it: within three periods of
    # the 50 Hz board (the recording is at 100 Hz)
    log = read_flight(flight)
    desktop = replay(log, config_for(log))
    assert abs(report["drogue_pulses_log_s"][0] - desktop.first("drogue").time_s) <= 3 * PERIOD_S
    assert abs(desktop.first("drogue").time_s - fl.apogee_s) <= 0.05


def test_sil_refuses_a_flight_without_accelerometer(tmp_path, capsys):
    flight = tmp_path / "baro.csv"
    flight.write_text("time_s,pressure_pa\n0,101325\n0.1,101300\n")
    assert main(["sil", "--out", str(tmp_path / "b"), "--flight", str(flight)]) == 2
    assert "no accelerometer readings" in capsys.readouterr().err
    assert main(["sil", "--out", str(tmp_path / "b"), "--flight", str(tmp_path / "none.csv")]) == 2


def test_sil_refuses_a_bad_configuration_or_output(tmp_path, capsys):
    cfg = tmp_path / "cfg.json"
    cfg.write_text(json.dumps({"main_deploy_m": -5}))
    assert main(["sil", "--out", str(tmp_path / "b"), "--config", str(cfg)]) == 2
    assert "main_deploy_m" in capsys.readouterr().err
    assert main(["sil", "--out", str(cfg)]) == 2
    assert "not a folder" in capsys.readouterr().err
