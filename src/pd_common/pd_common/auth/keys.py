"""Secret keys of a rig or a test: made by the tooling, kept in files only their owner reads.

A key file holds one line, ``pd-hmac-sha256 v1 <64 hex digits>``: a 256-bit secret for
HMAC-SHA256. Its *key id* (16 hex digits, derived from the secret by a one-way hash) names it
in messages and logs; the secret itself never leaves the file and the processes that load it:
it is not a parameter value, not on a topic, not in the bag, not in any log line.

:func:`load_key` refuses a key file that its group or others may read (or write), one that is
not a regular file, or one that belongs to another user: a key that others can read
authenticates nobody.
"""

from __future__ import annotations

import hashlib
import os
import re
import secrets
import stat
from dataclasses import dataclass, field
from pathlib import Path

from .errors import KeyFileError

__all__ = ['KEY_BYTES', 'KEY_FILE_ENV', 'Key', 'default_rig_key', 'generate_key', 'load_key',
           'new_key', 'operator_key_path']

#: Environment variable naming the key file when a node's ``key_file`` parameter is empty.
KEY_FILE_ENV = 'PD_KEY_FILE'

#: Length of a secret, bytes (256 bits, the HMAC-SHA256 block-size class).
KEY_BYTES = 32
#: Fewest distinct byte values a secret must have (a random one has about 30).
MIN_DISTINCT_BYTES = 8
_HEADER = 'pd-hmac-sha256 v1'
_LINE = re.compile(r'^pd-hmac-sha256 v1 ([0-9a-f]{64})\s*$')


@dataclass(frozen=True)
class Key:
    """A secret key and its public id.

    Attributes:
        key_id: 16 hex digits derived from the secret (safe to show and to send).
        secret: the 32-byte secret (never printed: not part of ``repr``).
    """

    key_id: str
    secret: bytes = field(repr=False)

    @classmethod
    def from_secret(cls, secret: bytes) -> Key:
        """The key of ``secret`` (its id derived from it)."""
        if len(secret) != KEY_BYTES:
            msg = f'a key must have {KEY_BYTES} bytes, got {len(secret)}'
            raise KeyFileError(msg)
        if len(set(secret)) < MIN_DISTINCT_BYTES:
            # 32 random bytes have about 30 distinct values; fewer than 8 happens with
            # probability below 1e-25: this is a made-up key (all zeros, a pattern).
            msg = (f'a key must be random: this one has {len(set(secret))} distinct byte '
                   'values in 32 (all zeros, or a pattern?); make one with ./pd keygen')
            raise KeyFileError(msg)
        digest = hashlib.sha256(b'pd key id\x00' + secret).hexdigest()
        return cls(key_id=digest[:16], secret=secret)


def new_key() -> Key:
    """A new random key (in memory only)."""
    return Key.from_secret(secrets.token_bytes(KEY_BYTES))


def generate_key(path: str | Path, *, overwrite: bool = False) -> Key:
    """Create a new key file readable by its owner only (mode 0600; its folder 0700 if new).

    Raises:
        KeyFileError: the file exists (and ``overwrite`` is false) or cannot be written.
    """
    path = Path(path).expanduser()
    key = new_key()
    try:
        if not path.parent.exists():
            path.parent.mkdir(mode=0o700, parents=True)
        if overwrite and path.exists() and not path.is_file():  # a FIFO would block, a device
            msg = f'{path}: not a regular file; a key file is replaced only by a key file'
            raise KeyFileError(msg)
        # (O_NONBLOCK: a FIFO put there meanwhile fails at once instead of waiting for a reader)
        flags = (os.O_WRONLY | os.O_CREAT | os.O_NONBLOCK
                 | (os.O_TRUNC if overwrite else os.O_EXCL))
        descriptor = os.open(path, flags, 0o600)
    except FileExistsError:
        msg = f'{path}: a key file exists already (keep it, or remove it deliberately)'
        raise KeyFileError(msg) from None
    except OSError as err:
        msg = f'{path}: cannot create the key file ({err.strerror})'
        raise KeyFileError(msg) from None
    with os.fdopen(descriptor, 'w', encoding='ascii') as stream:
        os.fchmod(stream.fileno(), 0o600)
        stream.write(f'{_HEADER} {key.secret.hex()}\n')
    return key


def load_key(path: str | Path) -> Key:
    """Read a key file, refusing one that anybody but its owner can read.

    Raises:
        KeyFileError: one line naming the file and what is wrong.
    """
    path = Path(path).expanduser()
    try:
        info = path.stat()
    except FileNotFoundError:
        msg = f'{path}: key file not found (make one with ./pd keygen)'
        raise KeyFileError(msg) from None
    except OSError as err:
        msg = f'{path}: cannot read the key file ({err.strerror})'
        raise KeyFileError(msg) from None
    if not stat.S_ISREG(info.st_mode):
        msg = f'{path}: a key file must be a regular file'
        raise KeyFileError(msg)
    mode = stat.S_IMODE(info.st_mode)
    if mode & 0o077:
        msg = (f'{path}: key file is accessible to group or others (mode {mode:04o}); only its '
               f'owner may read it: chmod 600 {path}')
        raise KeyFileError(msg)
    if info.st_uid != os.getuid():
        msg = f'{path}: key file belongs to another user (uid {info.st_uid})'
        raise KeyFileError(msg)
    try:
        text = path.read_text(encoding='ascii')
    except (OSError, UnicodeDecodeError) as err:
        msg = f'{path}: cannot read the key file ({err})'
        raise KeyFileError(msg) from None
    match = _LINE.match(text.strip())
    if match is None:
        msg = f'{path}: not a key file (expected one line "{_HEADER} <64 hex digits>")'
        raise KeyFileError(msg)
    try:
        return Key.from_secret(bytes.fromhex(match.group(1)))
    except KeyFileError as err:
        msg = f'{path}: {err}'
        raise KeyFileError(msg) from None


def default_rig_key() -> Path:
    """The default path of the rig's key (``./pd keygen`` without ``--out``)."""
    base = os.environ.get('XDG_CONFIG_HOME') or str(Path.home() / '.config')
    return Path(base) / 'pd' / 'keys' / 'rig.key'


def operator_key_path(explicit: str | Path | None = None) -> Path:
    """The key file an operator's tool uses.

    ``explicit``, else ``$PD_KEY_FILE``, else the rig's key (as ``./pd control`` and ``./pd
    console`` find it).
    """
    if explicit:
        return Path(explicit)
    return Path(os.environ.get(KEY_FILE_ENV) or default_rig_key())
