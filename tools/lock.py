"""Rewrite requirements.lock from pyproject.toml with uv: the one command to change or upgrade a dependency.

    python3 tools/lock.py             # after editing pyproject.toml: keep every pin that still fits
    python3 tools/lock.py --upgrade   # move every package to its newest version that fits

The lock holds one exact version per package, with the hashes of every released file, for every
Python the project supports (>= 3.11) and every platform (uv's universal resolution, choosing the
fewest versions: so the versions the tests pass with here are the ones installed everywhere).
uv runs from the project's .venv (set up by tools/dev.py) and is installed there if missing;
installing from the lock (tools/dev.py) needs only pip. Run the tests after an upgrade
(``python3 tools/dev.py test`` reinstalls from the new lock) and regenerate the figures the README
and docs/BENCHMARKS.md quote.
"""

import argparse
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from tools import dev  # noqa: E402

PYTHON_FLOOR = "%d.%d" % dev.MIN_PYTHON
COMPILE_ARGS = ("pip", "compile", "--quiet", "pyproject.toml", "--extra", "dev", "--generate-hashes",
                "--universal", "--fork-strategy", "fewest", "--python-version", PYTHON_FLOOR,
                "--custom-compile-command", "python3 tools/lock.py", "-o", "requirements.lock")


def ensure_uv(python):
    """Install uv into the virtual environment of ``python`` unless it is there."""
    if subprocess.run([python, "-m", "uv", "--version"], capture_output=True).returncode != 0:
        print("installing uv into .venv", flush=True)
        subprocess.run([python, "-m", "pip", "install", "--quiet", "uv"], check=True)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--upgrade", action="store_true", help="upgrade every package to its newest version")
    args = parser.parse_args(argv)
    dev.ensure_venv()
    python = str(dev.venv_python())
    ensure_uv(python)
    cmd = [python, "-m", "uv", *COMPILE_ARGS] + (["--upgrade"] if args.upgrade else [])
    status = subprocess.run(cmd, cwd=str(ROOT)).returncode
    if status == 0:
        print("wrote requirements.lock (git diff shows what moved); next: python3 tools/dev.py test")
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
