"""requirements.lock agrees with pyproject.toml: every dependency and dev extra is locked, at a
version its specifier allows, once, with hashes, for the Python floor the project states."""

import re
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name
from packaging.version import Version

from tools import dev, lock

ROOT = Path(__file__).parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
LOCK_TEXT = (ROOT / "requirements.lock").read_text(encoding="utf-8")
# a pin line: name==version, an optional environment marker, then the hash continuation
_PIN_RE = re.compile(r"^([A-Za-z0-9][A-Za-z0-9._-]*)==([^\s;\\]+)\s*(?:;\s*([^\\]*?))?\s*\\$", re.MULTILINE)


def locked_pins():
    """[(canonical name, Version, marker or None)] in lock order."""
    return [(canonicalize_name(name), Version(version), marker)
            for name, version, marker in _PIN_RE.findall(LOCK_TEXT)]


def declared_requirements():
    project = PYPROJECT["project"]
    return [Requirement(text) for text in project["dependencies"] + project["optional-dependencies"]["dev"]]


def test_every_pinned_line_of_the_lock_is_parsed():
    pins = locked_pins()
    assert len(pins) >= len(declared_requirements())
    # every "name==" line of the lock was understood
    assert len(pins) == len(re.findall(r"^[A-Za-z0-9][A-Za-z0-9._-]*==", LOCK_TEXT, re.MULTILINE))


@pytest.mark.parametrize("requirement", declared_requirements(), ids=str)
def test_every_declared_dependency_is_locked_at_a_version_it_allows(requirement):
    versions = [v for name, v, _marker in locked_pins() if name == canonicalize_name(requirement.name)]
    assert versions, "%s is in pyproject.toml but not in requirements.lock: run python3 tools/lock.py" % (
        requirement.name)
    for version in versions:
        assert requirement.specifier.contains(version, prereleases=True), (
            "requirements.lock pins %s==%s, outside pyproject.toml's %s: run python3 tools/lock.py"
            % (requirement.name, version, requirement.specifier))


def test_one_version_per_package():
    # the versions the tests pass with here are the ones every machine installs
    names = [name for name, _v, _marker in locked_pins()]
    assert len(names) == len(set(names)), sorted({n for n in names if names.count(n) > 1})


def test_every_pin_has_hashes():
    blocks = re.split(r"\n(?=[A-Za-z0-9])", LOCK_TEXT.split("\n", 2)[2])
    for block in blocks:
        assert "--hash=sha256:" in block, block.splitlines()[0]


def test_lock_command_and_python_floor_agree():
    floor = "%d.%d" % dev.MIN_PYTHON
    assert PYPROJECT["project"]["requires-python"] == ">=" + floor
    assert PYPROJECT["tool"]["ruff"]["target-version"] == "py" + floor.replace(".", "")
    assert lock.PYTHON_FLOOR == floor
    assert LOCK_TEXT.splitlines()[1] == "#    python3 tools/lock.py"
    assert sys.version_info >= dev.MIN_PYTHON


def test_dev_refuses_an_old_python_in_one_line(monkeypatch, capsys):
    monkeypatch.setattr(sys, "version_info", (3, 10, 14, "final", 0))
    assert dev.main(["test"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: this project needs Python >= 3.11 (this is 3.10") and err.count("\n") == 1
