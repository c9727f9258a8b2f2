"""Bounds on what arrives from the wire: every string and array a node takes has a limit.

Any process on the domain can publish, and DDS delivers a megabyte string as readily as a
short one. So a message whose fields exceed these bounds is *malformed*: the conversions of
:mod:`.convert` refuse it (:class:`MalformedMessageError`) before anything is verified, logged,
recorded or obeyed. The one open channel, the emergency stop, is never refused: its reason is
cut to :data:`MAX_REASON` characters (:func:`clip_reason`) and its repeats are counted, not
logged or recorded one by one.
"""

from __future__ import annotations

from collections.abc import Iterable, Sized

__all__ = ['MAX_ARRAY', 'MAX_NAME', 'MAX_REASON', 'MAX_TEXT', 'MalformedMessageError',
           'check_array', 'check_names', 'check_text', 'clip_reason', 'one_line']

#: Characters of an operator's reason (a control's, an emergency stop's).
MAX_REASON = 256
#: Characters of an id, a name, a session, a key id, a node name, a command.
MAX_NAME = 256
#: Characters of a status or feedback message, a configuration.
MAX_TEXT = 8192
#: Entries of one array of a step message (DOFs of one site).
MAX_ARRAY = 4096


class MalformedMessageError(ValueError):
    """A message from the wire exceeds a bound (refused as ``malformed``)."""


def check_text(field: str, value: str, limit: int) -> str:
    """``value`` if it has at most ``limit`` characters.

    Raises:
        MalformedMessageError: it is longer (one line naming the field).
    """
    if len(value) > limit:
        msg = f'{field}: {len(value)} characters (at most {limit})'
        raise MalformedMessageError(msg)
    return value


def check_array(field: str, value: Sized, limit: int = MAX_ARRAY) -> None:
    """Refuse an array of more than ``limit`` entries.

    Raises:
        MalformedMessageError: it is longer.
    """
    if len(value) > limit:
        msg = f'{field}: {len(value)} entries (at most {limit})'
        raise MalformedMessageError(msg)


def check_names(field: str, values: Iterable[str], limit: int = MAX_NAME) -> None:
    """Refuse a list of names with too many entries or an over-long one.

    Raises:
        MalformedMessageError: a bound is exceeded.
    """
    names = list(values)
    check_array(field, names)
    for name in names:
        check_text(field, name, limit)


def one_line(text: str) -> str:
    """``text`` on one line.

    Control characters and line breaks become spaces, runs of whitespace one space (a reason cannot
    forge log lines).
    """
    return ' '.join(''.join(ch if ch.isprintable() else ' ' for ch in text).split())


def clip_reason(text: str, limit: int = MAX_REASON) -> str:
    """An open channel's free text made safe to log and record.

    On one line, at most ``limit`` characters (cut ones are marked ``…``).
    """
    if len(text) > 4 * limit:  # never walk a megabyte string character by character
        text = text[:4 * limit]
    line = one_line(text)
    return line if len(line) <= limit else line[:limit - 1] + '…'
