"""The vRTHS benchmark's example controller PI-P (Silva, Dyke et al. 2020): ``pi_p``.

``u = C(s) (G_T(s) x_d − x_m)`` with the PI tracking controller ``C(s) = k_p + k_i / s``
(2 + 95/s) and the phase-lead feed-forward filter
``G_T(s) = (b_1 s + b_0) / (s + a_0)`` (50.8316 s + 8570.40)/(s + 8570.40), both discretised
by Tustin (bilinear) at the compensator's sample period with
:func:`scipy.signal.cont2discrete`. It is the baseline every entry of the benchmark is
compared with.

The benchmark's controller model also passes the target, the filter's output and the tracking
error through 18-bit converters; ``quantum`` (m, 0 by default: off) reproduces them. The
command's D/A and the measurement's A/D are the loop's (see the benchmark loop).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ...errors import RthsError
from ..base import quantise
from .base import Compensator, CompensatorParameter, CompensatorSpec, register_compensator

__all__ = ['PI_P', 'PiPController', 'tustin_first_order']


def tustin_first_order(num: tuple[float, float], den: tuple[float, float],
                       dt: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """The Tustin discretisation of ``(num[0] s + num[1]) / (den[0] s + den[1])``.

    Returns:
        ``((n0, n1), (1, d1))``: ``y[k] = n0 x[k] + n1 x[k−1] − d1 y[k−1]``.
    """
    from scipy import signal  # noqa: PLC0415 - 0.5 s to import: not on a node's start-up
    numd, dend, _dt = signal.cont2discrete(([num[0], num[1]], [den[0], den[1]]), dt,
                                          method='bilinear')
    n = [float(v) for v in numd.ravel()]
    d = [float(v) for v in dend.ravel()]
    return (n[0] / d[0], n[1] / d[0]), (1.0, d[1] / d[0])


class PiPController(Compensator):
    """PI-P: a Tustin PI controller on the feed-forward-filtered tracking error."""

    def __init__(self, dt: float, *, kp: float = 2.0, ki: float = 95.0,
                 ff_num1: float = 50.8316, ff_num0: float = 8570.40, ff_den0: float = 8570.40,
                 quantum: float = 0.0) -> None:
        """Create it for sample period ``dt`` (s).

        Args:
            dt: Sample period, s.
            kp: Proportional gain of C(s).
            ki: Integral gain of C(s), 1/s.
            ff_num1: Coefficient of s in the numerator of G_T(s), s.
            ff_num0: Constant of the numerator of G_T(s), 1/s.
            ff_den0: Pole of G_T(s): the denominator is s + ff_den0, 1/s.
            quantum: Quantisation step of the controller's own converters, m (0: none).

        Raises:
            RthsError: On a non-finite parameter, ``ff_den0 <= 0`` or ``quantum < 0``.
        """
        super().__init__(dt)
        values = {'kp': kp, 'ki': ki, 'ff_num1': ff_num1, 'ff_num0': ff_num0,
                  'ff_den0': ff_den0, 'quantum': quantum}
        for name, value in values.items():
            if not math.isfinite(value):
                msg = f'compensator pi_p: parameter {name} must be finite, got {value!r}'
                raise RthsError(msg)
        if ff_den0 <= 0.0:
            msg = (f'compensator pi_p: parameter ff_den0 must be > 0 (a stable filter), '
                   f'got {ff_den0!r}')
            raise RthsError(msg)
        if quantum < 0.0:
            msg = f'compensator pi_p: parameter quantum must be >= 0, got {quantum!r}'
            raise RthsError(msg)
        self.kp, self.ki = float(kp), float(ki)
        self.quantum = float(quantum)
        # C(s) = (kp s + ki) / s and G_T(s), Tustin.
        (self._c0, self._c1), (_one, self._cd1) = tustin_first_order(
            (self.kp, self.ki), (1.0, 0.0), self.dt)
        (self._f0, self._f1), (_one, self._fd1) = tustin_first_order(
            (float(ff_num1), float(ff_num0)), (1.0, float(ff_den0)), self.dt)
        self.reset()

    def reset(self) -> None:
        """Zero the filters' past."""
        self._target_prev = 0.0
        self._filtered_prev = 0.0
        self._error_prev = 0.0
        self._command_prev = 0.0

    def command(self, target: float, measured: float) -> float:
        """``u[k]`` for ``x_d[k]`` and ``x_m[k]``."""
        q = self.quantum
        x_d = quantise(target, q)
        filtered = self._f0 * x_d + self._f1 * self._target_prev - self._fd1 * self._filtered_prev
        self._target_prev = x_d
        self._filtered_prev = filtered
        error = quantise(quantise(filtered, q) - measured, q)
        u = self._c0 * error + self._c1 * self._error_prev - self._cd1 * self._command_prev
        self._error_prev = error
        self._command_prev = u
        return u


def _factory(dt: float, p: Mapping[str, Any]) -> Compensator:
    """``pi_p`` from its resolved parameters."""
    return PiPController(dt, kp=p['kp'], ki=p['ki'], ff_num1=p['ff_num1'],
                         ff_num0=p['ff_num0'], ff_den0=p['ff_den0'], quantum=p['quantum'])


PI_P = register_compensator(CompensatorSpec(
    name='pi_p', factory=_factory,
    parameters=(
        CompensatorParameter('kp', 2.0, 'proportional gain of C(s) = kp + ki/s'),
        CompensatorParameter('ki', 95.0, 'integral gain of C(s), 1/s'),
        CompensatorParameter('ff_num1', 50.8316,
                             'feed-forward G_T(s) = (ff_num1 s + ff_num0)/(s + ff_den0): '
                             'coefficient of s, s'),
        CompensatorParameter('ff_num0', 8570.40, 'feed-forward numerator constant, 1/s'),
        CompensatorParameter('ff_den0', 8570.40, 'feed-forward pole, 1/s'),
        CompensatorParameter('quantum', 0.0,
                             "the controller's own converters' step, m (0: none; the "
                             'benchmark model: 2**-18)'),
    ),
    description="the vRTHS benchmark's example: u = C(s)(G_T(s) x_d - x_m), C = 2 + 95/s, "
                'G_T = (50.8316 s + 8570.40)/(s + 8570.40), Tustin'))
