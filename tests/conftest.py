"""Shared test fixtures, the guard that MicroPython tests really ran, and the grouping of tests for
the two pytest-xdist workers of tools/dev.py (``-n 2 --dist loadgroup``)."""

import os

import pytest

_micropython_passed = []
# Modules whose tests share a module-level cache (one MicroPython run per interpreter): on one worker,
# so the cache is filled once.
_WHOLE_MODULES = ("tests/device/test_drivers_micropython.py",)


def pytest_configure(config):
    if hasattr(config, "workerinput"):
        config.pluginmanager.register(_GroupsFirst(), "apogee-groups-first")
    config.addinivalue_line("markers", "micropython: runs code on a real MicroPython interpreter")
    config.addinivalue_line("markers", "slow: takes seconds (RocketPy, MicroPython, subprocesses); "
                                       "the fast lane, pytest -m 'not slow', leaves it out")
    config.addinivalue_line("markers", "xdist_group(name): tests that run on the same pytest-xdist worker, "
                                       "in turn (tools/dev.py uses --dist loadgroup)")
    config.addinivalue_line("markers", "arm: runs on MicroPython's qemu port for a Cortex-M0 "
                                       "(tools/armboard.py; needs gcc-arm-none-eabi, "
                                       "libnewlib-arm-none-eabi, qemu-system-arm)")


def pytest_collection_modifyitems(config, items):
    # every MicroPython test starts an interpreter (seconds each): it belongs to the full run
    for item in items:
        if "micropython" in item.keywords:
            item.add_marker(pytest.mark.slow)


def pytest_itemcollected(item):
    _group_for_xdist(item)  # before pytest-xdist reads the marks (its pytest_collection_modifyitems)


class _GroupsFirst:
    """On a pytest-xdist worker: the groups, and their order.

    The collection starts with the ARM group, then the other groups, then the single tests:
    tools/dev.py schedules in collection order (--no-loadscope-reorder). The ARM group (firmware
    builds, then qemu runs, in turn) is the longest chain, so it starts at once on one worker while
    the other works through the rest; the single tests, last, even out the two workers' ends. The
    order within each part is kept.

    With --dist loadgroup, pytest-xdist 3.8 names a test's group by appending "@group" to its node
    id through ``item._nodeid``, which pytest 9.2 no longer reads (it keeps the id in ``item._id``):
    the groups would silently be ignored. The same suffix is set here where pytest 9.2 reads it."""

    @pytest.hookimpl(trylast=True)  # after pytest's own reordering by fixture and pytest-xdist's hook
    def pytest_collection_modifyitems(self, config, items):
        def group(item):
            names = sorted({str(m.args[0] if m.args else m.kwargs.get("name", "default"))
                            for m in item.iter_markers("xdist_group")})
            return "_".join(names) or None

        def rank(item):
            name = group(item)
            return 2 if name is None else 0 if name == "arm" else 1

        items.sort(key=rank)  # stable
        if config.getvalue("loadgroup") and hasattr(items[0] if items else None, "_id"):
            from _pytest.nodeid import coerce_node_id

            for item in items:
                name = group(item)
                if name is not None and not item.nodeid.endswith("@" + name):
                    item._id = coerce_node_id("%s@%s" % (item.nodeid, name))


def _group_for_xdist(item):
    """Keep on one worker what would be computed twice or raced on two: tests that share a module- or
    session-scoped fixture of their own module (a RocketPy flight, a replay) form one group per module,
    as do the modules of _WHOLE_MODULES. A test with an explicit xdist_group mark (tests sharing a
    fixed directory under build/: the ARM firmware builds, tools/deploy.py's staging) keeps it.
    Without pytest-xdist the mark does nothing."""
    if item.get_closest_marker("xdist_group") is not None:
        return
    module = item.nodeid.split("::")[0]
    shared = module in _WHOLE_MODULES
    info = getattr(item, "_fixtureinfo", None)
    for name in (info.names_closure if info is not None else ()):
        for fixturedef in info.name2fixturedefs.get(name, ()):
            if fixturedef.scope in ("module", "package", "session") and fixturedef.baseid == module:
                shared = True
    if shared:
        item.add_marker(pytest.mark.xdist_group(module))


def pytest_runtest_logreport(report):
    if report.when == "call" and report.passed and "micropython" in report.keywords:
        _micropython_passed.append(report.nodeid)


def pytest_sessionfinish(session, exitstatus):
    # tools/dev.py test sets this: a full run in which no MicroPython test passed is a failure,
    # never a silent pass (the interpreters are what prove the board code allocation-free). Under
    # pytest-xdist the controller judges (it receives every worker's reports); a worker that ran
    # none of them is not a failure.
    if hasattr(session.config, "workerinput"):
        return
    if os.environ.get("APOGEE_REQUIRE_MICROPYTHON") == "1" and not _micropython_passed:
        print("\nERROR: no MicroPython test ran and passed; the interpreters are required")
        session.exitstatus = pytest.ExitCode.TESTS_FAILED
