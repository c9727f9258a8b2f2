"""Quantities printed in units that fit their size."""

from __future__ import annotations

import pytest

from pd_common.units import format_quantity


@pytest.mark.parametrize(('value', 'unit', 'text'), [
    (10085.3, 'N', '10.085 kN'),
    (0.98712, 'N', '0.98712 N'),          # not '-0.001 kN'
    (-987.0, 'N', '-987.00 N'),
    (2.5e6, 'N', '2.5000 MN'),
    (0.0494117, 'm', '49.412 mm'),
    (1.5, 'm', '1.5000 m'),
    (-2.5e-7, 'm', '-0.25000 µm'),
    (3.0e-5, 'm', '30.000 µm'),
    (-15627.95, 'N/m', '-15.628 kN/m'),
    (0.0, 'm', '0 m'),
    (float('nan'), 'N', 'n/a'),
    (12.0, 's', '12.000 s'),              # a unit without prefixes
])
def test_format_quantity(value: float, unit: str, text: str) -> None:
    assert format_quantity(value, unit) == text


def test_significant_digits() -> None:
    assert format_quantity(0.566804123, 's', significant=6) == '0.566804 s'
    assert format_quantity(10000.0, 'N', significant=3) == '10.0 kN'
