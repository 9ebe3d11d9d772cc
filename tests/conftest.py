"""Shared test fixtures and the guard that MicroPython tests really ran."""

import os

import pytest

_micropython_passed = []


def pytest_configure(config):
    config.addinivalue_line("markers", "micropython: runs code on a real MicroPython interpreter")
    config.addinivalue_line("markers", "slow: takes seconds (RocketPy, MicroPython, subprocesses); "
                                       "the fast lane, pytest -m 'not slow', leaves it out")
    config.addinivalue_line("markers", "arm: runs on MicroPython's qemu port for a Cortex-M0 "
                                       "(tools/armboard.py; needs gcc-arm-none-eabi, "
                                       "libnewlib-arm-none-eabi, qemu-system-arm)")


def pytest_collection_modifyitems(config, items):
    # every MicroPython test starts an interpreter (seconds each): it belongs to the full run
    for item in items:
        if "micropython" in item.keywords:
            item.add_marker(pytest.mark.slow)


def pytest_runtest_logreport(report):
    if report.when == "call" and report.passed and "micropython" in report.keywords:
        _micropython_passed.append(report.nodeid)


def pytest_sessionfinish(session, exitstatus):
    # tools/dev.py test sets this: a full run in which no MicroPython test passed is a failure,
    # never a silent pass (the interpreters are what prove the board code allocation-free).
    if os.environ.get("APOGEE_REQUIRE_MICROPYTHON") == "1" and not _micropython_passed:
        print("\nERROR: no MicroPython test ran and passed; the interpreters are required")
        session.exitstatus = pytest.ExitCode.TESTS_FAILED
