"""``python -m desktop``: one sub-command per module, each exposing ``register(subparsers)``.

A command module's ``register`` adds its sub-parser and sets ``func`` to a callable taking the
parsed arguments and returning an exit status. Modules are imported only when listed here, so a
slow import (RocketPy) costs nothing to the other commands until they need it.
"""

import argparse
import importlib

# (command name, module defining it); the module's register() adds the sub-parser.
COMMANDS = (
    ("montecarlo", "desktop.study.seed_study"),
    ("replay", "desktop.review.replay"),
    ("simulate", "desktop.sim.simulate"),
    ("logdecode", "desktop.io.logdecode"),
    ("import", "desktop.io.importers"),
    ("sil", "desktop.hosts.sil.command"),
)


def build_parser():
    parser = argparse.ArgumentParser(
        prog="python -m desktop",
        description="Desktop tools of the flight computer: simulate flights, replay logs through the "
                    "exact board code, and compare apogee detectors.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for _name, module in COMMANDS:
        importlib.import_module(module).register(sub)
    return parser


def main(argv):
    parser = build_parser()
    args = parser.parse_args(argv)
    return args.func(args)
