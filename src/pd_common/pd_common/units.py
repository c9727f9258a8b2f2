"""Printing physical quantities in units that fit their size (``0.987 N``, ``10.085 kN``).

One home for the printouts of every package: summaries, log lines and reports choose the SI
prefix from the value, so a 1 N force is not printed as ``0.001 kN`` and a 50 mm displacement
not as ``0.04941 m``.
"""

from __future__ import annotations

import math

__all__ = ['format_quantity']

#: SI prefixes a unit may take (scale, prefix), smallest first. A unit not listed takes none.
_PREFIXES: dict[str, tuple[tuple[float, str], ...]] = {
    'N': ((1.0, ''), (1e3, 'k'), (1e6, 'M')),
    'm': ((1e-6, 'µ'), (1e-3, 'm'), (1.0, '')),
    'N/m': ((1.0, ''), (1e3, 'k'), (1e6, 'M'), (1e9, 'G')),
}


def format_quantity(value: float | None, unit: str, significant: int = 5) -> str:
    """``value`` in ``unit`` with the SI prefix that fits it, to ``significant`` digits.

    The prefix is the largest one (among those ``unit`` takes) that leaves a magnitude of at
    least 1; below the smallest prefix the smallest is used (``0.987 N`` stays in N).
    Non-finite values and ``None`` (no value: e.g. no committed step) print as ``n/a``.

    Examples: ``format_quantity(10085.3, 'N')`` is ``'10.085 kN'``,
    ``format_quantity(0.98712, 'N')`` is ``'0.98712 N'``,
    ``format_quantity(0.0494117, 'm')`` is ``'49.412 mm'``.
    """
    if not isinstance(value, (int, float)) or not math.isfinite(value):
        return 'n/a'
    if value == 0.0:
        return f'0 {unit}'
    choices = _PREFIXES.get(unit, ((1.0, ''),))
    magnitude = abs(value)
    scale, prefix = choices[0]
    for candidate, name in choices:
        if magnitude >= candidate:
            scale, prefix = candidate, name
    number = f'{value / scale:.{significant}g}'
    if 'e' not in number and magnitude > 0.0:
        # keep trailing zeros to the stated number of significant digits ('10.080', not '10.08')
        digits = len(number.replace('-', '').replace('.', '').lstrip('0'))
        if digits < significant:
            number += ('' if '.' in number else '.') + '0' * (significant - digits)
    return f'{number} {prefix}{unit}'
