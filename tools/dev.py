"""Set up the project's virtual environment and run the main job or the test suite.

Usage (from the repository root, with any Python >= 3.10):

    python3 tools/dev.py run     # set up .venv, run the 200-flight seed study, write plots to out/
    python3 tools/dev.py test    # set up .venv, run every test (MicroPython interpreters included)

The environment is (re)installed only when pyproject.toml changed since the last install.
"""

import hashlib
import os
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VENV = ROOT / ".venv"
STAMP = VENV / ".installed-pyproject-sha256"


def venv_python():
    sub = "Scripts/python.exe" if os.name == "nt" else "bin/python"
    return VENV / sub


def ensure_venv():
    """Create .venv and install the project with its dev extra if pyproject.toml changed."""
    digest = hashlib.sha256((ROOT / "pyproject.toml").read_bytes()).hexdigest()
    if venv_python().exists() and STAMP.exists() and STAMP.read_text().strip() == digest:
        return
    if not venv_python().exists():
        print("creating", VENV, flush=True)
        venv.EnvBuilder(with_pip=True).create(VENV)
    print("installing the project and its dependencies into .venv (first run takes a few minutes)",
          flush=True)
    subprocess.run([str(venv_python()), "-m", "pip", "install", "--quiet", "-e", str(ROOT) + "[dev]"],
                   check=True)
    STAMP.write_text(digest)


def main(argv):
    if len(argv) != 1 or argv[0] not in ("run", "test"):
        print(__doc__)
        return 2
    ensure_venv()
    py = str(venv_python())
    if argv[0] == "run":
        cmd = [py, "-m", "desktop", "montecarlo", "--flights", "200", "--seed", "1", "--plots", "out"]
    else:
        cmd = [py, "-m", "pytest", "-q"]
    env = dict(os.environ, APOGEE_REQUIRE_MICROPYTHON="1")
    return subprocess.run(cmd, cwd=str(ROOT), env=env).returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
