"""Backbone (monotonic pushover) curves and their loaders.

A backbone is the force-displacement curve of a monotonic pushover analysis, starting at the
origin with strictly increasing displacement. Hysteresis models evaluate it at a non-negative
displacement measured from a pivot (see :mod:`.hysteresis`).
"""

from __future__ import annotations

import math
import re
from bisect import bisect_right
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import BackboneError, HysteresisError, SpecimenError

BEYOND_MODES = ('extrapolate', 'plateau', 'error')
"""Accepted values of ``beyond``: what happens past the last backbone point."""

_SEPARATOR = re.compile(r'\s*,\s*|\s+')


@dataclass(frozen=True, eq=False)
class Backbone:
    """Piecewise-linear monotonic pushover curve, ``force = B(displacement)`` for ``d >= 0``.

    Attributes:
        displacement: Displacements in m: first exactly 0, strictly increasing, finite.
        force: Forces in N at those displacements: first exactly 0, finite. The force need not
            be monotonic (a P-delta pushover may soften).
        source: Where the curve came from, used in error messages.

    Raises:
        BackboneError: If the arrays are not 1-D of equal length >= 2, contain non-finite
            values, do not start at (0, 0) or the displacement is not strictly increasing.
    """

    displacement: np.ndarray
    force: np.ndarray
    source: str = 'backbone'
    _d: list[float] = field(init=False, repr=False, compare=False)
    _f: list[float] = field(init=False, repr=False, compare=False)
    _slope: list[float] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        """Check the points; keep them read-only, with the slopes between them."""
        name = f"backbone '{self.source}'"
        try:
            d = np.array(self.displacement, dtype=float)
            f = np.array(self.force, dtype=float)
        except (TypeError, ValueError) as exc:
            msg = f'{name}: points are not numbers ({exc})'
            raise BackboneError(msg) from None
        if d.ndim != 1 or f.ndim != 1 or d.shape != f.shape:
            msg = (
                f'{name}: displacement and force must be 1-D arrays of equal length, got shapes '
                f'{d.shape} and {f.shape}'
            )
            raise BackboneError(msg)
        if d.size < 2:
            msg = f'{name}: needs at least 2 points, got {d.size}'
            raise BackboneError(msg)
        for label, values in (('displacement', d), ('force', f)):
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size:
                i = int(bad[0])
                msg = f'{name}: point {i}: {label} is not finite ({values[i]})'
                raise BackboneError(msg)
        if d[0] != 0.0 or f[0] != 0.0:
            msg = f'{name}: point 0 must be (0, 0), got ({d[0]:g}, {f[0]:g})'
            raise BackboneError(msg)
        steps = np.diff(d)
        bad = np.flatnonzero(steps <= 0.0)
        if bad.size:
            i = int(bad[0]) + 1
            msg = (
                f'{name}: point {i}: displacement {d[i]:g} m is not greater than the previous '
                f'{d[i - 1]:g} m'
            )
            raise BackboneError(msg)
        d.setflags(write=False)
        f.setflags(write=False)
        object.__setattr__(self, 'displacement', d)
        object.__setattr__(self, 'force', f)
        object.__setattr__(self, '_d', d.tolist())
        object.__setattr__(self, '_f', f.tolist())
        object.__setattr__(self, '_slope', (np.diff(f) / steps).tolist())

    def __deepcopy__(self, memo: dict[int, object]) -> Backbone:
        """Return self: a backbone is immutable, so copies of models may share it."""
        return self

    @property
    def initial_stiffness(self) -> float:
        """Slope of the first segment in N/m (MATLAB ``kini``)."""
        return self._slope[0]

    @property
    def last_displacement(self) -> float:
        """Displacement of the last point in m."""
        return self._d[-1]

    def force_at(self, d: float, beyond: str = 'extrapolate') -> float:
        """Evaluate the backbone at ``d >= 0`` by linear interpolation.

        Args:
            d: Displacement from the origin of the curve in m.
            beyond: Behaviour past the last point: ``'extrapolate'`` (default) continues the
                slope of the last segment, ``'plateau'`` keeps the last force, ``'error'``
                raises (the MATLAB ``force`` function of the thesis has no value there).

        Returns:
            The force in N.

        Raises:
            HysteresisError: If ``d`` is negative or NaN, or beyond the last point with
                ``beyond='error'``.
            BackboneError: If ``beyond`` is not one of the accepted modes.
        """
        ds = self._d
        if d >= ds[-1]:
            if d == ds[-1]:
                return self._f[-1]
            if beyond == 'extrapolate':
                if math.isinf(d):
                    msg = f"backbone '{self.source}': displacement must be finite, got {d}"
                    raise HysteresisError(msg)
                return self._f[-1] + self._slope[-1] * (d - ds[-1])
            if beyond == 'plateau':
                return self._f[-1]
            if beyond == 'error':
                msg = (
                    f"backbone '{self.source}': displacement {d:g} m is beyond the last backbone "
                    f'point {ds[-1]:g} m'
                )
                raise HysteresisError(msg)
            msg = (
                f"backbone '{self.source}': beyond must be one of {', '.join(BEYOND_MODES)}, "
                f'got {beyond!r}'
            )
            raise BackboneError(msg)
        if not d >= 0.0:
            msg = f"backbone '{self.source}': displacement must be >= 0, got {d}"
            raise HysteresisError(msg)
        i = bisect_right(ds, d) - 1
        return self._f[i] + self._slope[i] * (d - ds[i])


def _positive(value: float, name: str, where: str) -> float:
    """Return ``value`` as a float, raising BackboneError unless positive and finite."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        msg = (
            f'{where}: {name} must be a positive finite number, got '
                            f'{value!r}'
        )
        raise BackboneError(msg) from None
    if not (math.isfinite(number) and number > 0.0):
        msg = f'{where}: {name} must be a positive finite number, got {value!r}'
        raise BackboneError(msg)
    return number


def residual_strength(value: float, yield_force: float, ratio: float, where: str,
                      error: type[SpecimenError] = BackboneError) -> float:
    """A strength floor ``F_r`` in ``[0, F_y]``, of a softening model only (``ratio < 0``).

    Raises:
        error: (``BackboneError`` by default) naming ``where`` and ``residual_force``.
    """
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not 0.0 <= number <= yield_force:
        msg = f'{where}: residual_force must be in [0, yield_force={yield_force:g}], got {value!r}'
        raise error(msg)
    if ratio >= 0.0:
        msg = (f'{where}: residual_force needs a negative hardening_ratio (softening), got '
               f'hardening_ratio={ratio:g}')
        raise error(msg)
    return number


def bilinear_backbone(stiffness: float, yield_force: float, hardening_ratio: float = 0.0,
                      max_displacement: float | None = None,
                      residual_force: float | None = None) -> Backbone:
    """Build the bilinear backbone (0, 0), (d_y, F_y), (d_max, F_y + b k (d_max - d_y)).

    With a negative ``hardening_ratio`` (softening) and a ``residual_force`` ``F_r`` the
    curve is trilinear: it descends from ``(d_y, F_y)`` to ``(d_r, F_r)``,
    ``d_r = d_y + (F_y - F_r) / (-b k)``, and stays at ``F_r`` up to ``d_max`` (if ``d_max``
    comes first the curve ends on the descent). Without a floor a softening curve may cross
    zero before ``d_max`` (collapse: a negative force).

    Args:
        stiffness: Initial stiffness ``k`` in N/m.
        yield_force: Yield force ``F_y`` in N; the yield displacement is ``d_y = F_y / k``.
        hardening_ratio: Post-yield to initial stiffness ratio ``b``, ``-1 < b < 1``.
        max_displacement: Displacement of the last point in m, greater than ``d_y``. Defaults
            to ``100 d_y``; past it the hysteresis model's ``beyond`` mode applies.
        residual_force: Strength floor ``F_r`` in N, ``0 <= F_r <= F_y``, only with
            ``b < 0``; ``None`` (default): no floor.

    Returns:
        The backbone.

    Raises:
        BackboneError: If an argument is out of range.
    """
    where = 'bilinear backbone'
    k = _positive(stiffness, 'stiffness', where)
    fy = _positive(yield_force, 'yield_force', where)
    try:
        b = float(hardening_ratio)
    except (TypeError, ValueError):
        b = math.nan
    if not -1.0 < b < 1.0:
        msg = f'{where}: hardening_ratio must be in (-1, 1), got {hardening_ratio!r}'
        raise BackboneError(msg)
    dy = fy / k
    d_max = 100.0 * dy if max_displacement is None else _positive(
        max_displacement, 'max_displacement', where)
    if not d_max > dy:
        msg = f'{where}: max_displacement {d_max:g} m must exceed the yield displacement {dy:g} m'
        raise BackboneError(msg)
    source = f'bilinear k={k:g} N/m, F_y={fy:g} N, b={b:g}'
    if residual_force is None:
        return Backbone(np.array([0.0, dy, d_max]),
                        np.array([0.0, fy, fy + b * k * (d_max - dy)]), source=source)
    fr = residual_strength(residual_force, fy, b, where)
    source = f'{source}, F_r={fr:g} N'
    d_r = dy + (fy - fr) / (-b * k)
    if d_r >= d_max:
        return Backbone(np.array([0.0, dy, d_max]),
                        np.array([0.0, fy, fy + b * k * (d_max - dy)]), source=source)
    if d_r == dy:
        return Backbone(np.array([0.0, dy, d_max]), np.array([0.0, fy, fy]), source=source)
    return Backbone(np.array([0.0, dy, d_r, d_max]), np.array([0.0, fy, fr, fr]),
                    source=source)


def _read_lines(path: Path, name: str) -> list[str]:
    """Read a text file, turning I/O errors into BackboneError."""
    try:
        return path.read_text(encoding='utf-8').splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        msg = f'{name}: cannot read file ({exc})'
        raise BackboneError(msg) from None


def _parse_number(text: str) -> float | None:
    """Return ``text`` as a float, or None if it is not a number."""
    try:
        return float(text)
    except ValueError:
        return None


def _check_points(d: list[float], f: list[float], lines: list[int], name: str) -> None:
    """Check finiteness and increasing displacement, naming the file line on failure."""
    for i, (di, fi) in enumerate(zip(d, f)):
        if not (math.isfinite(di) and math.isfinite(fi)):
            msg = (
                f'{name}: line {lines[i]}: values must be finite, got '
                                f'({di}, {fi})'
            )
            raise BackboneError(msg)
        if i and di <= d[i - 1]:
            msg = (
                f'{name}: line {lines[i]}: displacement {di:g} m is not greater than the '
                f'previous {d[i - 1]:g} m'
            )
            raise BackboneError(msg)


def _with_origin(d: list[float], f: list[float], name: str, first_line: int
                 ) -> tuple[list[float], list[float]]:
    """Prepend (0, 0) unless the curve already starts there."""
    if d[0] == 0.0 and f[0] == 0.0:
        return d, f
    if d[0] <= 0.0:
        msg = (
            f'{name}: line {first_line}: first point ({d[0]:g}, {f[0]:g}) must be (0, 0) or at a '
            f'positive displacement'
        )
        raise BackboneError(msg)
    return [0.0, *d], [0.0, *f]


def load_backbone_csv(path: str | Path) -> Backbone:
    """Load a backbone from a two-column text file (displacement in m, force in N).

    Columns are separated by a comma or whitespace. Blank lines and ``#`` comments are
    ignored; the first data line may be a non-numeric header. The point (0, 0) is prepended
    if the first row is not at the origin.

    Args:
        path: The file.

    Returns:
        The backbone, with ``source`` set to the file name.

    Raises:
        BackboneError: Naming the file and line if the file cannot be read, is empty, has a
            non-numeric value, a row without exactly two columns, a non-finite value or
            non-increasing displacement.
    """
    path = Path(path)
    name = f"backbone '{path}'"
    d: list[float] = []
    f: list[float] = []
    lines: list[int] = []
    header_allowed = True
    for number, raw in enumerate(_read_lines(path, name), start=1):
        text = raw.split('#', 1)[0].strip()
        if not text:
            continue
        fields = _SEPARATOR.split(text)
        values = [_parse_number(item) for item in fields]
        if header_allowed and all(value is None for value in values):
            header_allowed = False
            continue
        header_allowed = False
        if len(fields) != 2:
            msg = (
                f'{name}: line {number}: expected 2 columns (displacement, force), got '
                f'{len(fields)}'
            )
            raise BackboneError(msg)
        for item, value in zip(fields, values):
            if value is None:
                msg = f'{name}: line {number}: {item!r} is not a number'
                raise BackboneError(msg)
        d.append(values[0])  # type: ignore[arg-type]
        f.append(values[1])  # type: ignore[arg-type]
        lines.append(number)
    if not d:
        msg = f'{name}: no data rows'
        raise BackboneError(msg)
    _check_points(d, f, lines, name)
    d, f = _with_origin(d, f, name, lines[0])
    return Backbone(np.array(d), np.array(f), source=str(path))


def _read_recorder(path: Path, column: int) -> tuple[list[float], list[int]]:
    """Read one column of an OpenSees recorder file, with the line number of every row."""
    name = f"OpenSees recorder '{path}'"
    values: list[float] = []
    lines: list[int] = []
    for number, raw in enumerate(_read_lines(path, name), start=1):
        fields = raw.split()
        if not fields:
            continue
        for item in fields:
            if _parse_number(item) is None:
                msg = f'{name}: line {number}: {item!r} is not a number'
                raise BackboneError(msg)
        if column >= len(fields):
            msg = (
                f'{name}: line {number}: has {len(fields)} columns, column {column} '
                f'(0-based) requested'
            )
            raise BackboneError(msg)
        values.append(float(fields[column]))
        lines.append(number)
    return values, lines


def load_opensees_pushover(displacement_file: str | Path, reaction_file: str | Path, *,
                           skip_rows: int = 10, column: int = 1, force_sign: float = -1.0,
                           force_scale: float = 1.0) -> Backbone:
    """Load a backbone from the OpenSees recorder pair used in the thesis.

    ``DFree.txt`` records the free-end displacement and ``RBase.txt`` the base reaction, one
    row per analysis step (``time value ...``, whitespace separated). As in Appendix A, the
    first ``skip_rows`` rows (the gravity analysis) are dropped, the displacement is column
    ``column`` of the first file and the force is ``force_sign * force_scale`` times the same
    column of the second (the thesis uses ``-R / 50``, i.e. ``force_scale=0.02``). The point
    (0, 0) is prepended unless the first kept point is already the origin.

    Args:
        displacement_file: Displacement recorder file (m).
        reaction_file: Reaction recorder file (N).
        skip_rows: Number of leading rows to drop, >= 0.
        column: 0-based column holding the value (0 is the time).
        force_sign: Sign applied to the reaction (a base reaction opposes the push).
        force_scale: Positive scale factor applied to the reaction.

    Returns:
        The backbone, with ``source`` naming both files.

    Raises:
        BackboneError: Naming the file (and line) if a file cannot be read or is not numeric,
            the row counts differ, no row is left after skipping, or the displacement does
            not increase.
    """
    disp_path, react_path = Path(displacement_file), Path(reaction_file)
    source = f'{disp_path} + {react_path}'
    name = f"OpenSees pushover '{source}'"
    if isinstance(skip_rows, bool) or not isinstance(skip_rows, int) or skip_rows < 0:
        msg = f'{name}: skip_rows must be an integer >= 0, got {skip_rows!r}'
        raise BackboneError(msg)
    if isinstance(column, bool) or not isinstance(column, int) or column < 0:
        msg = f'{name}: column must be an integer >= 0, got {column!r}'
        raise BackboneError(msg)
    scale = _positive(force_scale, 'force_scale', name)
    try:
        sign = float(force_sign)
    except (TypeError, ValueError):
        sign = math.nan
    if not (math.isfinite(sign) and sign != 0.0):
        msg = (
            f'{name}: force_sign must be a non-zero finite number, got '
                            f'{force_sign!r}'
        )
        raise BackboneError(msg)
    d, lines = _read_recorder(disp_path, column)
    r, _ = _read_recorder(react_path, column)
    if len(d) != len(r):
        msg = (
            f"OpenSees pushover: '{disp_path}' has {len(d)} rows but '{react_path}' has "
            f'{len(r)}'
        )
        raise BackboneError(msg)
    if len(d) <= skip_rows:
        msg = (
            f"OpenSees pushover: '{disp_path}' has {len(d)} rows, none left after skipping "
            f'{skip_rows}'
        )
        raise BackboneError(msg)
    d, lines = d[skip_rows:], lines[skip_rows:]
    f = [sign * scale * value for value in r[skip_rows:]]
    _check_points(d, f, lines, name)
    d, f = _with_origin(d, f, name, lines[0])
    return Backbone(np.array(d), np.array(f), source=source)
