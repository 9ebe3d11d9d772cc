"""The package as a user installs it: build the wheel, install it (no dependencies) into a fresh
venv that sees the project's environment, and run ``replay`` and ``logdecode`` from another
directory, so that every module a desktop command imports must be in the wheel."""

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import venv
from importlib.metadata import version
from pathlib import Path

import pytest
from packaging.requirements import Requirement

from desktop import __version__
from tests.device.test_device_log import make_log

pytestmark = pytest.mark.slow

ROOT = Path(__file__).parents[2]
FLIGHT = ROOT / "tests" / "data" / "flights" / "altos" / "2012-09-29-serial-341-flight-005.csv"
PACKAGES = ("desktop", "shared", "tools", "device")  # pyproject's [tool.setuptools.packages.find]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
BUILD_REQUIREMENT = Requirement(PYPROJECT["build-system"]["requires"][0])


def run(cmd, cwd, **kw):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    proc = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True, **kw)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-4000:]
    return proc.stdout


def venv_python(path):
    return path / ("Scripts/python.exe" if os.name == "nt" else "bin/python")


def test_wheel_runs_replay_and_logdecode_from_another_directory(tmp_path):
    if not BUILD_REQUIREMENT.specifier.contains(version("setuptools")):
        pytest.skip("this environment's setuptools %s is not the build backend's %s (the locked .venv has it)"
                    % (version("setuptools"), BUILD_REQUIREMENT))
    # the sources a wheel is built from, without caches or build leftovers of the work tree
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    for name in PACKAGES:
        shutil.copytree(ROOT / name, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    dist = tmp_path / "dist"
    run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index", "-w", dist,
         src], cwd=tmp_path)
    (wheel,) = dist.glob("apogee_fc-%s-*.whl" % __version__)

    # --system-site-packages sees the base interpreter's packages; when the project's environment
    # is itself a venv, a .pth line puts its site-packages after the new venv's own
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(system_site_packages=True, with_pip=False).create(env_dir)
    py = venv_python(env_dir)
    purelib = Path(run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                       tmp_path).strip())
    parents = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
    (purelib / "project_environment.pth").write_text("\n".join(sorted(parents)) + "\n")
    run([sys.executable, "-m", "pip", "--python", py, "install", "--no-deps", "--no-index", wheel],
        cwd=tmp_path)

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    where = json.loads(run([py, "-c", "import json, desktop, device.flightlog, shared; print(json.dumps("
                                      "[desktop.__file__, device.flightlog.__file__, shared.__file__]))"],
                           elsewhere))
    assert all(Path(f).is_relative_to(purelib) for f in where), where

    scripts = Path(run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['scripts'])"],
                       tmp_path).strip())
    assert run([scripts / "apogee-fc", "--version"], elsewhere) == "apogee-fc %s\n" % __version__

    replayed = json.loads(run([py, "-m", "desktop", "replay", FLIGHT, "--json"], elsewhere))
    flight_events = [e["event"] for e in replayed["events"] if e["event"] not in ("health", "mode")]
    assert flight_events == ["launch", "burnout", "apogee", "drogue", "main"]

    make_log(elsewhere / "flight.log")
    out = run([scripts / "apogee-fc", "logdecode", "flight.log", "--out", "flight.csv", "--check"], elsewhere)
    assert "replay reproduces the board's decisions" in out
    assert (elsewhere / "flight.csv").exists() and (elsewhere / "flight.config.json").exists()
