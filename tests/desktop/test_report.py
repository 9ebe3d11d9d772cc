"""The flight review (desktop/review/report.py, ``replay --report``): no overlapping text in the
figure (matplotlib's text extents), the summary's figures against independent expectations, in
metres and in feet, and the board's own decisions beside ours."""

import itertools
import math

import matplotlib.pyplot as plt
import pytest
from matplotlib.text import Text

from desktop.cli import main
from desktop.io.flightcsv import read_flight_csv, write_flight_csv
from desktop.io.importers import read_flight
from desktop.io.logdecode import read_log, write_csv
from desktop.review.replay import config_for, replay
from desktop.review.report import UNITS, figure, summary
from shared.physics import G0_MPS2
from tests.support import altos_export
from tests.support.fault_flight import AIR_START_ROCKET, flight_csv_columns, fly

EXAMPLE_LOG = "examples/logs/sil_flight.log"
ALTOS = "tests/data/flights/altos/2012-09-29-serial-341-flight-005.csv"
FT = 0.3048
# examples/logs/sil_flight.log was flown with flightgen's Scenario(seed=1) defaults: 60 m/s^2 for
# 1.5 s from 30 s, drag-free coast, 20 m/s descent, a pad 300 m above sea level
BURNOUT_SPEED_MPS = 90.0
APOGEE_M = 0.5 * 60 * 1.5**2 + 90.0**2 / (2 * G0_MPS2)
DESCENT_MPS = 20.0
SITE_M = 300.0


@pytest.fixture(scope="module")
def sil(tmp_path_factory):
    csv, cfg = write_csv(read_log(EXAMPLE_LOG), tmp_path_factory.mktemp("sil") / "flight.csv")
    log = read_flight_csv(csv)
    config = config_for(log, cfg)
    return log, config, replay(log, config)


def _value(summ, label):
    return dict(summ.rows)[label]


def _number(text):
    return float(text.split()[0])


def _flights(tmp_path, sil):
    """(name, log, config, result): a decoded board log, an AltosUI export, and a flight CSV with
    no board decisions."""
    out = [("board log",) + sil]
    src = read_flight_csv(ALTOS)
    path = tmp_path / "altos.csv"
    altos_export.write_v6(path, src, "TeleMega")
    log = read_flight(path)
    out.append(("AltosUI export", log, config_for(log), replay(log, config_for(log))))
    plain = tmp_path / "plain.csv"
    write_flight_csv(plain, {"time_s": src.time_s, "pressure_pa": src.pressure_pa,
                             "accel_mps2": src.accel_mps2})
    log = read_flight_csv(plain)
    out.append(("no board", log, config_for(log), replay(log, config_for(log))))
    return out


def drawn_texts(fig):
    """Every non-empty visible Text of the figure, less the tick labels of ticks outside the view
    (matplotlib keeps them but does not draw them)."""
    ticks, in_view = set(), set()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                for label in (tick.label1, tick.label2):
                    ticks.add(id(label))
                    if lo - 1e-9 <= tick.get_loc() <= hi + 1e-9:
                        in_view.add(id(label))
    return [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()
            and (id(t) not in ticks or id(t) in in_view)]


@pytest.mark.slow
@pytest.mark.parametrize("units", ["m", "ft"])
def test_no_overlapping_text_in_the_figure(tmp_path, sil, units):
    for name, log, config, result in _flights(tmp_path, sil):
        u = UNITS[units]
        fig = figure(result, log, config, u, summary(result, log, u), f"Flight review: {name}")
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        texts = drawn_texts(fig)
        boxes = [(t.get_text(), t.get_window_extent(renderer).shrunk(0.98, 0.9)) for t in texts]
        assert len(boxes) > 40, name  # tick labels, legends, summary lines
        page = fig.bbox
        for text, box in boxes:  # everything on the page
            assert page.x0 <= box.x0 and box.x1 <= page.x1 + 1, (name, text)
        clashes = [(a, b) for (a, ba), (b, bb) in itertools.combinations(boxes, 2) if ba.overlaps(bb)]
        plt.close(fig)
        assert not clashes, (name, clashes[:5])


def test_summary_of_a_known_flight_in_metres(sil):
    log, _config, result = sil
    summ = summary(result, log, UNITS["m"])
    assert _number(_value(summ, "apogee")) == pytest.approx(APOGEE_M, abs=3)
    speed = _number(_value(summ, "max speed"))
    assert speed == pytest.approx(BURNOUT_SPEED_MPS, abs=3)
    # Mach against the ISA speed of sound at the pad plus the altitude at burnout
    t_k = 288.15 - 0.0065 * (SITE_M + 0.5 * 60 * 1.5**2)
    mach = float(_value(summ, "max speed").split("Mach ")[1].split(")")[0])
    assert mach == pytest.approx(speed / math.sqrt(1.4 * 287.053 * t_k), abs=0.01)
    assert _number(_value(summ, "max acceleration")) == pytest.approx(60, abs=6)
    assert _number(_value(summ, "burnout")) == pytest.approx(1.5, abs=0.3)
    assert _number(_value(summ, "descent under drogue")) == pytest.approx(DESCENT_MPS, abs=1)
    # launch at 0 s; landed declared some seconds after touchdown (APOGEE time + fall)
    touchdown_s = 1.5 + BURNOUT_SPEED_MPS / G0_MPS2 + APOGEE_M / DESCENT_MPS
    assert touchdown_s < _number(_value(summ, "flight time")) < touchdown_s + 20
    assert _value(summ, "flight time").endswith("to landing")


def test_summary_in_feet_is_the_same_flight(sil):
    log, _config, result = sil
    metres, feet = summary(result, log, UNITS["m"]), summary(result, log, UNITS["ft"])
    for label in ("apogee", "max speed", "max acceleration", "descent under drogue"):
        assert _number(_value(feet, label)) * FT == pytest.approx(_number(_value(metres, label)), abs=0.06)
        assert " ft" in _value(feet, label)
    assert "Mach" in _value(feet, "max speed")


def test_board_decisions_beside_ours(tmp_path, sil):
    log, _config, result = sil
    summ = summary(result, log, UNITS["m"])
    assert "board_events" in summ.board_source
    rows = {d[0]: d for d in summ.decisions}
    assert rows["drogue"][1] == rows["drogue"][2] and rows["drogue"][3] == "+0.00 s"
    name, log, _config, result = _flights(tmp_path, sil)[1]
    summ = summary(result, log, UNITS["m"])
    rows = {d[0]: d for d in summ.decisions}
    # the AltOS board (the 341 flight) entered drogue at 16.48 s (tests/data README: first row
    # after coast 16.59 s in the converted file's 10 Hz rows)
    assert rows["drogue"][2] == "16.59 s"
    assert abs(float(rows["drogue"][3].split()[0])) < 0.5


def test_board_igniter_firing_from_the_continuity_voltage(tmp_path):
    src = read_flight_csv(ALTOS)
    path = tmp_path / "easymega.csv"
    names = altos_export.write_v6(path, src, "EasyMega")
    j_time, j_drogue = names.index("time"), names.index("drogue_voltage")
    lines = path.read_text().splitlines()
    for k in range(1, len(lines)):
        cells = lines[k].split(",")
        if float(cells[j_time]) >= 16.69:  # the charge burns the igniter open (a 10 Hz row)
            cells[j_drogue] = " 0.05"
        lines[k] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    log = read_flight(path)
    summ = summary(replay(log, config_for(log)), log, UNITS["m"])
    assert _value(summ, "board's igniters open") == "drogue 16.69 s"  # main never fired: not listed


@pytest.mark.slow
def test_replay_report_command_writes_png_and_markdown(tmp_path, capsys):
    out = tmp_path / "review"
    assert main(["replay", ALTOS, "--report", str(out), "--units", "ft"]) == 0
    md = (out / "report.md").read_text()
    assert "![flight review](report.png)" in md and "| apogee |" in md and " ft at " in md
    assert "| drogue |" in md  # the board's decisions table
    assert (out / "report.png").stat().st_size > 20000
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["replay", ALTOS, "--report", str(blocker / "sub")]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_backup_charges_in_the_summary_and_the_figure(sil):
    # the backup channels (docs/CONFIG.md, "Backup charges"): their firings in the summary, their
    # lines in the figure; the board log's flight (sil) replayed with them on
    from shared.config import load_config

    log, config, _result = sil
    config = load_config(dict(config.values, backup_drogue_delay_s=2, backup_main_m=100))
    result = replay(log, config)
    summ = summary(result, log, UNITS["m"])
    drogue = _number(_value(summ, "drogue fired"))
    assert _number(_value(summ, "backup drogue fired")) - drogue == pytest.approx(2, abs=0.021)  # 50 Hz
    backup_main = _value(summ, "backup main fired")
    assert 95 <= float(backup_main.split(" at ")[1].split()[0]) <= 100
    fig = figure(result, log, config, UNITS["m"], summ, "backups")
    labels = {t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()}
    plt.close(fig)
    assert {"backup drogue fired (ours)", "backup main fired (ours)"} <= labels


def test_a_motor_lit_in_coast_is_in_the_summary(tmp_path):
    # a staged flight (docs/DESIGN.md D19) written as a flight CSV: the summary names the ignition
    path = tmp_path / "staged.csv"
    write_flight_csv(path, flight_csv_columns(fly(AIR_START_ROCKET, after_apogee_s=5.0)))
    log = read_flight_csv(path)
    result = replay(log, config_for(log))
    lit = _value(summary(result, log, UNITS["m"]), "ignition in coast")
    # (in the file's time, from the first motor lighting: the launch's 0.1 s of boost after it)
    assert AIR_START_ROCKET.motor2_at_s + 0.08 <= _number(lit) <= AIR_START_ROCKET.motor2_at_s + 0.15, lit
