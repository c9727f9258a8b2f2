"""The hysteresis model ``linear_spring``: ``f = stiffness · factor · x``.

A specimen element ``{model: linear_spring, stiffness: 2.0e5, factor: 0.5}`` is the built-in
``{model: elastic, stiffness: 1.0e5}``.
"""

from __future__ import annotations

from pd_common.registry import Parameter
from pd_common.specimen import ElementReader, HysteresisModel, HysteresisModelSpec


class LinearSpring(HysteresisModel):
    """A linear elastic spring of stiffness ``stiffness · factor`` (N/m)."""

    def __init__(self, stiffness: float, factor: float) -> None:
        """Create the spring (the values are checked by the declarations below)."""
        self._k = stiffness * factor
        super().__init__()

    def _initial_state(self) -> tuple[float, ...]:
        """No internal state."""
        return ()

    def _evaluate(self, x: float) -> tuple[float, tuple[float, ...]]:
        """``f = k x``."""
        return self._k * x, ()

    @property
    def initial_stiffness(self) -> float:
        """``k`` in N/m."""
        return self._k


def build(reader: ElementReader) -> LinearSpring:
    """The spring of one element; every key checked by its declaration, named in errors."""
    return LinearSpring(**reader.values())


LINEAR_SPRING = HysteresisModelSpec(
    name='linear_spring',
    build=build,
    parameters=(
        Parameter('stiffness', None, 'spring stiffness, N/m', low=0.0, low_open=True,
                  required=True),
        Parameter('factor', 1.0, 'factor on the stiffness', low=0.0, high=10.0,
                  low_open=True),
    ),
    description='linear elastic spring f = stiffness * factor * x',
)
