"""Opening the files a user names: regular files only, of a bounded size, as UTF-8 text.

Every command reads files it is given (a test file, a ground-motion record, a run's journal
or launch plan). Whatever the name points to, reading it must end, fast, with the file or one
line about it: a FIFO would block the reader forever, ``/dev/zero`` or ``/dev/urandom`` never
end, a directory or a socket is no file at all, and a regular file of gigabytes is not a test
file. :func:`open_regular_file` opens without blocking (``O_NONBLOCK``: a FIFO with no writer
does not wait for one) and checks the opened file itself (``fstat``: no race with a rename);
:func:`read_bytes` and :func:`read_text` read at most ``limit`` bytes.

Every refusal is an :class:`InputFileError`, an :class:`OSError` whose ``str()`` is one line
naming the file, e.g. ``/dev/zero: not a regular file but a character device``; its
``strerror`` is the reason alone (for messages that name the file their own way).
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path
from typing import BinaryIO

__all__ = ['MAX_TEXT_BYTES', 'InputFileError', 'describe_size', 'existing_path',
           'open_regular_file', 'read_bytes', 'read_text']

#: The largest configuration file read (a test file, a bridge's parameters, a launch plan):
#: 4 MiB. PyYAML's (pure Python) loader reads about 0.5 MB/s, so the largest file takes
#: seconds, not minutes; a test file with an inline record of 300,000 samples fits.
MAX_TEXT_BYTES = 4 * 2**20

#: What a file that is not a regular one is, by its ``st_mode`` type.
_KINDS = ((stat.S_ISDIR, 'a directory'), (stat.S_ISFIFO, 'a FIFO'),
          (stat.S_ISCHR, 'a character device'), (stat.S_ISBLK, 'a block device'),
          (stat.S_ISSOCK, 'a socket'))


class InputFileError(OSError):
    """A file that cannot be read as an input: not a regular file, too large, or not UTF-8.

    ``str()`` is ``<file>: <reason>`` (one line); ``strerror`` is the reason and ``filename``
    the file, as for an :class:`OSError` of the system.
    """

    def __init__(self, path: str | os.PathLike[str], reason: str) -> None:
        super().__init__(errno.EINVAL, reason, os.fspath(path))

    def __str__(self) -> str:
        """The file name and the reason, on one line."""
        return f'{self.filename}: {self.strerror}'


def describe_size(size: int) -> str:
    """A size in bytes for a message: ``5.2 GiB``, ``4 MiB``, ``812 KiB``, ``12 bytes``."""
    for unit, factor in (('GiB', 2**30), ('MiB', 2**20), ('KiB', 2**10)):
        if size >= factor:
            return f'{size / factor:.3g} {unit}'
    return f'{size} bytes'


def existing_path(path: str | os.PathLike[str]) -> Path:
    """``path`` made absolute with every symbolic link resolved; it must exist.

    Raises:
        InputFileError: a symbolic link loop (``Path.resolve`` raises ``RuntimeError`` for
            one before Python 3.13).
        OSError: it does not exist (or cannot be looked up).
    """
    try:
        return Path(path).resolve(strict=True)
    except RuntimeError:
        raise InputFileError(path, 'a symbolic link loop') from None
    except OSError as err:
        if err.errno == errno.ELOOP:
            raise InputFileError(path, 'a symbolic link loop') from None
        raise


def open_regular_file(path: str | os.PathLike[str]) -> BinaryIO:
    """Open ``path`` for reading in binary mode if it is a regular file (symbolic links followed).

    Without blocking on a FIFO.

    Raises:
        InputFileError: it is a directory, a FIFO, a device or a socket.
        OSError: it cannot be opened (missing, no permission, a symbolic link loop, ...).
    """
    descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        mode = os.fstat(descriptor).st_mode
        if not stat.S_ISREG(mode):
            kind = next((name for test, name in _KINDS if test(mode)), 'a special file')
            raise InputFileError(path, f'not a regular file but {kind}')
        os.set_blocking(descriptor, True)
        return os.fdopen(descriptor, 'rb')
    except BaseException:
        os.close(descriptor)
        raise


def read_bytes(path: str | os.PathLike[str], *, limit: int = MAX_TEXT_BYTES,
               what: str = 'a file') -> bytes:
    """The content of the regular file ``path``, at most ``limit`` bytes.

    Args:
        path: the file.
        limit: the most bytes read; a larger file is refused before it is read.
        what: what the file is, for the message (``'a test file'``).

    Raises:
        InputFileError: not a regular file, or larger than ``limit``.
        OSError: it cannot be opened or read.
    """
    with open_regular_file(path) as file:
        size = os.fstat(file.fileno()).st_size
        data = file.read(limit + 1) if size <= limit else b''
    if size > limit or len(data) > limit:
        reason = (f'{describe_size(max(size, len(data)))}, more than the '
                  f'{describe_size(limit)} {what} may have')
        raise InputFileError(path, reason)
    return data


def read_text(path: str | os.PathLike[str], *, limit: int = MAX_TEXT_BYTES,
              what: str = 'a file', encoding: str = 'utf-8') -> str:
    """The text of the regular file ``path`` (UTF-8), at most ``limit`` bytes.

    Raises:
        InputFileError: not a regular file, larger than ``limit``, or not UTF-8 text (the
            reason names the first bad byte and its line).
        OSError: it cannot be opened or read.
    """
    data = read_bytes(path, limit=limit, what=what)
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as err:
        line = data.count(b'\n', 0, err.start) + 1
        reason = (f'line {line}: not UTF-8 text, byte 0x{data[err.start]:02x} at offset '
                  f'{err.start}')
        raise InputFileError(path, reason) from None
