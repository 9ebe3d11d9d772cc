"""A flight configuration file (JSON, docs/CONFIG.md) as the desktop commands read it."""

import json

from desktop.io.files import read_text
from shared.config import ConfigError


def config_file_values(path):
    """The settings in the configuration file ``path`` (a JSON object), not yet validated
    (``shared.config.load_config`` does that): InputFileError if it cannot be read as text,
    ConfigError if it is not a JSON object."""
    try:
        values = json.loads(read_text(path, "configuration file"))
    except ValueError as exc:
        raise ConfigError("config: %s is not valid JSON: %s" % (path, exc)) from None
    if not isinstance(values, dict):
        raise ConfigError("config: %s: expected a JSON object of settings, got %s" % (
            path, type(values).__name__))
    return values
