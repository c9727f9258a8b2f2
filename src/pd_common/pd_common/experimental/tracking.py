"""Tracking monitors: command vs measured displacement (error and tracking indicator).

Monitors. :func:`tracking_error` is the history of ``measured - command``.
:func:`tracking_indicator` is the tracking indicator proposed by Mercan and Ricles ("Stability and
accuracy analysis of outer loop dynamics in real-time pseudodynamic testing of SDOF systems",
Earthquake Eng. Struct. Dyn. 36, 2007): the area enclosed by the loop of the measured versus the
commanded displacement. Here it is accumulated with the trapezoidal rule in the symmetric form
``TI = (int x_m dx_c - int x_c dx_m) / 2``, i.e.
``TI_{i+1} = TI_i + (x_m,i x_c,i+1 - x_m,i+1 x_c,i) / 2``, which is zero for perfect tracking
even on an open path and equals ``oint x_m dx_c`` on a closed cycle.

Sign: positive = energy removed, negative = energy added. For a linear specimen of stiffness
``k`` the integrator pairs the force ``k x_m`` measured at the achieved displacement with its own
command ``x_c``, so over a cycle it sees the work ``k * TI`` done on the specimen. A measured
displacement *lagging* the command (the actuator delay analysed by Mercan and Ricles, equivalent
to negative damping) traverses the (command, measured) loop counter-clockwise and gives
``TI < 0``: energy added to the test. A *leading* one gives ``TI > 0``: energy removed (extra
damping). For ``x_c = a sin(w t)`` and ``x_m = a sin(w t - phi)`` one cycle gives
``TI = -pi a^2 sin(phi)``. Units: m2 (times a stiffness in N/m, J).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Integral
from typing import Any

import numpy as np

from ..types import FloatArray

__all__ = ['TrackingMonitor', 'TrackingSample', 'tracking_error', 'tracking_indicator']


def tracking_error(
    command: Sequence[float] | FloatArray, measured: Sequence[float] | FloatArray
) -> FloatArray:
    """History of the tracking error ``measured - command``.

    Args:
        command: Commanded displacements, shape ``(n,)`` or ``(n, n_dof)``, m.
        measured: Measured displacements, the same shape, m.

    Returns:
        ``measured - command``, the same shape (positive: beyond the command), m.

    Raises:
        ValueError: On different shapes or non-finite values.
    """
    c, m = _series(command, measured)
    return m - c


def tracking_indicator(
    command: Sequence[float] | FloatArray, measured: Sequence[float] | FloatArray
) -> FloatArray:
    """Running tracking indicator (Mercan and Ricles 2007) of a measured-vs-command history.

    ``TI_0 = 0`` and ``TI_{i+1} = TI_i + (x_m,i x_c,i+1 - x_m,i+1 x_c,i) / 2``, the trapezoidal
    form of ``(int x_m dx_c - int x_c dx_m) / 2``: zero for perfect tracking, ``oint x_m dx_c``
    over a closed cycle. Positive means energy removed from the test (measured leading the
    command), negative energy added (measured lagging); see the module docstring. Usable on a
    whole test's series, at the controller rate or one value per step.

    Args:
        command: Commanded displacements, shape ``(n,)`` or ``(n, n_dof)``, m.
        measured: Measured displacements, the same shape, m.

    Returns:
        The indicator after each sample, the same shape, m2.

    Raises:
        ValueError: On different shapes or non-finite values.
    """
    c, m = _series(command, measured)
    result = np.zeros_like(c)
    if c.shape[0] > 1:
        increments = 0.5 * (m[:-1] * c[1:] - m[1:] * c[:-1])
        result[1:] = np.cumsum(increments, axis=0)
    return result


@dataclass(frozen=True)
class TrackingSample:
    """The monitors after one sample (one value per DOF).

    Attributes:
        error: ``measured - command``, m.
        indicator: Tracking indicator so far, m2.
    """

    error: FloatArray
    indicator: FloatArray


class TrackingMonitor:
    """Incremental tracking error and indicator, for publishing during a test.

    Gives the same values as :func:`tracking_error` and :func:`tracking_indicator` on the whole
    series.
    """

    def __init__(self, n_dof: int = 1, *, keep_history: bool = True) -> None:
        """Create an empty monitor.

        Args:
            n_dof: Number of DOF.
            keep_history: keep every sample (the history properties); ``False`` keeps only
                the last sample and the running indicator, in constant memory (a live monitor
                of a test of any length, as the bridge's).

        Raises:
            ValueError: On a bad ``n_dof``.
        """
        if isinstance(n_dof, bool) or not isinstance(n_dof, Integral) or n_dof < 1:
            msg = f'TrackingMonitor: n_dof must be a positive integer, got {n_dof!r}'
            raise ValueError(msg)
        self._n: int = int(n_dof)
        self._keep: bool = keep_history
        self.reset()

    def reset(self) -> None:
        """Forget every sample."""
        self._commands: list[FloatArray] = []
        self._measured: list[FloatArray] = []
        self._errors: list[FloatArray] = []
        self._indicators: list[FloatArray] = []
        self._indicator = np.zeros(self._n)
        self._count = 0

    def update(
        self, command: Sequence[float] | FloatArray, measured: Sequence[float] | FloatArray
    ) -> TrackingSample:
        """Add one (command, measured) pair.

        Args:
            command: Commanded displacement per DOF, m.
            measured: Measured displacement per DOF, m.

        Returns:
            The error of this sample and the indicator so far.

        Raises:
            ValueError: On a malformed or non-finite value.
        """
        c = _vector(command, 'command', self._n)
        m = _vector(measured, 'measured', self._n)
        if self._commands:
            c0, m0 = self._commands[-1], self._measured[-1]
            self._indicator = self._indicator + 0.5 * (m0 * c - m * c0)
        error = m - c
        if not self._keep:  # only what the next sample needs
            self._commands.clear()
            self._measured.clear()
            self._errors.clear()
            self._indicators.clear()
        self._commands.append(c)
        self._measured.append(m)
        self._errors.append(error)
        self._indicators.append(self._indicator.copy())
        self._count += 1
        return TrackingSample(error.copy(), self._indicator.copy())

    @property
    def count(self) -> int:
        """Number of samples."""
        return self._count

    @property
    def indicator(self) -> FloatArray:
        """Tracking indicator so far per DOF, m2."""
        return self._indicator.copy()

    @property
    def commands(self) -> FloatArray:
        """Command history, shape ``(count, n_dof)``, m.

        Without ``keep_history``: the last sample only.
        """
        return _stack(self._commands, self._n)

    @property
    def measured(self) -> FloatArray:
        """Measured history, shape ``(count, n_dof)``, m."""
        return _stack(self._measured, self._n)

    @property
    def errors(self) -> FloatArray:
        """Tracking error history, shape ``(count, n_dof)``, m."""
        return _stack(self._errors, self._n)

    @property
    def indicators(self) -> FloatArray:
        """Tracking indicator history, shape ``(count, n_dof)``, m2."""
        return _stack(self._indicators, self._n)




# ---------------------------------------------------------------------- helpers


def _stack(rows: list[FloatArray], n: int) -> FloatArray:
    return np.array(rows) if rows else np.zeros((0, n))


def _series(command: Any, measured: Any) -> tuple[FloatArray, FloatArray]:
    c = np.asarray(command, dtype=float)
    m = np.asarray(measured, dtype=float)
    if c.shape != m.shape or c.ndim not in (1, 2):
        msg = (f'command and measured must have the same shape (n,) or (n, n_dof), got '
               f'{c.shape} and {m.shape}')
        raise ValueError(msg)
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(m))):
        msg = 'command and measured must be finite'
        raise ValueError(msg)
    return c, m


def _vector(values: Any, what: str, n: int) -> FloatArray:
    try:
        vector = np.array(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        msg = f'{what} must be a sequence of numbers, got {values!r}'
        raise ValueError(msg) from None
    if vector.size != n:
        msg = f'{what} has {vector.size} values, expected {n}'
        raise ValueError(msg)
    if not np.isfinite(vector).all():
        msg = f'non-finite {what}: {vector.tolist()}'
        raise ValueError(msg)
    return vector
