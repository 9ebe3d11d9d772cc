"""``python -m desktop``: every bad input is one line ``error: ...`` on stderr and exit status 2;
``--version``; a ``--help`` that imports no scipy, matplotlib or RocketPy; a quiet broken pipe."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from desktop import __version__
from desktop.cli import COMMANDS, EXIT_BROKEN_PIPE, EXIT_USER_ERROR, main

ROOT = Path(__file__).parents[2]
FLIGHT = ROOT / "tests" / "data" / "flights" / "altos" / "2012-09-29-serial-341-flight-005.csv"
HEAVY_MODULES = ("scipy", "matplotlib", "rocketpy")


def one_error_line(argv, capsys):
    """Run the CLI in-process; assert status 2 and a single ``error:`` line; return that line."""
    status = main(argv)
    err = capsys.readouterr().err
    assert status == EXIT_USER_ERROR, err
    assert err.startswith("error: ") and err.count("\n") == 1 and err.endswith("\n"), err
    return err.strip()


@pytest.fixture
def a_file(tmp_path):
    """A regular file, to stand where a folder is expected."""
    path = tmp_path / "a_file.txt"
    path.write_text("not a folder\n")
    return path


# --------------------------------------------------------------------------------------------------
# replay


def test_replay_config_missing(tmp_path, capsys):
    line = one_error_line(["replay", str(FLIGHT), "--config", str(tmp_path / "none.json")], capsys)
    assert line == "error: %s: configuration file not found" % (tmp_path / "none.json")


def test_replay_config_is_a_directory(tmp_path, capsys):
    line = one_error_line(["replay", str(FLIGHT), "--config", str(tmp_path)], capsys)
    assert line == "error: %s: is a directory, not a configuration file" % tmp_path


def test_replay_config_not_utf8(tmp_path, capsys):
    cfg = tmp_path / "latin1.json"
    cfg.write_bytes('{"main_deploy_m": 300}\n{"note": "300 m \u00b0"}\n'.encode("latin-1"))
    line = one_error_line(["replay", str(FLIGHT), "--config", str(cfg)], capsys)
    assert line.startswith("error: %s:2: not UTF-8 text (byte 0xb0" % cfg)


@pytest.mark.parametrize("text, expected", [
    ("[1, 2]", "expected a JSON object of settings, got list"),
    ("{main_deploy_m: 300}", "is not valid JSON"),
])
def test_replay_config_not_a_json_object(tmp_path, capsys, text, expected):
    cfg = tmp_path / "c.json"
    cfg.write_text(text)
    assert expected in one_error_line(["replay", str(FLIGHT), "--config", str(cfg)], capsys)


@pytest.mark.parametrize("value, kind", [
    ("[400]", "list"), ("400", "int"), ('"x"', "str"), ("null", "NoneType")])
def test_replay_board_config_metadata_not_an_object(tmp_path, capsys, value, kind):
    log = tmp_path / "decoded.csv"
    log.write_text("# board_config: %s\n" % value + FLIGHT.read_text())
    line = one_error_line(["replay", str(log)], capsys)
    assert line == "error: %s: metadata board_config is not a JSON object of settings (got %s)" % (log, kind)


def test_replay_plot_into_a_missing_folder(tmp_path, capsys):
    out = tmp_path / "no_such_folder" / "replay.png"
    line = one_error_line(["replay", str(FLIGHT), "--plot", str(out)], capsys)
    assert line == "error: %s: cannot write the plot: folder %s does not exist" % (out, out.parent)
    assert not out.parent.exists()


def test_replay_plot_onto_a_directory(tmp_path, capsys):
    line = one_error_line(["replay", str(FLIGHT), "--plot", str(tmp_path)], capsys)
    assert line == "error: %s: is a directory, not a plot" % tmp_path


# --------------------------------------------------------------------------------------------------
# montecarlo (checked before any flight is simulated)


@pytest.mark.parametrize("flights", ["0", "-3"])
def test_montecarlo_flights_must_be_positive(capsys, flights):
    line = one_error_line(["montecarlo", "--flights", flights], capsys)
    assert line == "error: --flights %s must be >= 1" % flights


@pytest.mark.parametrize("pad", ["-1", "601", "nan"])
@pytest.mark.parametrize("extra", [[], ["--params", "paper"], ["--rocket", "examples/rockets/c6_model.toml"]])
def test_montecarlo_pad_out_of_range(capsys, pad, extra):
    line = one_error_line(["montecarlo", "--flights", "2", "--pad-s", pad, *extra], capsys)
    assert line == "error: --pad-s %s is out of range (allowed 0 to 600 s)" % pad


def test_montecarlo_negative_flight_index(capsys, tmp_path):
    line = one_error_line(["montecarlo", "--export-csv", str(tmp_path / "f.csv"), "--flight", "-1"], capsys)
    assert line == "error: --flight -1 must be >= 0"


def test_montecarlo_export_csv_into_a_missing_folder(tmp_path, capsys):
    out = tmp_path / "missing" / "f.csv"
    line = one_error_line(["montecarlo", "--export-csv", str(out)], capsys)
    assert line == "error: %s: cannot write the flight CSV: folder %s does not exist" % (out, out.parent)


def test_montecarlo_export_csv_under_a_file(a_file, capsys):
    out = a_file / "f.csv"
    line = one_error_line(["montecarlo", "--export-csv", str(out)], capsys)
    assert line == "error: %s: cannot write the flight CSV: folder %s is not a folder" % (out, a_file)


def test_montecarlo_plots_onto_a_file(a_file, capsys):
    line = one_error_line(["montecarlo", "--flights", "2", "--plots", str(a_file)], capsys)
    assert line == "error: %s: cannot create the plots folder: it is a file, not a folder" % a_file


def test_montecarlo_plots_under_a_file(a_file, capsys):
    out = a_file / "plots"
    line = one_error_line(["montecarlo", "--flights", "2", "--plots", str(out)], capsys)
    assert line == "error: %s: cannot create the plots folder: Not a directory" % out


def _read_only_folder(tmp_path):
    folder = tmp_path / "read_only"
    folder.mkdir()
    folder.chmod(0o500)
    if os.access(folder, os.W_OK):
        folder.chmod(0o700)
        pytest.skip("running with privileges that ignore folder permissions")
    return folder


def test_montecarlo_unwritable_outputs(tmp_path, capsys):
    folder = _read_only_folder(tmp_path)
    try:
        line = one_error_line(["montecarlo", "--export-csv", str(folder / "f.csv")], capsys)
        assert line.endswith("cannot write the flight CSV: permission denied")
        line = one_error_line(["montecarlo", "--flights", "2", "--plots", str(folder / "plots")], capsys)
        assert line.endswith("cannot create the plots folder: Permission denied")
    finally:
        folder.chmod(0o700)


# --------------------------------------------------------------------------------------------------
# logdecode and simulate outputs


def test_logdecode_out_into_a_missing_folder(tmp_path, capsys):
    out = tmp_path / "missing" / "flight.csv"
    line = one_error_line(["logdecode", str(tmp_path / "flight.log"), "--out", str(out)], capsys)
    assert line == "error: %s: cannot write the flight CSV: folder %s does not exist" % (out, out.parent)


def test_logdecode_missing_log(tmp_path, capsys):
    argv = ["logdecode", str(tmp_path / "flight.log"), "--out", str(tmp_path / "f.csv")]
    line = one_error_line(argv, capsys)
    assert line == "error: %s: flight log not found" % (tmp_path / "flight.log")


def test_simulate_out_into_a_missing_folder(tmp_path, capsys):
    out = tmp_path / "missing" / "flight.csv"
    line = one_error_line(["simulate", "examples/rockets/c6_model.toml", "--out", str(out)], capsys)
    assert line == "error: %s: cannot write the flight CSV: folder %s does not exist" % (out, out.parent)


# --------------------------------------------------------------------------------------------------
# the process: --version, --help, broken pipe, console script


def test_version_prints_the_package_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out == "apogee-fc %s\n" % __version__


_IMPORTS_AFTER_HELP = """
import runpy, sys
for argv in %r:
    sys.argv = ["desktop", *argv, "--help"]
    try:
        runpy.run_module("desktop", run_name="__main__", alter_sys=True)
    except SystemExit:
        pass
heavy = sorted(m for m in sys.modules if m.split(".")[0] in %r)
sys.stderr.write("HEAVY MODULES: %%s\\n" %% " ".join(heavy))
""" % ([[]] + [[name] for name, _module in COMMANDS], HEAVY_MODULES)


@pytest.mark.slow
def test_help_imports_no_scipy_matplotlib_or_rocketpy():
    # every command's --help in one process: none of them imports a heavy module
    proc = subprocess.run([sys.executable, "-c", _IMPORTS_AFTER_HELP], capture_output=True, text=True,
                          cwd=ROOT)
    assert proc.stdout.count("usage:") == 1 + len(COMMANDS), proc.stderr
    assert proc.stderr.splitlines()[-1] == "HEAVY MODULES: ", proc.stderr


@pytest.fixture
def tiny_flight(tmp_path):
    """A short flight CSV (a second on the pad): replays in a moment."""
    path = tmp_path / "tiny.csv"
    path.write_text("time_s,altitude_m\n" + "".join("%.2f,0\n" % (i / 100) for i in range(100)))
    return path


@pytest.mark.slow
def test_broken_pipe_exits_quietly(tiny_flight):
    # the reader goes away before the command writes (as `| head` does once it has its lines)
    proc = subprocess.Popen([sys.executable, "-m", "desktop", "replay", str(tiny_flight)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()
    err = proc.stderr.read()
    proc.stderr.close()
    assert proc.wait(timeout=120) == EXIT_BROKEN_PIPE
    assert err == b""


@pytest.mark.slow
def test_piped_into_head_keeps_the_first_lines(tiny_flight):
    proc = subprocess.run("%s -m desktop replay %s | head -n 1" % (sys.executable, tiny_flight),
                          shell=True, executable="/bin/bash", capture_output=True, text=True, cwd=ROOT)
    assert proc.stdout.startswith(str(tiny_flight)) and proc.stdout.count("\n") == 1
    assert "Traceback" not in proc.stderr and proc.stderr == ""
