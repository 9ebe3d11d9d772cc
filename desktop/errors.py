"""The desktop's errors: problems the user can fix, each shown by the CLI as one line and exit status 2.

``desktop/cli.py`` catches ``DesktopError`` (and ``shared.config.ConfigError``, the configuration's
own error, which stays in shared/ because the board raises it too) in one place. Every reader's
error derives from ``DesktopError``: ``FlightCSVError``, ``RocketFileError``, ``OpenRocketError``,
``LogDecodeError``, ``SensorProfileError``, ``TrajectoryError``; an error whose cause is a bug is
any other exception, and keeps its traceback.
"""


class DesktopError(Exception):
    """A problem with the user's input or options; the message is one line naming it."""


class UsageError(DesktopError):
    """An option out of its range, or options that do not go together."""


class InputFileError(DesktopError):
    """An input file that cannot be read: missing, a directory, unreadable, binary or not UTF-8.

    ``path`` and ``line`` (None when the problem is not on one line) name where."""

    def __init__(self, path, line, problem):
        self.path = str(path)
        self.line = line
        self.problem = problem
        where = self.path if line is None else "%s:%d" % (self.path, line)
        super().__init__("%s: %s" % (where, problem))


class OutputPathError(DesktopError):
    """An output file or folder that cannot be written: missing folder, not writable, a directory."""
