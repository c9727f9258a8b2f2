"""Reading one configuration document: the file, its YAML, a mapping; refusals of one line.

The first half of every typed reader (a test file, the bridge's parameter file, a driver's
settings file): :func:`read_document` reads the file (a regular one, bounded, UTF-8, see
:mod:`.files`) and its YAML (:func:`~.loader.load_yaml`) and checks that it is a mapping; the
schema then types it. A file that cannot be read or is no mapping is one
:class:`~.schema_base.SchemaError`::

    /rig/daqmx.yaml: cannot read the driver settings (No such file or directory)
    daqmx.yaml: line 3: found a key given twice, 'timeout'
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .files import MAX_TEXT_BYTES, read_text
from .loader import YAMLError, load_yaml, yaml_problem
from .schema_base import SchemaError

__all__ = ['read_document']


def read_document(path: str | Path, *, what: str) -> dict[str, Any]:
    """The parsed YAML of the file ``path``, a mapping (an empty file: an empty mapping).

    Args:
        path: the file.
        what: what the file is, for messages (``'test file'``, ``'driver settings'``).

    Raises:
        SchemaError: the file cannot be read (missing, not a regular file, too large, not
            UTF-8: ``<path>: cannot read the <what> (<reason>)``), is not YAML
            (``<name>: line N: <problem>``) or not a mapping (``<name>: a <what> must be a
            mapping ..., got <type>``).
    """
    path = Path(path)
    try:
        text = read_text(path, limit=MAX_TEXT_BYTES, what=f'a {what}')
    except OSError as err:  # (also not a regular file, too large, not UTF-8: InputFileError)
        reason = f'cannot read the {what} ({err.strerror or type(err).__name__})'
        raise SchemaError(str(path), '', reason) from None
    try:
        data = load_yaml(text)
    except YAMLError as err:
        raise SchemaError(path.name, '', yaml_problem(err)) from None
    data = {} if data is None else data
    if not isinstance(data, dict):
        reason = f'a {what} must be a mapping of sections, got {type(data).__name__}'
        raise SchemaError(path.name, '', reason)
    return data
