"""The flight code on a real 32-bit ARM MicroPython: MicroPython's bare-metal qemu port, built for
a Cortex-M0 (ARMv6-M, the RP2040's instruction set) or a Cortex-M3, run under
``qemu-system-arm -icount shift=0``, where SysTick cycles count guest instructions.

    python tools/armboard.py build [--board m0|m3|all] [--form FORM|all]
    python tools/armboard.py run SCRIPT.py [--board m0] [--form frozen]   # prints the guest's output
    python tools/armboard.py bench [--board m0,m3] [--form all] [--json OUT.json]
    python tools/armboard.py bench --board m0 --form frozen --locked-only --items "full step" --profile
    python tools/armboard.py bench --board m0 --form frozen --locked-only --items none --op-costs
    python tools/armboard.py check-tables     # no constant tuple holds an int outside +-8191

Forms (how the project's modules reach the board):

- ``frozen``: frozen into the firmware as bytecode (manifest ``freeze``, mpy-tool), as production
  firmware is usually built;
- ``frozen-source``: frozen into the firmware as source (``freeze_as_str``), compiled on import;
- ``mpy``: compiled by the same version's mpy-cross and loaded at run time from a RAM filesystem
  filled over the raw REPL (as ``mpremote cp`` of .mpy files would);
- ``source``: .py files loaded at run time from that RAM filesystem.

Modules: ``shared/``, ``device/``, the software-in-the-loop fakes (``desktop/hosts/sil/``,
``desktop/sim/fakes/``), ``tools/bench_step.py``, ``tools/synthetic_flight.py`` and
``tools/armboard_guest.py``.

MicroPython comes from ``third_party/micropython/`` (the vendored tarball, with the patch that
makes the qemu port's ``time.ticks_cpu()`` return SysTick cycles and fixes its ``ticks_us`` wrap
race) or from ``--micropython PATH`` (a checkout of the MicroPython repository; the patch is
applied to a copy). Builds are cached in ``build/arm/`` and redone only when an input changes.
The toolchain: ``apt-get install -y gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm``
(Debian/Ubuntu); the README says how to get it elsewhere. Every problem is one line on stderr and
exit status 2.
"""

import argparse
import ast
import hashlib
import json
import os
import re
import select
import shutil
import subprocess
import sys
import tarfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))  # the bench imports desktop.hosts.sil for the firmware's flight
VENDOR = ROOT / "third_party" / "micropython"
TARBALL = VENDOR / "micropython-1c3c2011.tar.gz"
PATCH = VENDOR / "qemu-ticks-cpu.patch"
FLAGS_MK = VENDOR / "rp2-flags.mk"
M0_LDSCRIPT = VENDOR / "nrf51-2m.ld"
CACHE = Path(os.environ.get("APOGEE_ARM_CACHE", ROOT / "build" / "arm"))
APT_HINT = "apt-get install -y gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm"

HEAP_BYTES = 1835008  # 1.75 MB: the tests' longest flights and their states fit (RAM is 2 MB)
M0_SRAM_BYTES = 4194304  # the firmware is linked for the first 2 MB; files are loaded above
M0_FLASH_BYTES = 1048576
# name: (MicroPython BOARD, qemu machine, extra qemu arguments, extra make arguments)
BOARDS = {
    "m0": ("MICROBIT", "microbit",
           ["-global", "nrf51-soc.flash-size=%d" % M0_FLASH_BYTES,
            "-global", "nrf51-soc.sram-size=%d" % M0_SRAM_BYTES],
           ["LDSCRIPT=%s" % M0_LDSCRIPT]),
    "m3": ("MPS2_AN385", "mps2-an385", [], []),
}
FORMS = ("frozen", "frozen-source", "mpy", "source")
# The firmware each form runs: the VFS forms share one with nothing frozen.
FIRMWARE_OF_FORM = {"frozen": "frozen", "frozen-source": "frozen-source", "mpy": "plain", "source": "plain"}
# rp2-like speed options (the rp2 port's computed goto; -O2 for vm.c and gc.c through CSUPEROPT,
# map.c and mpz.c through rp2-flags.mk); the inline assembler, which the port leaves out on the
# Cortex-M0 only, for the calibration loop.
CFLAGS_EXTRA = "-DMICROPY_OPT_COMPUTED_GOTO=1"
CFLAGS_EXTRA_M0 = " -DMICROPY_EMIT_INLINE_THUMB=1"

# Files put on the board (relative to the repository root).
MODULE_GLOBS = ("shared/*.py", "device/*.py", "device/drivers/*.py", "desktop/__init__.py",
                "desktop/sim/__init__.py", "desktop/sim/fakes/*.py", "desktop/hosts/__init__.py",
                "tools/__init__.py", "tools/bench_step.py",
                "tools/synthetic_flight.py", "tools/armboard_guest.py")
SIL_MODULES = ("desktop/hosts/sil/__init__.py", "desktop/hosts/sil/fake_machine.py",
               "desktop/hosts/sil/fake_micropython.py", "desktop/hosts/sil/fake_time.py",
               "desktop/hosts/sil/replay_sensors.py", "desktop/hosts/sil/world.py")
FIRMWARE_DIRS = ("shared/", "device/")  # check-tables: the flight firmware (not the test fakes)
PACKAGE_INITS = ("tests/__init__.py",)  # namespace packages on CPython: frozen with a comment
# An empty frozen-as-source module ends the frozen table early and a later import crashes the
# port (HardFault): every empty file gets this line before freezing.
EMPTY_MODULE_TEXT = "# package\n"
SMALL_INT_MIN = -8192  # mpy-tool freezes ints outside this range in constant tuples as long ints
SMALL_INT_MAX = 8191

CALIBRATION_LOOPS = 1000000  # x (subs; bne): 2,000,000 instructions, less those of one loop
CALIBRATION = """
@micropython.asm_thumb
def _spin(r0):
    label(loop)
    sub(r0, r0, 1)
    bne(loop)
import time
def _cycles(n):
    t0 = time.ticks_cpu()
    _spin(n)
    return time.ticks_diff(time.ticks_cpu(), t0)
print('calibration', _cycles(%d) - _cycles(1))
""" % CALIBRATION_LOOPS

RAMFS = '''
import io, os, sys
class RamFS:
    """A read-only filesystem in RAM (stat, open, ilistdir): what import and open() need."""
    def __init__(self):
        self.files = {}
        self.dirs = {""}
        self.cwd = ""
    def load(self, addr, size, index):
        import uctypes
        mem = memoryview(uctypes.bytearray_at(addr, size))
        for path, offset, length in index:
            self.files[path] = mem[offset:offset + length]
            parts = path.split("/")
            for k in range(1, len(parts)):
                self.dirs.add("/".join(parts[:k]))
    def mount(self, readonly, mkfs):
        pass
    def umount(self):
        pass
    def chdir(self, path):
        self.cwd = self._path(path)
    def getcwd(self):
        return "/" + self.cwd
    def _path(self, path):
        if not path.startswith("/") and self.cwd:
            path = self.cwd + "/" + path
        return path.strip("/")
    def ilistdir(self, path):
        path = self._path(path)
        for name in self.files:
            if name.rsplit("/", 1)[0] == path or (path == "" and "/" not in name):
                yield (name.rsplit("/", 1)[-1], 0x8000, 0, len(self.files[name]))
    def stat(self, path):
        path = self._path(path)
        if path in self.dirs:
            return (0x4000, 0, 0, 0, 0, 0, 0, 0, 0, 0)
        if path in self.files:
            return (0x8000, 0, 0, 0, 0, 0, len(self.files[path]), 0, 0, 0)
        raise OSError(2)
    def open(self, path, mode):
        path = self._path(path)
        if path not in self.files:
            raise OSError(2)
        return io.BytesIO(self.files[path])
_rf = RamFS()
os.mount(_rf, "/ram")
sys.path.insert(0, "/ram")
'''
# Where qemu's generic loader puts the files of the RAM filesystem: past the 2 MB of RAM the
# Cortex-M0 firmware is linked for (qemu gives it 4 MB), and the MPS2's PSRAM.
BLOB_ADDR = {"m0": 0x20200000, "m3": 0x21000000}
BLOB_MAX_BYTES = 2097152


class ArmError(Exception):
    """A problem for the user: one line, exit status 2."""


# -- toolchain and sources ---------------------------------------------------------------------------

def check_toolchain():
    """Raise ArmError naming the install command if the cross compiler, newlib or qemu is missing."""
    for tool in ("arm-none-eabi-gcc", "qemu-system-arm", "make", "cc"):
        if shutil.which(tool) is None:
            raise ArmError("%s not found: install the toolchain (Debian/Ubuntu: sudo %s)" % (tool, APT_HINT))
    libc = subprocess.run(["arm-none-eabi-gcc", "-mcpu=cortex-m0", "-mthumb", "-print-file-name=libc.a"],
                          capture_output=True, text=True).stdout.strip()
    if not os.path.isabs(libc) or not os.path.exists(libc):
        raise ArmError("newlib for arm-none-eabi not found (Debian/Ubuntu: sudo %s)" % APT_HINT)


def toolchain_missing():
    """None if the toolchain is installed, else the one-line reason (used by the tests to skip)."""
    try:
        check_toolchain()
    except ArmError as exc:
        return str(exc)
    return None


def _sha(*parts):
    h = hashlib.sha256()
    for p in parts:
        h.update(p if isinstance(p, bytes) else str(p).encode())
    return h.hexdigest()[:16]


def _run(cmd, cwd, log, what):
    with open(log, "w") as f:
        proc = subprocess.run(cmd, cwd=str(cwd), stdout=f, stderr=subprocess.STDOUT)
    if proc.returncode != 0:
        raise ArmError("%s failed (exit %d); the log is %s" % (what, proc.returncode, log))


def source_tree(micropython=None):
    """Unpacked (or copied) MicroPython with the ticks_cpu patch applied; returns its path."""
    patch = PATCH.read_bytes()
    if micropython is None:
        if not TARBALL.exists():
            raise ArmError("%s is missing (the vendored MicroPython)" % TARBALL)
        key = _sha(TARBALL.read_bytes(), patch)
    else:
        src = Path(micropython).resolve()
        if not (src / "py" / "mpconfig.h").exists() or not (src / "ports" / "qemu").is_dir():
            raise ArmError("%s is not a MicroPython source tree (no py/mpconfig.h or ports/qemu)" % src)
        key = _sha(str(src), patch)
    tree = CACHE / ("src-" + key)
    if (tree / ".ready").exists():
        return tree
    if tree.exists():
        shutil.rmtree(tree)
    tmp = CACHE / ("tmp-" + key)
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir(parents=True)
    if micropython is None:
        with tarfile.open(TARBALL) as tar:
            tar.extractall(tmp, filter="data") if sys.version_info >= (3, 12) else tar.extractall(tmp)
        (top,) = [p for p in tmp.iterdir() if p.is_dir()]
    else:
        top = tmp / "micropython"
        top.mkdir()
        for sub in ("py", "extmod", "shared", "lib", "drivers", "mpy-cross", "tools", "ports/qemu"):
            if (src / sub).exists():
                shutil.copytree(src / sub, top / sub, symlinks=True,
                                ignore=shutil.ignore_patterns("build*", ".git"))
        shutil.copy(src / "LICENSE", top / "LICENSE") if (src / "LICENSE").exists() else None
    proc = subprocess.run(["git", "apply", "-p1", str(PATCH)], cwd=str(top), capture_output=True, text=True)
    if proc.returncode != 0:
        raise ArmError("the ticks_cpu patch does not apply to %s: %s" % (
            micropython or TARBALL, (proc.stderr.strip().splitlines() or ["?"])[0]))
    top.rename(tree)
    shutil.rmtree(tmp)
    (tree / ".ready").write_text(key)
    return tree


def mpy_cross(tree):
    """Path of the tree's own mpy-cross, built once."""
    exe = tree / "mpy-cross" / "build" / "mpy-cross"
    if not exe.exists():
        _run(["make", "-j2", "-C", "mpy-cross"], tree, CACHE / "mpy-cross.log", "building mpy-cross")
    return exe


# -- the project's modules --------------------------------------------------------------------------

def module_files():
    """Repository-relative paths of every module put on the board."""
    files = []
    for pattern in MODULE_GLOBS:
        files += sorted(str(p.relative_to(ROOT)) for p in ROOT.glob(pattern))
    return files + list(SIL_MODULES)


def stage_modules():
    """Copy the modules into the cache (empty ones get a comment); returns (dir, content hash)."""
    contents = {}
    for rel in module_files():
        text = (ROOT / rel).read_text()
        contents[rel] = text if text.strip() else EMPTY_MODULE_TEXT
    for rel in PACKAGE_INITS:
        contents[rel] = EMPTY_MODULE_TEXT
    key = _sha(*[k + "\0" + v for k, v in sorted(contents.items())])
    stage = CACHE / ("stage-" + key)
    if not (stage / ".ready").exists():
        for old in CACHE.glob("stage-*"):  # stale copies of the modules
            shutil.rmtree(old, ignore_errors=True)
        for rel, text in contents.items():
            (stage / rel).parent.mkdir(parents=True, exist_ok=True)
            (stage / rel).write_text(text)
        (stage / ".ready").write_text(key)
    return stage, key, sorted(contents)


def big_tuple_ints(path):
    """(line, value) of every int outside +-8191 in a constant tuple of a Python file: MicroPython's
    freezer stores those as long-int objects, which allocate whenever they are used."""
    tree = ast.parse(Path(path).read_text())
    consts = {}
    for node in tree.body:  # NAME = const(value) at module level: the compiler substitutes it
        if (isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name)
                and isinstance(node.value, ast.Call) and getattr(node.value.func, "id", "") == "const"
                and node.value.args and isinstance(node.value.args[0], ast.Constant)):
            consts[node.targets[0].id] = node.value.args[0].value

    def value(node):
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            v = value(node.operand)
            return -v if isinstance(v, (int, float)) and not isinstance(v, bool) else _NOT_CONST
        if isinstance(node, ast.Name) and node.id in consts:
            return consts[node.id]
        if isinstance(node, ast.Tuple):
            items = [value(e) for e in node.elts]
            return _NOT_CONST if any(v is _NOT_CONST for v in items) else tuple(items)
        return _NOT_CONST

    def ints(v):
        if isinstance(v, tuple):
            for x in v:
                yield from ints(x)
        elif isinstance(v, int) and not isinstance(v, bool):
            yield v

    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Tuple):
            v = value(node)
            if v is not _NOT_CONST:
                found += [(node.lineno, x) for x in ints(v) if not SMALL_INT_MIN <= x <= SMALL_INT_MAX]
    return sorted(set(found))


_NOT_CONST = object()


# -- firmware ---------------------------------------------------------------------------------------

def _manifest(kind, stage, files):
    if kind == "plain":
        return "# nothing frozen: the modules come through the RAM filesystem\n"
    if kind == "frozen":
        return "freeze(%r, %r)\n" % (str(stage), tuple(files))
    return "freeze_as_str(%r)\n" % str(stage)


def build(board, kind, micropython=None, quiet=False):
    """Build (or reuse) the firmware of ``board`` ("m0"/"m3") and ``kind`` ("frozen",
    "frozen-source", "plain"); returns (firmware.elf path, seconds spent building)."""
    check_toolchain()
    t0 = time.monotonic()
    tree = source_tree(micropython)
    cross = mpy_cross(tree)
    stage, stage_key, files = stage_modules()
    mp_board, _machine, _qemu_args, make_args = BOARDS[board]
    cflags = (CFLAGS_EXTRA + (CFLAGS_EXTRA_M0 if board == "m0" else "")
              + (" -DMICROPY_MODULE_FROZEN_STR=1" if kind == "frozen-source" else ""))
    # make tracks source files but not flags: a change of options rebuilds from scratch, a change
    # of the frozen modules only regenerates the frozen content
    options = _sha(tree.name, board, kind, cflags, HEAP_BYTES, FLAGS_MK.read_bytes(),
                   M0_LDSCRIPT.read_bytes())
    inputs = options + "-" + (stage_key if kind != "plain" else "")
    out = CACHE / ("fw-%s-%s-%s" % (tree.name[4:12], board, kind))
    elf = out / "firmware.elf"
    stamp = out / ".inputs"
    old = stamp.read_text() if stamp.exists() else ""
    if elf.exists() and old == inputs:
        return elf, 0.0
    if out.exists() and not old.startswith(options + "-"):
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)
    manifest = out / "manifest.py"
    manifest.write_text(_manifest(kind, stage, files))
    libdir = out / "no-micropython-lib"  # the port's default manifest wants micropython-lib
    libdir.mkdir(exist_ok=True)
    (libdir / "README.md").write_text("micropython-lib is not used\n")
    if not quiet:
        print("building %s firmware (%s) in %s ..." % (board, kind, out), file=sys.stderr, flush=True)
    cmd = ["make", "-j2", "-f", str(FLAGS_MK), "BOARD=" + mp_board, "BUILD=" + str(out),
           "FROZEN_MANIFEST=" + str(manifest), "MPY_LIB_DIR=" + str(libdir),
           "MPY_CROSS=" + str(cross), "MICROPY_HEAP_SIZE=%d" % HEAP_BYTES, "CSUPEROPT=-O2",
           "CFLAGS_EXTRA=" + cflags] + make_args
    _run(cmd, tree / "ports" / "qemu", out / "build.log", "building the %s firmware (%s)" % (board, kind))
    if kind == "frozen":
        _check_frozen_ints(out)
    stamp.write_text(inputs)
    return elf, time.monotonic() - t0


def frozen_tuple_long_ints(c_text, prefix="const_obj_shared_"):
    """Names of the long-int objects inside constant tuples of mpy-tool's frozen C (``prefix``: the
    modules checked). Each would allocate when used; true long ints outside tuples (such as the
    log's CRC constants) are not the freezer's doing and are not listed."""
    longs = set(re.findall(r"static const mp_obj_int_t (%s\w+) = \{\{&mp_type_int\}" % prefix, c_text))
    in_tuples = set()
    tuple_re = r"mp_rom_obj_tuple_t %s\w+ = \{\{&mp_type_tuple\}, \d+, \{(.*?)\}\};" % prefix
    for body in re.findall(tuple_re, c_text, re.S):
        in_tuples.update(re.findall(r"&(%s\w+)\)" % prefix, body))
    return sorted(longs & in_tuples)


def _check_frozen_ints(out):
    """Refuse a frozen shared/ whose constant tuples hold long ints."""
    content = out / "frozen_content.c"
    if content.exists():
        hits = frozen_tuple_long_ints(content.read_text())
        if hits:
            raise ArmError("frozen shared/ holds %d long-int constants in tuples (%s ...): an int outside "
                           "+-8191 in a constant tuple; see python tools/armboard.py check-tables"
                           % (len(hits), hits[0]))


def compile_mpy(tree, stage, files):
    """{board path: .mpy bytes} of every staged module, compiled by the tree's mpy-cross."""
    cross = mpy_cross(tree)
    out = {}
    for rel in files:
        dest = CACHE / "mpy" / (rel[:-3] + ".mpy")
        src = stage / rel
        dest.parent.mkdir(parents=True, exist_ok=True)
        if not dest.exists() or dest.stat().st_mtime < src.stat().st_mtime:
            proc = subprocess.run([str(cross), "-o", str(dest), "-s", rel, str(src)],
                                  capture_output=True, text=True)
            if proc.returncode != 0:
                raise ArmError("mpy-cross %s: %s" % (rel, proc.stderr.strip().splitlines()[-1]))
        out[rel[:-3] + ".mpy"] = dest.read_bytes()
    return out


# -- running ----------------------------------------------------------------------------------------

class Board:
    """One qemu-system-arm process with the firmware, driven through the raw REPL on its UART."""

    def __init__(self, elf, board, timeout_s=600, blob=None):
        _mp_board, machine, qemu_args, _make = BOARDS[board]
        self.timeout_s = timeout_s
        cmd = (["qemu-system-arm", "-machine", machine] + qemu_args
               + ["-display", "none", "-monitor", "none", "-serial", "stdio", "-semihosting",
                  "-icount", "shift=0", "-kernel", str(elf)])
        if blob is not None:
            cmd += ["-device", "loader,file=%s,addr=0x%x,force-raw=on" % (blob, BLOB_ADDR[board])]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.DEVNULL)
        self.fd = self.proc.stdout.fileno()
        self.buf = b""
        self._send(b"\r\x03\x03\x01")
        self._read_until(b"raw REPL; CTRL-B to exit\r\n>")

    def _send(self, data):
        self.proc.stdin.write(data)
        self.proc.stdin.flush()

    def _read_until(self, token):
        deadline = time.monotonic() + self.timeout_s
        while token not in self.buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise ArmError("the board did not answer within %d s (last output: %r)" % (
                    self.timeout_s, self.buf[-200:]))
            ready, _, _ = select.select([self.fd], [], [], left)
            if ready:
                chunk = os.read(self.fd, 65536)
                if not chunk:
                    raise ArmError("qemu exited (last output: %r)" % self.buf[-200:])
                self.buf += chunk
        head, _, self.buf = self.buf.partition(token)
        return head

    def exec(self, code):
        """Run ``code`` in the raw REPL; returns its stdout; raises ArmError with the traceback."""
        self._send(code.encode() + b"\x04")
        self._read_until(b"OK")
        out = self._read_until(b"\x04")
        err = self._read_until(b"\x04")
        self._read_until(b">")
        if err.strip():
            lines = err.decode(errors="replace").strip().splitlines()
            raise GuestError(lines[-1], err.decode(errors="replace"))
        return out.decode(errors="replace").replace("\r\n", "\n")

    def close(self):
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()


class GuestError(ArmError):
    """The guest code raised; ``str()`` is its last traceback line, ``traceback`` the whole text."""

    def __init__(self, line, traceback):
        super().__init__("the guest raised: " + line)
        self.traceback = traceback


def start(board, form, micropython=None, timeout_s=600, files=None, modules=None):
    """A running Board with the project's modules available in ``form``, and ``files`` ({path:
    bytes}) in its RAM filesystem (/ram, also on sys.path); close it after use. ``modules``
    limits the modules the VFS forms load to those under these prefixes (default: all)."""
    kind = FIRMWARE_OF_FORM[form]
    elf, _ = build(board, kind, micropython, quiet=True)
    payload = dict(files or {})
    if form in ("mpy", "source"):
        stage, _key, names = stage_modules()
        names = [n for n in names if modules is None or n.startswith(tuple(modules))]
        if form == "mpy":
            payload.update(compile_mpy(source_tree(micropython), stage, names))
        else:
            payload.update({rel: (stage / rel).read_bytes() for rel in names})
    index = []
    data = bytearray()
    for path in sorted(payload):
        index.append((path, len(data), len(payload[path])))
        data += payload[path]
        data += bytes(-len(data) % 4)
    if len(data) > BLOB_MAX_BYTES:
        raise ArmError("the files for the board take %d bytes, more than %d" % (len(data), BLOB_MAX_BYTES))
    blob = CACHE / ("files-%s-%s-%s.bin" % (board, form, _sha(bytes(data))))
    if not blob.exists():
        for old in CACHE.glob("files-%s-%s-*.bin" % (board, form)):
            old.unlink()
        blob.write_bytes(bytes(data) or bytes(4))
    b = Board(elf, board, timeout_s, blob)
    try:
        b.exec(RAMFS)
        b.exec("_rf.load(0x%x, %d, %r)" % (BLOB_ADDR[board], len(data), index))
    except BaseException:
        b.close()
        raise
    return b


def calibrate(b):
    """Guest instructions per SysTick cycle, measured with an inline-assembler loop."""
    out = b.exec(CALIBRATION)
    ticks = int(out.split("calibration")[1].split()[0])
    return 2 * (CALIBRATION_LOOPS - 1) / ticks


def parse_ints(out, label):
    """The ints of a tools.armboard_guest.print_ints() line."""
    for line in out.splitlines():
        if line.startswith(label + ":"):
            return [int(x) for x in line[len(label) + 1:].split()]
    raise ArmError("no %r line in the guest's output: %r" % (label, out[-300:]))


def parse_dump(out, name):
    """(ticks, phases, states) lists from a tools.armboard_guest.dump() output."""
    parts = {}
    for line in out.splitlines():
        if line.startswith(name + " "):
            head, _, values = line.partition(": ")
            parts[head.split()[-1]] = [int(x) for x in values.split()]
    return parts["ticks"], parts["phases"], parts["states"]


# -- bench ------------------------------------------------------------------------------------------

BENCH_RATE_HZ = 100
PHASES = ("pad", "boost", "coast", "descent")
BENCH_SETUP = """
from tools.synthetic_flight import make_flight
from tools import armboard_guest as g
flight = make_flight(rate_hz=%d)
phases = g.flight_phases(flight, %d, 2, 2000)
print('overhead', g.overhead())
""" % (BENCH_RATE_HZ, BENCH_RATE_HZ)
BENCH_ITEMS = (
    # name, guest call, samples from (the detector and filter loops skip sample 0)
    ("filter", "g.count_filter(flight, phases, %d, %%s)" % BENCH_RATE_HZ, 1),
    ("detector", "g.count_detector(flight, phases, len(flight[0]) // 4, %s)", 1),
    ("full step", "g.count_fc(flight, %s)", 0),
    ("pressure_to_alt_mm", "g.count_altitude(2000, %s)", 0),
)


def summarise(ticks, phases, overhead, scale, first=0):
    """Mean and worst instructions per sample, overall and by phase."""
    net = [(t - overhead) * scale for t in ticks[first:]]
    ph = phases[first:]
    res = {"mean": sum(net) / len(net), "worst": max(net), "samples": len(net), "phases": {}}
    for k, name in enumerate(PHASES):
        sel = [v for v, p in zip(net, ph, strict=True) if p == k]
        if sel:
            res["phases"][name] = {"mean": sum(sel) / len(sel), "worst": max(sel), "samples": len(sel)}
    return res


FW_BENCH_SAMPLES = 700  # 14 s of a 50 Hz board (pico.json): pad, boost, coast, apogee, descent
FW_BENCH_SCENARIO = dict(duration_s=16, launch_s=1.0, boost_mps2=80.0, burn_s=1.0, seed=21)


def firmware_files(workdir, scenario):
    """{board path: bytes} of board.json, config.json and the sensor frames of a SIL scenario."""
    from desktop.hosts.sil.flightgen import Scenario
    from desktop.hosts.sil.host import prepare

    prepare(workdir, Scenario(**scenario))
    return {"sil/" + n: (Path(workdir) / n).read_bytes() for n in ("board.json", "config.json", "frames.bin")}


def parse_profile(out, overhead, scale):
    """The per-function breakdown of a tools.armboard_guest.dump_profile() output: {label: {"calls",
    "incl", "self" (instructions per sample, means over the flight), "self_worst" (the worst
    sample's), "phases": {phase: self mean}}}, in the guest's order, the step last."""
    labels = None
    for line in out.splitlines():
        if line.startswith("profile labels: "):
            labels = line[len("profile labels: "):].split()
    if labels is None:
        raise ArmError("no profile in the guest's output: %r" % out[-300:])
    k = len(labels)
    incl, self_t, calls = (parse_ints(out, "profile " + part) for part in ("incl", "self", "calls"))
    worst = parse_ints(out, "profile worst")
    phases = parse_ints(out, "profile phases")
    n = len(phases)
    counts = [phases.count(p) for p in range(len(PHASES))]
    res = {}
    for j, label in enumerate(labels):
        step = j == k - 1  # the step's ticks include the loop's readings
        ovh = overhead if step else 0
        tot = [sum(a[p * k + j] for p in range(len(PHASES))) for a in (incl, self_t, calls)]
        res[label] = {
            "calls": tot[2] / n,
            "incl": (tot[0] - ovh * n) * scale / n,
            "self": (tot[1] - ovh * n) * scale / n,
            "self_worst": (worst[j] - ovh) * scale,
            "phases": {name: (self_t[p * k + j] - ovh * counts[p]) * scale / counts[p]
                       for p, name in enumerate(PHASES) if counts[p]},
        }
    return res


def print_profile(profile, unprofiled_mean=None):
    """The breakdown table, by self time (instructions per sample, thousands)."""
    print("  per-function breakdown of the full step (instructions per sample, thousands; self = "
          "without the functions listed; calls per sample)")
    print("  %-36s %7s %7s %7s %7s %7s %7s %7s %7s" % ("function", "calls", "self", "incl", "worst",
                                                     *PHASES))
    rows = sorted(profile.items(), key=lambda kv: -kv[1]["self"])
    for label, r in rows:
        if not r["calls"]:
            continue
        print("  %-36s %7.2f %7.1f %7.1f %7.1f %s" % (
            label, r["calls"], r["self"] / 1000, r["incl"] / 1000, r["self_worst"] / 1000,
            " ".join("%7.1f" % (r["phases"].get(p, 0) / 1000) for p in PHASES)))
    total = sum(r["self"] for r in profile.values())
    print("  %-36s %7s %7.1f%s" % ("sum of self", "", total / 1000, "" if unprofiled_mean is None else
                                   "   (unprofiled full step: %.1f)" % (unprofiled_mean / 1000)))


def bench_form(board, form, micropython=None, unlocked=True, profile=False, items=None, op_costs=False):
    """Instruction counts of every BENCH_ITEMS entry (or those named in ``items``), and of the
    firmware's sample() (unless ``items`` leaves out "firmware"), on one board and form; with
    ``profile`` the per-function breakdown of the full step (``parse_profile``) too, with
    ``op_costs`` the instructions of single operations and calls ({label: instructions})."""
    files = firmware_files(CACHE / "sil-bench", FW_BENCH_SCENARIO)
    b = start(board, form, micropython, files=files)
    try:
        scale = calibrate(b)
        out = b.exec(BENCH_SETUP)
        overhead = int(out.split("overhead")[1].split()[0])
        result = {"instructions_per_tick": scale, "overhead_ticks": overhead, "locked": {}, "unlocked": {}}
        for lock in (True, False) if unlocked else (True,):
            for name, call, first in BENCH_ITEMS:
                if not lock and name == "pressure_to_alt_mm" or items is not None and name not in items:
                    continue
                out = b.exec("g.dump('r', %s)" % (call % lock))
                ticks, phases, _states = parse_dump(out, "r")
                mode = "locked" if lock else "unlocked"
                result[mode][name] = summarise(ticks, phases, overhead, scale, first)
        if profile:
            out = b.exec("g.dump_profile(g.profile_fc(flight))")
            result["profile"] = parse_profile(out, overhead, scale)
        if op_costs:
            out = b.exec("g.dump_op_costs()")
            result["op_costs"] = {}
            for line in out.splitlines():
                if line.startswith("opcost "):
                    _word, ticks, label = line.split(" ", 2)
                    result["op_costs"][label] = int(ticks) * scale / 10  # ten operations per reading
        if items is not None and "firmware" not in items:
            return result
        out = b.exec("g.dump('fw', g.firmware_path('/ram/sil/frames.bin', '/ram/sil', %d, True, True))\n"
                     "g.print_ints('fake', g.FAKE_BUS_TICKS)\n" % FW_BENCH_SAMPLES)
        ticks, phases, _states = parse_dump(out, "fw")
        result["locked"]["firmware sample(), fake I2C"] = summarise(parse_ints(out, "fake"), phases,
                                                                    overhead, scale)
        result["locked"]["firmware sample(), replayed"] = summarise(ticks, phases, overhead, scale)
    finally:
        b.close()
    return result


def _fmt_k(x):
    return "%.1fk" % (x / 1000.0)


def print_bench(results, header=True):
    """The bench table: instructions per sample (thousands), mean / worst, by phase."""
    if header:
        print("guest instructions per sample (thousands; qemu -icount shift=0, SysTick), mean / worst; "
              "the firmware rows: 50 Hz, two flight computers per sample on the pad")
    for (board, form), r in results.items():
        print("\n%s, %s (%.2f instructions per SysTick cycle)" % (board, form, r["instructions_per_tick"]))
        print("  %-30s %-8s %15s %15s %15s %15s %15s" % ("what", "heap", "all", *PHASES))
        for mode in ("locked", "unlocked"):
            for name, s in r[mode].items():
                cells = ["%s / %s" % (_fmt_k(s["mean"]), _fmt_k(s["worst"]))]
                for ph in PHASES:
                    p = s["phases"].get(ph)
                    cells.append("%s / %s" % (_fmt_k(p["mean"]), _fmt_k(p["worst"])) if p and name not in (
                        "pressure_to_alt_mm",) else "-")
                print("  %-30s %-8s %15s %15s %15s %15s %15s" % (name, mode, *cells))
        if "profile" in r:
            step = r["locked"].get("full step")
            print()
            print_profile(r["profile"], step["mean"] if step else None)
        if "op_costs" in r:
            print("\n  instructions per operation (heap locked)")
            for label, n in r["op_costs"].items():
                print("  %-50s %6.0f" % (label, n))


def _boards(text):
    names = list(BOARDS) if text == "all" else text.split(",")
    for n in names:
        if n not in BOARDS:
            raise ArmError("unknown board %r (known: %s, all)" % (n, ", ".join(BOARDS)))
    return names


def _forms(text):
    names = list(FORMS) if text == "all" else text.split(",")
    for n in names:
        if n not in FORMS:
            raise ArmError("unknown form %r (known: %s, all)" % (n, ", ".join(FORMS)))
    return names


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     epilog=__doc__.split("\n\n", 1)[1],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--micropython", metavar="PATH",
                        help="a MicroPython source tree to build instead of the vendored tarball")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("build", help="build the firmware (cached in build/arm/)")
    p.add_argument("--board", default="m0",
                   help="m0 (Cortex-M0, micro:bit), m3 (Cortex-M3, MPS2-AN385) or all")
    p.add_argument("--form", default="all", help="%s, or all" % ", ".join(FORMS))
    p = sub.add_parser("run", help="run a script on the board (modules available in --form)")
    p.add_argument("script")
    p.add_argument("--board", default="m0")
    p.add_argument("--form", default="frozen")
    p.add_argument("--timeout", type=float, default=600, help="seconds without an answer (default 600)")
    p = sub.add_parser("bench", help="instructions per sample of the filter, detector and full step")
    p.add_argument("--board", default="m0,m3")
    p.add_argument("--form", default="all")
    p.add_argument("--locked-only", action="store_true", help="skip the heap-unlocked runs")
    p.add_argument("--json", metavar="OUT", help="also write the figures as JSON")
    p.add_argument("--profile", action="store_true",
                   help="also the full step's per-function breakdown (heap locked)")
    p.add_argument("--op-costs", action="store_true",
                   help="also the instructions of single operations and calls (local, attribute, call, "
                        "method call on each of the flight computer's objects)")
    p.add_argument("--items", metavar="NAMES",
                   help="only these, comma-separated: %s, firmware, or none (default: all)" % ", ".join(
                       name for name, _call, _first in BENCH_ITEMS))
    sub.add_parser("check-tables", help="list ints outside +-8191 in constant tuples of shared/ and device/")
    args = parser.parse_args(argv)
    try:
        if args.command == "check-tables":
            firmware = [rel for rel in module_files() if rel.startswith(FIRMWARE_DIRS)]
            bad = [(rel, line, v) for rel in firmware for line, v in big_tuple_ints(ROOT / rel)]
            for rel, line, v in bad:
                print("%s:%d: %d in a constant tuple (frozen as a long int)" % (rel, line, v))
            print("%d modules checked, %d big ints in constant tuples" % (len(firmware), len(bad)))
            return 1 if bad else 0
        if args.command == "build":
            for board in _boards(args.board):
                for kind in sorted({FIRMWARE_OF_FORM[f] for f in _forms(args.form)}):
                    elf, seconds = build(board, kind, args.micropython)
                    print("%s %s: %s (%s)" % (board, kind, elf, "built in %.0f s" % seconds if seconds
                                              else "up to date"))
            return 0
        if args.command == "run":
            (board,) = _boards(args.board)
            (form,) = _forms(args.form)
            code = Path(args.script).read_text()
            b = start(board, form, args.micropython, args.timeout)
            try:
                sys.stdout.write(b.exec(code))
            finally:
                b.close()
            return 0
        items = None
        if args.items is not None:
            items = args.items.split(",")
            known = [name for name, _call, _first in BENCH_ITEMS] + ["firmware", "none"]
            for name in items:
                if name not in known:
                    raise ArmError("unknown bench item %r (known: %s)" % (name, ", ".join(known)))
        results = {}
        for board in _boards(args.board):
            for form in _forms(args.form):
                results[(board, form)] = bench_form(board, form, args.micropython, not args.locked_only,
                                                    args.profile, items, args.op_costs)
                print_bench({(board, form): results[(board, form)]}, header=len(results) == 1)
                sys.stdout.flush()
        if args.json:
            Path(args.json).write_text(json.dumps({"%s/%s" % k: v for k, v in results.items()}, indent=1))
        return 0
    except GuestError as exc:
        print("armboard: %s" % exc, file=sys.stderr)
        print(exc.traceback, file=sys.stderr)
        return 2
    except ArmError as exc:
        print("armboard: %s" % exc, file=sys.stderr)
        return 2
    except OSError as exc:
        print("armboard: %s" % exc, file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
