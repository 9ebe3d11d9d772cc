"""Reading the user's input files and checking output paths, with one-line errors.

Every desktop reader (flight CSV, flight log, rocket file, motor file, OpenRocket export,
configuration) reads through ``read_bytes`` or ``read_text``, so a missing file, a directory, an
unreadable file or text that is not UTF-8 gives the same ``InputFileError`` everywhere. Commands
check their output paths with ``check_output_file`` / ``make_output_dir`` before they compute, so
a bad path fails at once and not after a long study.
"""

import os
from pathlib import Path

from desktop.errors import InputFileError, OutputPathError

_UTF16_BOMS = (b"\xff\xfe", b"\xfe\xff")


def read_bytes(path, what="file"):
    """The bytes of ``path``; ``what`` names the kind of file in the error message."""
    p = Path(path)
    try:
        return p.read_bytes()
    except FileNotFoundError:
        raise InputFileError(p, None, "%s not found" % what) from None
    except IsADirectoryError:
        raise InputFileError(p, None, "is a directory, not a %s" % what) from None
    except OSError as exc:
        raise InputFileError(p, None, "cannot read %s: %s" % (what, exc.strerror or exc)) from None


def decode_text(path, data, what="file", fallback_encoding=None):
    """``data`` as text: UTF-8 (a leading byte-order mark dropped), else ``fallback_encoding`` if
    given (undecodable bytes replaced); InputFileError for UTF-16, NUL bytes or invalid UTF-8,
    naming the line."""
    if data[:2] in _UTF16_BOMS:
        raise InputFileError(path, 1, "UTF-16 text; save the file as UTF-8")
    nul = data.find(b"\x00")
    if nul >= 0:
        raise InputFileError(path, data.count(b"\n", 0, nul) + 1,
                             "binary data (NUL byte); not a %s text file" % what)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        if fallback_encoding is not None:
            return data.decode(fallback_encoding, errors="replace")
        line = data.count(b"\n", 0, exc.start) + 1
        raise InputFileError(path, line, "not UTF-8 text (byte 0x%02x at offset %d)" % (
            data[exc.start], exc.start)) from None
    return text[1:] if text.startswith("\ufeff") else text


def read_text(path, what="file", fallback_encoding=None):
    """The text of ``path`` (``read_bytes`` then ``decode_text``)."""
    return decode_text(Path(path), read_bytes(path, what), what, fallback_encoding)


def check_output_file(path, what="file"):
    """Raise OutputPathError unless ``path`` can be written: its folder exists and is writable and
    it is not a directory. Returns ``path`` as a Path."""
    p = Path(path)
    folder = p.parent
    if p.is_dir():
        raise OutputPathError("%s: is a directory, not a %s" % (p, what))
    if not folder.is_dir():
        problem = "is not a folder" if folder.exists() else "does not exist"
        raise OutputPathError("%s: cannot write the %s: folder %s %s" % (p, what, folder, problem))
    if not os.access(folder, os.W_OK) or (p.exists() and not os.access(p, os.W_OK)):
        raise OutputPathError("%s: cannot write the %s: permission denied" % (p, what))
    return p


def make_output_dir(path, what="folder"):
    """Create the folder ``path`` (and its parents) if needed; OutputPathError if that fails or it
    is not writable. Returns it as a Path."""
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise OutputPathError("%s: cannot create the %s: it is a file, not a folder" % (p, what)) from None
    except OSError as exc:
        raise OutputPathError("%s: cannot create the %s: %s" % (p, what, exc.strerror or exc)) from None
    if not os.access(p, os.W_OK):
        raise OutputPathError("%s: cannot write into the %s: permission denied" % (p, what))
    return p
