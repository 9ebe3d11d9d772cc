"""Set up the project's virtual environment and run the main job or the test suite.

Usage (from the repository root, with Python >= 3.11 and git; nothing else):

    python3 tools/dev.py run     # set up .venv, run the 200-flight seed study, write plots to out/
    python3 tools/dev.py test    # set up .venv, run every test (MicroPython interpreters included)
    python3 tools/dev.py fast    # the fast lane while developing: pytest -m "not slow" (about a minute)

Both test commands run pytest on two pytest-xdist workers (``-n 2 --dist loadgroup``: tests that
share a build directory or an expensive module fixture stay on one worker, tests/conftest.py).

The environment gets the exact versions in requirements.lock (with their hashes, by plain pip),
then the project itself (editable, without dependencies). It is reinstalled only when
requirements.lock or pyproject.toml changed since the last install. To change or upgrade a
dependency: edit pyproject.toml if needed, then ``python3 tools/lock.py [--upgrade]``.
"""

import hashlib
import os
import subprocess
import sys
import venv
from pathlib import Path

MIN_PYTHON = (3, 11)
ROOT = Path(__file__).resolve().parent.parent
VENV = ROOT / ".venv"
LOCK = ROOT / "requirements.lock"
PYPROJECT = ROOT / "pyproject.toml"
STAMP = VENV / ".installed-sha256"


def venv_python():
    sub = "Scripts/python.exe" if os.name == "nt" else "bin/python"
    return VENV / sub


def environment_digest():
    """SHA-256 of what the environment is installed from: the lock and pyproject.toml."""
    h = hashlib.sha256()
    for path in (LOCK, PYPROJECT):
        h.update(path.read_bytes())
    return h.hexdigest()


def pip(*args):
    subprocess.run([str(venv_python()), "-m", "pip", "--disable-pip-version-check", *args], check=True)


def ensure_venv():
    """Create .venv and install the locked dependencies and the project if the lock or
    pyproject.toml changed since the last install."""
    digest = environment_digest()
    if venv_python().exists() and STAMP.exists() and STAMP.read_text().strip() == digest:
        return
    if not venv_python().exists():
        print("creating", VENV, flush=True)
        venv.EnvBuilder(with_pip=True).create(VENV)
    print("installing the locked dependencies (requirements.lock) and the project into .venv "
          "(the first run takes a few minutes)", flush=True)
    STAMP.unlink(missing_ok=True)
    pip("install", "--quiet", "--require-hashes", "-r", str(LOCK))
    pip("install", "--quiet", "--no-deps", "-e", str(ROOT))
    STAMP.write_text(digest)


# two workers (CI's two cores); loadgroup keeps each xdist_group on one worker, and the work goes
# out in the order tests/conftest.py gives (the ARM builds first)
PYTEST = ("-m", "pytest", "-q", "-n", "2", "--dist", "loadgroup", "--no-loadscope-reorder")


def main(argv):
    if sys.version_info < MIN_PYTHON:
        print("error: this project needs Python >= %d.%d (this is %d.%d: %s); run tools/dev.py with a newer "
              "python3" % (*MIN_PYTHON, *sys.version_info[:2], sys.executable), file=sys.stderr)
        return 2
    if len(argv) != 1 or argv[0] not in ("run", "test", "fast"):
        print(__doc__)
        return 2
    ensure_venv()
    py = str(venv_python())
    if argv[0] == "run":
        cmd = [py, "-m", "desktop", "montecarlo", "--flights", "200", "--seed", "1", "--plots", "out"]
    elif argv[0] == "fast":
        # the development lane: no RocketPy flights, MicroPython interpreters or subprocesses
        return subprocess.run([py, *PYTEST, "-m", "not slow"], cwd=str(ROOT)).returncode
    else:
        cmd = [py, *PYTEST]
    env = dict(os.environ, APOGEE_REQUIRE_MICROPYTHON="1")
    return subprocess.run(cmd, cwd=str(ROOT), env=env).returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
