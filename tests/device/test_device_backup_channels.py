"""The backup pyro channels on the board (docs/FIRMWARE.md, docs/CONFIG.md "Backup charges"):
optional ``pyro.backup_drogue`` / ``pyro.backup_main`` in board.json, validated like the
primaries, in pyro_pins.txt, driven low first thing by boot.py, refused when the configuration
enables one the board lacks, pulsed by the flight loop with their own hardware guard, logged, and
fired by the ground test only with the channel name typed again.

pico.json plus GP18 (backup drogue) and GP19 (backup main, with an ADC continuity input on GP28)."""

import copy
import json
import shutil

import pytest

from desktop.hosts.micropython import REPO_ROOT
from device.board import BoardError, check_with_config, pyro_pins_text, validate
from shared.config import load_config
from tests.support.boot_run import boot_pin_states
from tests.support.groundtest_guest import run_groundtest

PICO = json.loads((REPO_ROOT / "device" / "boards" / "pico.json").read_text())
BACKUP_DROGUE_PIN = 18
BACKUP_MAIN_PIN = 19
BACKUP_PYRO = {"backup_drogue": {"pin": BACKUP_DROGUE_PIN},
               "backup_main": {"pin": BACKUP_MAIN_PIN, "sense": {"pin": 28, "kind": "adc"}}}
BACKUPS = {"backup_drogue_delay_s": 1, "backup_main_m": 150}


def with_backups(desc=None, **pyro):
    d = copy.deepcopy(desc or PICO)
    d["pyro"].update(copy.deepcopy(pyro or BACKUP_PYRO))
    d["timers"] = [-1] * len(d["pyro"])
    return d


def test_backup_channels_validate_and_join_pyro_pins_txt():
    b = validate(with_backups())
    assert list(b["pyro"]) == ["drogue", "main", "backup_drogue", "backup_main"]
    assert b["pyro"]["backup_main"]["sense"]["pin"] == 28
    assert pyro_pins_text(b) == "16 17 18 19\n"
    check_with_config(b, load_config(BACKUPS))
    only_main = validate(with_backups(backup_main=BACKUP_PYRO["backup_main"]))
    assert pyro_pins_text(only_main) == "16 17 19\n"


@pytest.mark.parametrize("change, message", [
    (lambda d: d["pyro"]["backup_main"].update(pin=16), "uses pin 16, already used by pyro.drogue"),
    (lambda d: d["pyro"]["backup_drogue"].update(pin=24), "reserved"),
    (lambda d: d["pyro"]["backup_drogue"].update(colour=1), "unknown key pyro.backup_drogue.colour"),
    (lambda d: d["pyro"].update(backup_apogee={"pin": 20}), "unknown key pyro.backup_apogee"),
    (lambda d: d.update(timers=[-1, -1]), "timers must be 4 hardware timer ids"),
])
def test_bad_backup_channels_one_line(change, message):
    d = with_backups()
    change(d)
    with pytest.raises(BoardError, match=message) as exc:
        validate(d)
    assert "\n" not in str(exc.value)


def test_esp32_refuses_a_strapping_pin_for_a_backup_channel():
    d = json.loads((REPO_ROOT / "device" / "boards" / "esp32.json").read_text())
    d["pyro"]["backup_main"] = {"pin": 12}
    d["timers"] = [0, 1, 2]
    with pytest.raises(BoardError, match="pyro.backup_main.pin = 12 glitches at reset"):
        validate(d)


@pytest.mark.parametrize("key,value,channel", [("backup_drogue_delay_s", 1, "backup_drogue"),
                                               ("backup_main_m", 150, "backup_main")])
def test_config_needs_the_backup_channels(key, value, channel):
    b = validate(PICO)
    with pytest.raises(BoardError, match="config %s = %r needs pyro.%s" % (key, value, channel)):
        check_with_config(b, load_config({key: value}))
    check_with_config(b, load_config({}))  # off: the board needs no backup channel


# -- on MicroPython ---------------------------------------------------------------------------------

@pytest.mark.micropython
@pytest.mark.parametrize("pins_txt", ["16 17 18 19\n", None, "16 17\n"])
def test_boot_py_drives_the_backup_pins_low(tmp_path, pins_txt):
    # from pyro_pins.txt, from board.json when the file is missing, and from board.json when a
    # stale file names only the primaries
    wd = tmp_path / "board"
    wd.mkdir()
    (wd / "board.json").write_text(json.dumps(with_backups()))
    if pins_txt is not None:
        (wd / "pyro_pins.txt").write_text(pins_txt)
    assert boot_pin_states(wd, (BACKUP_DROGUE_PIN, BACKUP_MAIN_PIN, 16, 17)) == [0, 0, 0, 0, 1]


GROUND_TEST = """
out["no_confirm"] = attempt(channel="backup_main", ms=50)
out["wrong_confirm"] = attempt(channel="backup_main", ms=50, confirm="main")
fake_machine.ADC_VALUES[28] = 40000                # an igniter on the backup main
out["igniter"] = attempt(channel="backup_main", ms=50, confirm="backup_main")
out["backup_main"] = attempt(channel="backup_main", ms=50, confirm="backup_main", igniter=LIVE)
out["backup_drogue"] = attempt(channel="backup_drogue", ms=70, confirm="backup_drogue")
from device import board
from device.pyro import Pyro
p = Pyro(machine, board.load("board.json"))
n0 = fake_machine.EV_N[0]
t0 = fake_time.elapsed
assert p.guard(3, 80)                              # the backup main's hardware bound
p.drive(False, False, False, True)
fake_time.advance(200000)
out["guard"] = [(t - t0, pin, l) for (t, pin, l) in fake_machine.pin_events()[n0:]]
"""


@pytest.mark.micropython
def test_ground_test_fires_a_backup_channel_only_when_confirmed(tmp_path):
    wd = tmp_path / "board"
    wd.mkdir()
    (wd / "board.json").write_text(json.dumps(with_backups()))
    res = run_groundtest(wd, GROUND_TEST)
    assert "type the channel name again" in res["no_confirm"]["refused"]
    assert "type the channel name again" in res["wrong_confirm"]["refused"]
    assert "igniter connected on backup_main" in res["igniter"]["refused"]
    assert res["backup_main"]["pins"] == [[0, 19, 1], [50000, 19, 0]]  # only that channel, 50 ms
    assert res["backup_drogue"]["pins"] == [[0, 18, 1], [70000, 18, 0]]
    assert res["guard"] == [[0, 19, 1], [80000, 19, 0]]


@pytest.mark.micropython
def test_ground_test_refuses_a_backup_channel_the_board_lacks(tmp_path):
    wd = tmp_path / "board"
    wd.mkdir()
    shutil.copy(REPO_ROOT / "device" / "boards" / "pico.json", wd / "board.json")
    res = run_groundtest(
        wd, 'out["missing"] = attempt(channel="backup_drogue", ms=50, confirm="backup_drogue")')
    assert "the board has no backup_drogue channel" in res["missing"]["refused"]


@pytest.fixture(scope="module")
def backup_flight(tmp_path_factory):
    from desktop.hosts.sil.flightgen import Scenario
    from desktop.hosts.sil.host import run_sil

    tmp = tmp_path_factory.mktemp("sil_backup")
    sc = Scenario(duration_s=90, launch_s=30, seed=3)
    adc = [[26, 40000], [27, 40000], [28, 40000]]
    result = run_sil(tmp / "board", sc, board={"pyro": with_backups()["pyro"], "timers": [-1] * 4},
                     config=BACKUPS, adc=adc)
    assert not (result.get("summary") or {}).get("heap_lock_faults"), "sample() allocated under the heap lock"
    return sc, result, tmp


@pytest.mark.micropython
def test_sil_flight_pulses_each_backup_once_after_its_primary(backup_flight):
    from desktop.hosts.sil.host import DROGUE_PIN, MAIN_PIN, rises

    sc, result, _tmp = backup_flight
    assert result["summary"]["reason"] == "landed", result["console"][-5:]
    boot = result["boots"][0]
    for pin in (BACKUP_DROGUE_PIN, BACKUP_MAIN_PIN):  # boot.py: low before anything else ran
        assert boot["modes"][pin] == 1 and boot["levels"][pin] == 0
    pulses = {pin: rises(result, pin) for pin in (DROGUE_PIN, MAIN_PIN, BACKUP_DROGUE_PIN, BACKUP_MAIN_PIN)}
    for pin, got in pulses.items():
        assert len(got) == 1 and got[0][1] == 500000, (pin, got)  # once, pulse_ms each
    assert abs(pulses[BACKUP_DROGUE_PIN][0][0] - pulses[DROGUE_PIN][0][0] - 1000000) <= 5000  # 1 s
    t_bm = pulses[BACKUP_MAIN_PIN][0][0]
    assert t_bm - pulses[MAIN_PIN][0][0] >= 1000000
    assert 125 <= sc.truth(t_bm / 1e6)[0] <= 150
    assert result["timers_fired"] == [1, 1, 1, 1]  # every channel's own hardware guard
    header_continuity = None
    from desktop.io.logdecode import read_log

    header_continuity = read_log(result["log"]).header["pad_checks"]["continuity"]
    assert header_continuity == {"drogue": "connected", "main": "connected",
                                 "backup_drogue": "no sense input", "backup_main": "connected"}


@pytest.mark.micropython
def test_sil_log_keeps_the_backup_events_and_replays_bit_identically(backup_flight):
    from desktop.io.logdecode import check_log, read_log, to_columns
    from shared.flight import EV_BACKUP_DROGUE, EV_BACKUP_MAIN
    from shared.logformat import FLAG_PYRO_BACKUP_DROGUE, FLAG_PYRO_BACKUP_MAIN

    _sc, result, _tmp = backup_flight
    log = read_log(result["log"])
    cols, _meta = to_columns(log)
    events, flags = cols["board_events"], cols["board_flags"]
    for event, flag in ((EV_BACKUP_DROGUE, FLAG_PYRO_BACKUP_DROGUE), (EV_BACKUP_MAIN, FLAG_PYRO_BACKUP_MAIN)):
        rows = [i for i in range(len(events)) if events[i] & event]
        assert len(rows) == 1 and flags[rows[0]] & flag and not flags[rows[0] - 1] & flag
        assert (flags & flag != 0).sum() == 25  # 500 ms at 50 Hz
    rows, problems = check_log(log, load_config(log.config))
    assert rows > 1000 and problems == []
