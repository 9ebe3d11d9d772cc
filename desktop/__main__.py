"""Command-line entry point: ``python -m desktop <command> [options]``."""

import sys

from desktop.cli import main

sys.exit(main())
