"""``python -m desktop`` (or ``apogee-fc``): one sub-command per module, each with ``register(subparsers)``.

A command module's ``register`` adds its sub-parser and sets ``func`` to a callable taking the
parsed arguments and returning an exit status. Command modules import only the standard library,
numpy and the project's light modules at import time (scipy, matplotlib and RocketPy inside the
functions that use them), so ``--help`` answers at once; tests/desktop/test_cli.py checks it.

Errors the user can fix (``desktop.errors.DesktopError`` and ``shared.config.ConfigError``) are
reported here, once: ``error: <message>`` on one line on stderr, exit status 2.
"""

import argparse
import importlib
import os
import sys

from desktop import __version__
from desktop.errors import DesktopError
from shared.config import ConfigError

# (command name, module defining it); the module's register() adds the sub-parser.
COMMANDS = (
    ("montecarlo", "desktop.study.montecarlo_cli"),
    ("replay", "desktop.review.replay"),
    ("simulate", "desktop.sim.simulate"),
    ("logdecode", "desktop.io.logdecode"),
    ("import", "desktop.io.importers"),
    ("sil", "desktop.hosts.sil.command"),
)
EXIT_USER_ERROR = 2
# Output cut short by the reader (``| head``): Python's documented way out (signal module, "Note
# on SIGPIPE"): stdout onto /dev/null so that the final flush cannot fail again, and status 1.
EXIT_BROKEN_PIPE = 1


def build_parser():
    parser = argparse.ArgumentParser(
        prog="python -m desktop",
        description="Desktop tools of the flight computer: simulate flights, replay logs through the "
                    "exact board code, and compare apogee detectors.",
    )
    parser.add_argument("--version", action="version", version="apogee-fc %s" % __version__)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for _name, module in COMMANDS:
        importlib.import_module(module).register(sub)
    return parser


def main(argv=None):
    """Run one command; ``argv`` defaults to the process's arguments. Returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        status = args.func(args)
        sys.stdout.flush()
    except (DesktopError, ConfigError) as exc:
        print("error: %s" % exc, file=sys.stderr)
        return EXIT_USER_ERROR
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    return status
