"""Ground-motion record files: the readers of each layout and the dispatcher.

The readers accept the layouts the thesis's MATLAB code reads (Appendix A, lines 28–60) and the
PEER NGA ``.AT2`` format:

- two columns, time and acceleration (comma or whitespace separated);
- a single column of accelerations (the time step is given separately);
- several accelerations per row, read across each row and then down (row-major), the layout
  the MATLAB code flattens with its nested ``rr``/``cc`` loops;
- PEER NGA ``.AT2``: four header lines, ``NPTS`` and ``DT`` on line 4, values in g;
- MATLAB ``.mat`` (v4–v7, :func:`scipy.io.loadmat`): a 2×N array with rows [time;
  acceleration] or an N×2 one with those columns, the layout of the vRTHS benchmark's records
  (in m/s²: pass ``units='m/s2'``).

Every value must be a well-formed decimal number (optional sign, digits with an optional point,
an optional exponent ``E``/``D`` with its digits): ``1.2E-`` is refused, never read as something
else, and in an AT2 file, which a program writes in Fortran's ``E`` format, an exponent has at
least two digits (``-.1790158E-0`` is the start of ``-.1790158E-02`` in a cut file).

:func:`read_ground_motion` picks the reader from the format (or the file). Records in g are
converted with ``g = 9.81`` m/s² by default, the value hard-coded in the thesis's MATLAB code,
so that results can be compared with it; pass ``g=G_STANDARD`` for the standard gravity.

Every reader returns a :class:`~.ground_motion.GroundMotion` and raises
:class:`~pd_core.errors.GroundMotionError` with a one-line message naming the file
(and the line, when one is to blame).
"""

from __future__ import annotations

import io
import math
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Union

import numpy as np

from pd_common.config import read_bytes

from ..errors import GroundMotionError
from .ground_motion import G_THESIS, GroundMotion, dt_close

__all__ = [
    'FORMATS',
    'MAX_RECORD_BYTES',
    'UNITS',
    'read_at2',
    'read_ground_motion',
    'read_mat',
    'read_multi_column',
    'read_single_column',
    'read_two_column',
]

FORMATS = ('auto', 'two_column', 'single_column', 'multi_column', 'at2', 'mat')
"""Values accepted by ``read_ground_motion(format=...)``."""

UNITS = ('g', 'm/s2', 'm/s^2')
"""Values accepted by the ``units`` argument of the readers."""

MAX_RECORD_BYTES = 32 * 2**20
"""The largest record file read (a million samples of time and acceleration are about 25 MB;
the text readers take some 6 s for the largest). Only regular files are read: a FIFO or a
device (``/dev/zero``) is refused before anything is read."""

PathLike = Union[str, 'os.PathLike[str]']

_NUMBER_RE = re.compile(r'[+-]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][+-]?\d+)?', re.ASCII)
# An AT2 value: written by a program in Fortran's E format, its exponent has two digits or more.
_AT2_NUMBER_RE = re.compile(r'[+-]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][+-]?\d{2,})?', re.ASCII)
# The parts of a number: the digits after the point and the exponent's digits.
_NUMBER_PARTS_RE = re.compile(r'[+-]?\d*(?:\.(\d*))?(?:[eEdD][+-]?(\d+))?', re.ASCII)
# A number cut short or with a dangling exponent ('1.2E-', '-.'): data, not a header word.
_CUT_NUMBER_RE = re.compile(r'[+-]?(?:\d+\.?\d*|\.\d*)(?:[eEdD][+-]?\d*)?', re.ASCII)
_NON_FINITE_RE = re.compile(r'[+-]?(?:nan|inf|infinity)', re.IGNORECASE)
_FIELD_SPLIT_RE = re.compile(r'\s*,\s*|\s+')
_AT2_NPTS_RE = re.compile(r'\bNPTS\s*=\s*([^\s,]+)', re.IGNORECASE)
# DT and its unit word, if any (a word followed by '=' is the next key, not a unit).
_AT2_DT_RE = re.compile(r'\bDT\s*=\s*([^\s,]+)(?:[ \t]+([A-Za-z]+)\b(?![ \t]*=))?',
                        re.IGNORECASE)
#: Seconds per unit of the time step on line 4 of an AT2 file (no unit: seconds).
_AT2_DT_UNITS = {'SEC': 1, 'SECS': 1, 'S': 1, 'SECOND': 1, 'SECONDS': 1,
                 'MSEC': 1000, 'MSECS': 1000, 'MS': 1000}
_AT2_OLD_RE = re.compile(r'^\s*([^\s,]+)\s*,?\s+([^\s,]+)\s+NPTS\s*,?\s*DT\b', re.IGNORECASE)


# ---------------------------------------------------------------------- public readers


def read_two_column(path: PathLike, *, units: str = 'g', g: float = G_THESIS) -> GroundMotion:
    """Read a two-column file of time and acceleration.

    Columns are separated by commas and/or whitespace. Blank lines and lines starting with
    ``#`` are skipped, and one non-numeric header line (e.g. ``time,accel``) is allowed before
    the data. The time may start at any value (it is shifted to 0) but must be uniform:
    ``dt = t[1] - t[0]`` (rounded to 12 significant digits to drop decimal-to-binary noise) and
    every step must satisfy ``|t[i+1] - t[i] - dt| <= 1e-6 dt + 1e-9``.

    Args:
        path: The file.
        units: Acceleration units in the file: ``'g'`` or ``'m/s2'`` (``'m/s^2'``).
        g: Gravity in m/s² used to convert g; 9.81 by default, as in the thesis's MATLAB.

    Returns:
        The record in m/s², ``source`` the file name.

    Raises:
        GroundMotionError: If the file cannot be read or is not a valid two-column record.
    """
    scale = _unit_scale(path, units, g)
    label, lines = _load_lines(path)
    rows = _parse_table(label, lines)
    return _build_two_column(path, label, rows, scale)


def read_single_column(
    path: PathLike, *, dt: float, units: str = 'g', g: float = G_THESIS
) -> GroundMotion:
    """Read a file with one acceleration value per line.

    Blank lines, ``#`` comment lines and one non-numeric header line are allowed.

    Args:
        path: The file.
        dt: Time step in s (not stored in the file).
        units: Acceleration units in the file: ``'g'`` or ``'m/s2'`` (``'m/s^2'``).
        g: Gravity in m/s² used to convert g; 9.81 by default, as in the thesis's MATLAB.

    Returns:
        The record in m/s², ``source`` the file name.

    Raises:
        GroundMotionError: If the file cannot be read, a line holds more than one value, or
            ``dt`` is invalid.
    """
    scale = _unit_scale(path, units, g)
    dt = _check_dt(path, dt)
    label, lines = _load_lines(path)
    rows = _parse_table(label, lines)
    return _build_single_column(path, label, rows, dt, scale)


def read_multi_column(
    path: PathLike, *, dt: float, units: str = 'g', g: float = G_THESIS
) -> GroundMotion:
    """Read a file with several acceleration values per row, read across then down.

    This is the row-major layout the thesis's MATLAB code flattens (Appendix A, lines 35–41).
    Every row must hold as many values as the first one, except the last, which may be
    shorter. Blank lines, ``#`` comment lines and one non-numeric header line are allowed.

    Args:
        path: The file.
        dt: Time step in s (not stored in the file).
        units: Acceleration units in the file: ``'g'`` or ``'m/s2'`` (``'m/s^2'``).
        g: Gravity in m/s² used to convert g; 9.81 by default, as in the thesis's MATLAB.

    Returns:
        The record in m/s², ``source`` the file name.

    Raises:
        GroundMotionError: If the file cannot be read, a row other than the last is ragged, or
            ``dt`` is invalid.
    """
    scale = _unit_scale(path, units, g)
    dt = _check_dt(path, dt)
    label, lines = _load_lines(path)
    rows = _parse_table(label, lines)
    return _build_multi_column(path, label, rows, dt, scale)


def read_at2(path: PathLike, *, g: float = G_THESIS) -> GroundMotion:
    """Read a PEER NGA ``.AT2`` acceleration file (values in g).

    Lines 1–3 are free text. Line 4 holds the number of points and the time step, in any of
    the forms ``NPTS=  4000, DT=   .0050 SEC``, ``npts= 4000 dt= 0.005 sec`` or the older
    ``4000    0.00500    NPTS, DT``. NPTS is an integer (``5372.0`` is read as 5372); DT is
    in seconds, or in milliseconds with the unit ``MSEC`` (``DT= 10 MSEC`` is 0.010 s); any
    other unit word is refused. The values follow, several per line, read across each line and
    then down; their count must equal NPTS.

    A file that does not end with a line end may have been cut: its last value must then be
    written like the one before it (an exponent of as many digits, as many digits after the
    point), or the file is refused (``-.1790158`` after ``.2339013E-02`` is what is left of
    ``-.1790158E-02``).

    Args:
        path: The file.
        g: Gravity in m/s² used to convert g; 9.81 by default, as in the thesis's MATLAB.

    Returns:
        The record in m/s², ``source`` the file name.

    Raises:
        GroundMotionError: If the header is missing or unparseable, a value is not a
            well-formed number or not finite, the file looks cut short, or the number of values
            differs from NPTS.
    """
    scale = _unit_scale(path, 'g', g)
    label, text = _load_text(path)
    _npts, dt, values = _parse_at2(label, text.splitlines(),
                                   ends_with_line_end=text.endswith(('\n', '\r')))
    return _make(path, dt, values * scale)


def read_mat(path: PathLike, *, units: str = 'm/s2', g: float = G_THESIS,
             variable: str | None = None) -> GroundMotion:
    """Read a MATLAB ``.mat`` record: time and acceleration as a 2×N (rows) or N×2 (columns) array.

    The vRTHS benchmark's records (``ElCentroAccelNoScaling.mat`` etc.) hold one such 2×N
    array in m/s², the units' default here. The array is ``variable`` or, if not given, the
    only real numeric array of the file with 2 rows or 2 columns (a 2×2 array is read as
    rows). The time may start at any value (shifted to 0) but must be uniform, as for
    :func:`read_two_column`.

    Args:
        path: The file (MATLAB v4–v7; v7.3/HDF5 files are refused: save with ``-v7``).
        units: Acceleration units in the file: ``'g'`` or ``'m/s2'`` (``'m/s^2'``).
        g: Gravity in m/s² used to convert g.
        variable: The name of the array in the file (optional).

    Returns:
        The record in m/s², ``source`` the file name.

    Raises:
        GroundMotionError: If the file cannot be read, no single (or the named) array is a
            record, or its time is not uniform and increasing.
    """
    scale = _unit_scale(path, units, g)
    label = _label(path)
    from scipy import io as scipy_io  # noqa: PLC0415 - only .mat files need it

    data_bytes = _read_file(path, label)
    try:
        content = scipy_io.loadmat(io.BytesIO(data_bytes))
    except NotImplementedError:
        msg = f'ground motion {label}: MATLAB v7.3 (HDF5) files are not supported; save with -v7'
        raise GroundMotionError(msg) from None
    except (OSError, ValueError, TypeError, scipy_io.matlab.MatReadError) as exc:
        msg = f'ground motion {label}: cannot read MATLAB file: {exc}'
        raise GroundMotionError(msg) from exc
    arrays = {name: value for name, value in content.items()
              if not name.startswith('__') and isinstance(value, np.ndarray)
              and value.dtype.kind in 'iuf' and value.ndim == 2 and 2 in value.shape}
    if variable is not None:
        if variable not in arrays:
            msg = (f'ground motion {label}: no 2-row or 2-column numeric array {variable!r} in '
                   f'the file (found: {", ".join(sorted(arrays)) or "none"})')
            raise GroundMotionError(msg)
        name = variable
    elif len(arrays) == 1:
        name = next(iter(arrays))
    else:
        found = ', '.join(sorted(arrays)) or 'none'
        msg = (f'ground motion {label}: expected one 2-row or 2-column numeric array '
               f'(time, acceleration), found: {found}; name it with variable=...')
        raise GroundMotionError(msg)
    data = np.asarray(arrays[name], dtype=np.float64)
    data = data if data.shape[0] == 2 else data.T
    time, acc = data[0], data[1]
    if time.size < 2:
        msg = f'ground motion {label}: {name}: need at least 2 samples, found {time.size}'
        raise GroundMotionError(msg)
    if not (np.all(np.isfinite(time)) and np.all(np.isfinite(acc))):
        msg = f'ground motion {label}: {name}: non-finite value'
        raise GroundMotionError(msg)
    raw_dt = float(time[1] - time[0])
    if not raw_dt > 0.0:
        msg = (f'ground motion {label}: {name}: time must increase, got {float(time[0])!r} '
               f'then {float(time[1])!r}')
        raise GroundMotionError(msg)
    steps = np.diff(time)
    bad = np.flatnonzero(np.abs(steps - raw_dt) > 1e-6 * raw_dt + 1e-9)
    if bad.size:
        index = int(bad[0]) + 1
        msg = (f'ground motion {label}: {name}: non-uniform time step at sample {index} '
               f'(step {float(steps[index - 1])!r} s, expected {raw_dt!r} s)')
        raise GroundMotionError(msg)
    return _make(path, float(f'{raw_dt:.12g}'), acc * scale)


def read_ground_motion(
    path: PathLike,
    *,
    format: str = 'auto',
    units: str = 'g',
    dt: float | None = None,
    g: float = G_THESIS,
) -> GroundMotion:
    """Read a ground-motion record in any supported layout.

    With ``format='auto'`` a ``.at2`` suffix (any case) selects the PEER reader and a ``.mat``
    suffix the MATLAB reader (:func:`read_mat`, ``units`` as given); otherwise the
    number of values on the first numeric row decides: 2 -> two columns (time, acceleration),
    1 -> single column, more -> multi-column (row-major). Single- and multi-column files need
    ``dt``. For two-column and AT2 files the time step comes from the file; a ``dt`` given as
    well must agree with it within 1e-9 relative.

    Args:
        path: The file.
        format: One of ``'auto'``, ``'two_column'``, ``'single_column'``, ``'multi_column'``,
            ``'at2'``, ``'mat'``.
        units: Acceleration units in the file: ``'g'`` or ``'m/s2'`` (``'m/s^2'``). AT2 files
            are always in g.
        dt: Time step in s, required for single- and multi-column files.
        g: Gravity in m/s² used to convert g; 9.81 by default, as in the thesis's MATLAB.

    Returns:
        The record in m/s², ``source`` the file name.

    Raises:
        GroundMotionError: On an unknown format or unit, a missing or contradicting ``dt``, or
            any problem reading the file.
    """
    label = _label(path)
    if not isinstance(format, str) or format not in FORMATS:
        msg = (
            f'ground motion {label}: unknown format {format!r} '
            f'(expected one of {", ".join(FORMATS)})'
        )
        raise GroundMotionError(msg)
    scale = _unit_scale(path, units, g)
    if dt is not None:
        dt = _check_dt(path, dt)

    fmt = format
    if fmt == 'auto' and Path(path).suffix.lower() == '.at2':
        fmt = 'at2'
    if fmt == 'auto' and Path(path).suffix.lower() == '.mat':
        fmt = 'mat'
    if fmt == 'mat':
        motion = read_mat(path, units=units, g=g)
        _check_file_dt(label, motion.dt, dt)
        return motion
    if fmt == 'at2':
        if _normalise_units(units) != 'g':
            msg = f'ground motion {label}: AT2 files are in g, units={units!r} does not apply'
            raise GroundMotionError(msg)
        motion = read_at2(path, g=g)
        _check_file_dt(label, motion.dt, dt)
        return motion

    label, lines = _load_lines(path)
    rows = _parse_table(label, lines)
    if fmt == 'auto':
        n_columns = len(rows[0][1])
        if n_columns == 2:
            fmt = 'two_column'
        elif n_columns == 1:
            fmt = 'single_column'
        else:
            fmt = 'multi_column'

    if fmt == 'two_column':
        motion = _build_two_column(path, label, rows, scale)
        _check_file_dt(label, motion.dt, dt)
        return motion
    if dt is None:
        layout = 'single-column' if fmt == 'single_column' else 'multi-column'
        msg = (
            f'ground motion {label}: a {layout} file needs dt (the time step is not in the '
            f'file); pass dt=...'
        )
        raise GroundMotionError(msg)
    if fmt == 'single_column':
        return _build_single_column(path, label, rows, dt, scale)
    return _build_multi_column(path, label, rows, dt, scale)


# ---------------------------------------------------------------------- helpers

_Row = tuple[int, list[float]]


def _label(path: PathLike) -> str:
    """Quoted file name for error messages."""
    return f"'{os.fspath(path)}'"


def _source(path: PathLike) -> str:
    """The ``source`` of a record read from ``path``: its file name."""
    return Path(path).name


def _normalise_units(units: object) -> str | None:
    """Canonical unit ('g' or 'm/s2'), or None if unknown."""
    if not isinstance(units, str):
        return None
    key = units.strip().lower()
    if key == 'g':
        return 'g'
    if key in ('m/s2', 'm/s^2'):
        return 'm/s2'
    return None


def _unit_scale(path: PathLike, units: object, g: float) -> float:
    """Factor converting the file's units to m/s²."""
    label = _label(path)
    unit = _normalise_units(units)
    if unit is None:
        msg = f"ground motion {label}: unknown units {units!r} (expected 'g' or 'm/s2')"
        raise GroundMotionError(msg)
    try:
        g_value = float(g)
    except (TypeError, ValueError):
        g_value = math.nan
    if not (math.isfinite(g_value) and g_value > 0.0):
        msg = f'ground motion {label}: g must be positive and finite, got {g!r}'
        raise GroundMotionError(msg)
    return g_value if unit == 'g' else 1.0


def _check_dt(path: PathLike, dt: float) -> float:
    """Validate a user-given time step."""
    try:
        value = float(dt)
    except (TypeError, ValueError):
        value = math.nan
    if not (math.isfinite(value) and value > 0.0):
        msg = f'ground motion {_label(path)}: dt must be positive and finite, got {dt!r}'
        raise GroundMotionError(msg)
    return value


def _check_file_dt(label: str, file_dt: float, dt: float | None) -> None:
    """Reject a user-given dt that contradicts the one stored in the file."""
    if dt is not None and not dt_close(file_dt, dt):
        msg = f'ground motion {label}: dt={dt!r} was given but the file has dt={file_dt!r}'
        raise GroundMotionError(msg)


def _make(path: PathLike, dt: float, acceleration: np.ndarray) -> GroundMotion:
    """Build the record, reporting validation errors against the file path."""
    return GroundMotion(dt, acceleration, _source(path))


def _load_lines(path: PathLike) -> tuple[str, list[str]]:
    """Read the file as text lines (BOM and line endings handled)."""
    label, text = _load_text(path)
    return label, text.splitlines()


def _read_file(path: PathLike, label: str) -> bytes:
    """The bytes of a record file: a regular file of at most :data:`MAX_RECORD_BYTES`."""
    try:
        return read_bytes(path, limit=MAX_RECORD_BYTES, what='a ground-motion record')
    except OSError as exc:
        reason = exc.strerror or exc.__class__.__name__
        msg = f'ground motion {label}: cannot read file: {reason}'
        raise GroundMotionError(msg) from None


def _load_text(path: PathLike) -> tuple[str, str]:
    """Read the file as text (BOM removed); an empty file is an error."""
    label = _label(path)
    data = _read_file(path, label)
    try:
        text = data.decode('utf-8-sig')
    except UnicodeDecodeError:
        msg = f'ground motion {label}: not a text file'
        raise GroundMotionError(msg) from None
    if not text.strip():
        msg = f'ground motion {label}: file is empty'
        raise GroundMotionError(msg)
    return label, text


def _tokens(line: str) -> list[str]:
    """Split a line on commas and/or whitespace (empty fields are kept, as '')."""
    return _FIELD_SPLIT_RE.split(line.strip())


def _parse_number(token: str) -> float | None:
    """Parse a plain decimal number (Fortran D exponents allowed); None if not numeric."""
    if not _NUMBER_RE.fullmatch(token):
        return None
    return float(token.replace('d', 'e').replace('D', 'E'))


def _is_numberish(token: str) -> bool:
    """Whether a token is a number, a number cut short (``1.2E-``) or a nan/inf spelling."""
    return bool(_NUMBER_RE.fullmatch(token) or _NON_FINITE_RE.fullmatch(token)
                or _CUT_NUMBER_RE.fullmatch(token))


def _parse_values(label: str, lineno: int, line: str, last: bool, *, at2: bool = False
                  ) -> list[float]:
    """Parse every field of a data line, naming the line on failure.

    ``at2``: the line is AT2 data, whose exponents have two digits or more.
    """
    values = []
    for token in _tokens(line):
        value = _parse_number(token)
        if at2 and value is not None and not _AT2_NUMBER_RE.fullmatch(token):
            msg = (f'ground motion {label}: line {lineno}: malformed value {token!r} (an AT2 '
                   'file writes an exponent with two digits or more; file truncated?)')
            raise GroundMotionError(msg)
        if value is None or not math.isfinite(value):
            if value is not None or _NON_FINITE_RE.fullmatch(token):
                what = f'non-finite value {token!r}'
            elif token == '':
                what = 'empty field'
            else:
                what = f'non-numeric value {token!r}'
            hint = ' (file truncated?)' if last else ''
            msg = f'ground motion {label}: line {lineno}: {what}{hint}'
            raise GroundMotionError(msg)
        values.append(value)
    return values


def _parse_table(label: str, lines: Sequence[str]) -> list[_Row]:
    """Parse a numeric table with optional ``#`` comments and one leading header line.

    Returns:
        ``(line number, values)`` for each data row; at least one row.
    """
    content = [
        (number, line)
        for number, line in enumerate(lines, start=1)
        if line.strip() and not line.lstrip().startswith('#')
    ]
    if not content:
        msg = f'ground motion {label}: no data, only comments or blank lines'
        raise GroundMotionError(msg)
    first_line = content[0][1]
    if not any(_is_numberish(token) for token in _tokens(first_line)):
        content = content[1:]  # a single header line such as 'time,accel'
        if not content:
            msg = f'ground motion {label}: no data after the header line {first_line.strip()!r}'
            raise GroundMotionError(msg)
    last_number = content[-1][0]
    return [
        (number, _parse_values(label, number, line, number == last_number))
        for number, line in content
    ]


def _flatten(rows: Sequence[_Row]) -> np.ndarray:
    """All values of the rows, row-major."""
    return np.array([value for _, values in rows for value in values], dtype=np.float64)


def _build_two_column(
    path: PathLike, label: str, rows: Sequence[_Row], scale: float
) -> GroundMotion:
    """Two-column (time, acceleration) rows to a record."""
    for number, values in rows:
        if len(values) != 2:
            msg = (
                f'ground motion {label}: line {number}: expected 2 columns (time, '
                f'acceleration), found {len(values)}'
            )
            raise GroundMotionError(msg)
    if len(rows) < 2:
        msg = f'ground motion {label}: need at least 2 samples, found {len(rows)}'
        raise GroundMotionError(msg)
    time = np.array([values[0] for _, values in rows], dtype=np.float64)
    acc = np.array([values[1] for _, values in rows], dtype=np.float64)
    raw_dt = time[1] - time[0]
    if not raw_dt > 0.0:
        msg = (
            f'ground motion {label}: line {rows[1][0]}: time must increase, '
            f'got {time[0]!r} then {time[1]!r}'
        )
        raise GroundMotionError(msg)
    dt = float(f'{raw_dt:.12g}')
    steps = np.diff(time)
    bad = np.flatnonzero(np.abs(steps - raw_dt) > 1e-6 * raw_dt + 1e-9)
    if bad.size:
        index = int(bad[0]) + 1
        msg = (
            f'ground motion {label}: non-uniform time step at line {rows[index][0]} '
            f'(step {steps[index - 1]!r} s, expected {dt!r} s)'
        )
        raise GroundMotionError(msg)
    return _make(path, dt, acc * scale)


def _build_single_column(
    path: PathLike, label: str, rows: Sequence[_Row], dt: float, scale: float
) -> GroundMotion:
    """Single-column rows to a record."""
    for number, values in rows:
        if len(values) != 1:
            msg = (
                f'ground motion {label}: line {number}: expected 1 value per line in a '
                f'single-column file, found {len(values)}'
            )
            raise GroundMotionError(msg)
    acc = _flatten(rows)
    if acc.size < 2:
        msg = f'ground motion {label}: need at least 2 samples, found {acc.size}'
        raise GroundMotionError(msg)
    return _make(path, dt, acc * scale)


def _build_multi_column(
    path: PathLike, label: str, rows: Sequence[_Row], dt: float, scale: float
) -> GroundMotion:
    """Row-major multi-column rows to a record; only the last row may be shorter."""
    width = len(rows[0][1])
    for index, (number, values) in enumerate(rows):
        is_last = index == len(rows) - 1
        if len(values) == width or (is_last and len(values) < width):
            continue
        msg = (
            f'ground motion {label}: line {number}: expected {width} values, found '
            f'{len(values)} (only the last row may be shorter)'
        )
        raise GroundMotionError(msg)
    acc = _flatten(rows)
    if acc.size < 2:
        msg = f'ground motion {label}: need at least 2 samples, found {acc.size}'
        raise GroundMotionError(msg)
    return _make(path, dt, acc * scale)


def _parse_at2_header(label: str, line: str) -> tuple[int, float]:
    """NPTS and DT from line 4 of an AT2 file."""
    npts_match = _AT2_NPTS_RE.search(line)
    dt_match = _AT2_DT_RE.search(line)
    if npts_match and dt_match:
        npts_text, dt_text = npts_match.group(1), dt_match.group(1)
    else:
        old = _AT2_OLD_RE.match(line)
        if not old:
            msg = f'ground motion {label}: line 4: cannot find NPTS and DT in {line.strip()!r}'
            raise GroundMotionError(msg)
        npts_text, dt_text = old.group(1), old.group(2)
    unit = dt_match.group(2) if npts_match and dt_match else None
    count = _parse_number(npts_text)  # '5372.0' is an integer; '5372.5' is not
    if count is None or not (math.isfinite(count) and count >= 0 and count == int(count)):
        msg = (
            f'ground motion {label}: line 4: NPTS must be a non-negative integer, '
            f'got {npts_text!r}'
        )
        raise GroundMotionError(msg)
    npts = int(count)
    dt = _parse_number(dt_text)
    if dt is None or not (math.isfinite(dt) and dt > 0.0):
        msg = f'ground motion {label}: line 4: DT must be a positive number, got {dt_text!r}'
        raise GroundMotionError(msg)
    if unit is not None:
        per_second = _AT2_DT_UNITS.get(unit.upper())
        if per_second is None:
            msg = (f'ground motion {label}: line 4: unknown DT unit {unit!r} (expected SEC or '
                   'MSEC, or no unit for seconds)')
            raise GroundMotionError(msg)
        if per_second != 1:
            dt /= per_second
    return npts, dt


def _number_shape(token: str) -> tuple[int | None, int | None]:
    """How a (well-formed) number is written: digits after the point, digits of the exponent.

    ``None`` for a part that is not there.
    """
    parts = _NUMBER_PARTS_RE.fullmatch(token)
    if parts is None:
        return None, None
    fraction, exponent = parts.groups()
    return (None if fraction is None else len(fraction),
            None if exponent is None else len(exponent))


def _check_last_value(label: str, data: Sequence[tuple[int, str]]) -> None:
    """Refuse a last value written unlike the one before it (the file looks cut short).

    Only for values written with an exponent (the E format of a program): ``-.1790158`` after
    ``.2339013E-02`` is the start of ``-.1790158E-02``.
    """
    tokens = [(number, token) for number, line in data[-2:] for token in _tokens(line)]
    if len(tokens) < 2:
        return
    (_, before), (number, last) = tokens[-2:]
    shape_before, shape_last = _number_shape(before), _number_shape(last)
    if shape_before[1] is None:  # no exponent: nothing tells how the value was written
        return
    if shape_last != shape_before:
        msg = (f'ground motion {label}: line {number}: last value {last!r} is not written like '
               f'the one before it ({before!r}) and the file does not end with a line end: '
               'file truncated?')
        raise GroundMotionError(msg)


def _parse_at2(label: str, lines: Sequence[str], *, ends_with_line_end: bool = True
               ) -> tuple[int, float, np.ndarray]:
    """NPTS, DT and the values (in g) of an AT2 file.

    ``ends_with_line_end``: whether the text ends with a line end (if not, it may be cut).
    """
    if len(lines) < 4:
        msg = (
            f'ground motion {label}: AT2 header incomplete: expected 4 header lines, '
            f'found {len(lines)}'
        )
        raise GroundMotionError(msg)
    npts, dt = _parse_at2_header(label, lines[3])
    data = [(number, line) for number, line in enumerate(lines, start=1) if number > 4]
    data = [(number, line) for number, line in data if line.strip()]
    last_number = data[-1][0] if data else 0
    values = [
        value
        for number, line in data
        for value in _parse_values(label, number, line, number == last_number, at2=True)
    ]
    if not ends_with_line_end:
        _check_last_value(label, data)
    if len(values) != npts:
        msg = f'ground motion {label}: line 4: NPTS={npts} but {len(values)} values were read'
        raise GroundMotionError(msg)
    return npts, dt, np.array(values, dtype=np.float64)

