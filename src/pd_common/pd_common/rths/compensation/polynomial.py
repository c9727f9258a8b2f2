"""Polynomial extrapolation of the target over a constant delay (Horiuchi et al. 1999).

``polynomial``.

The transfer system answers a command about ``τ`` later (the benchmark's plant: about 24 ms
at the structure's first mode) and with an amplitude ``A``. The compensator sends the target
extrapolated ``τ`` ahead by the polynomial of degree ``n`` (1–3) through the last ``n + 1``
targets at the controller rate (``x_d[k]``, ``x_d[k−1]``, …, ``x_d[k−n]``), divided by the
amplitude, plus an optional PI feedback on the tracking error ``e = x_d − x_m``::

    u[k] = (1/A) Σ_{i=0..n} w_i x_d[k−i] + k_p e[k] + k_i Σ_j e[j] dt

with the Lagrange weights ``w_i = Π_{j≠i} (p + j)/(j − i)``, ``p = τ/dt`` (for n = 1:
``(1 + p) x_k − p x_{k−1}``; the extrapolation is exact for a target that is a polynomial of
degree ``n``). Reference: M. Horiuchi, M. Inoue, T. Konno, Y. Namita, "Real-time hybrid
experimental system with actuator delay compensation and its application to a piping system
with energy absorber", Earthquake Engng Struct. Dyn. 28 (1999) 1121–1141.

:func:`lagrange_weights` (also the backward-difference derivatives of the other compensators)
is the weights of a value or derivative of the interpolating polynomial through equally
spaced samples.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ...errors import RthsError
from .base import Compensator, CompensatorParameter, CompensatorSpec, register_compensator

__all__ = [
    'POLYNOMIAL',
    'PolynomialExtrapolation',
    'backward_derivative_weights',
    'lagrange_weights',
    'push_and_filter',
]


def lagrange_weights(nodes: Sequence[float], point: float, derivative: int = 0) -> list[float]:
    """The weights of a derivative of the interpolating polynomial at ``point``.

    The weights ``w`` with ``p^{(d)}(point) = Σ w_i f(nodes[i])`` for the polynomial ``p``
    of degree ``len(nodes) − 1`` through ``(nodes[i], f_i)`` (``d = derivative``).

    Solved from the moment conditions ``Σ w_i (node_i − point)^m = m! δ_{md}``, m = 0…n
    (exact for every polynomial of degree ≤ n).

    Raises:
        RthsError: On repeated nodes or a derivative order above the degree.
    """
    x = np.asarray(nodes, dtype=np.float64) - float(point)
    n = x.size
    if n == 0 or len(set(x.tolist())) != n:
        msg = 'lagrange_weights: the nodes must be distinct (one or more)'
        raise RthsError(msg)
    if not 0 <= derivative < n:
        msg = f'lagrange_weights: derivative must be 0…{n - 1}, got {derivative!r}'
        raise RthsError(msg)
    vandermonde = np.vander(x, n, increasing=True).T     # row m: x_i^m
    rhs = np.zeros(n)
    rhs[derivative] = math.factorial(derivative)
    return [float(v) for v in np.linalg.solve(vandermonde, rhs)]


def backward_derivative_weights(derivative: int, points: int, dt: float) -> list[float]:
    """The weights of a backward derivative from the last ``points`` samples.

    The weights of the ``derivative``-th derivative at sample ``k`` from the samples
    ``k, k−1, …, k−points+1`` (spacing ``dt``): the derivative of their interpolating
    polynomial (no lag; exact for a polynomial of degree ``points − 1``).
    """
    unit = lagrange_weights([-float(i) for i in range(points)], 0.0, derivative)
    return [w / dt ** derivative for w in unit]


def push_and_filter(history: list[float], weights: Sequence[float], value: float) -> float:
    """Shift ``value`` into ``history`` and return the FIR output.

    Shift ``value`` into ``history`` (newest first, its length kept) and return the FIR
    output ``Σ w_i history_i`` (the feed-forward of the polynomial and model-based
    compensators).
    """
    history.pop()
    history.insert(0, value)
    total = 0.0
    for w, x in zip(weights, history, strict=True):
        total += w * x
    return total


def _check(name: str, parameter: str, ok: bool, requirement: str, value: object) -> None:
    if not ok:
        msg = f'compensator {name}: parameter {parameter} must be {requirement}, got {value!r}'
        raise RthsError(msg)


class PolynomialExtrapolation(Compensator):
    """``u = (1/A) x̂_d(t + τ) + PI(e)``: the target extrapolated over the delay."""

    def __init__(self, dt: float, *, delay: float = 0.0237, order: int = 3,
                 amplitude: float = 0.93, kp: float = 0.0, ki: float = 0.0) -> None:
        """Create it for sample period ``dt`` (s).

        Args:
            dt: Sample period, s.
            delay: The delay ``τ`` to compensate, s (>= 0).
            order: Degree ``n`` of the extrapolating polynomial, 1–3.
            amplitude: The plant's amplitude ``A`` (the command is divided by it), > 0.
            kp: Proportional gain of the feedback on ``x_d − x_m`` (>= 0).
            ki: Integral gain of the feedback, 1/s (>= 0).

        Raises:
            RthsError: One line naming the parameter on a bad value.
        """
        super().__init__(dt)
        name = 'polynomial'
        _check(name, 'delay', math.isfinite(delay) and delay >= 0.0, 'a finite number >= 0',
               delay)
        _check(name, 'order', isinstance(order, int) and 1 <= order <= 3, '1, 2 or 3', order)
        _check(name, 'amplitude', math.isfinite(amplitude) and amplitude > 0.0,
               'a finite number > 0', amplitude)
        for key, value in (('kp', kp), ('ki', ki)):
            _check(name, key, math.isfinite(value) and value >= 0.0, 'a finite number >= 0',
                   value)
        self.delay, self.order, self.amplitude = float(delay), int(order), float(amplitude)
        self.kp, self.ki = float(kp), float(ki)
        p = self.delay / self.dt
        weights = lagrange_weights([-float(i) for i in range(self.order + 1)], p)
        self.weights = tuple(w / self.amplitude for w in weights)
        self.reset()

    def reset(self) -> None:
        """Forget the past targets and the integral."""
        self._history = [0.0] * (self.order + 1)
        self._integral = 0.0

    def command(self, target: float, measured: float) -> float:
        """``u[k]`` for ``x_d[k]`` and ``x_m[k]``."""
        u = push_and_filter(self._history, self.weights, target)
        if self.kp or self.ki:
            error = target - measured
            self._integral += error * self.dt
            u += self.kp * error + self.ki * self._integral
        return u


def _factory(dt: float, p: Mapping[str, Any]) -> Compensator:
    """``polynomial`` from its resolved parameters."""
    return PolynomialExtrapolation(dt, delay=p['delay'], order=p['order'],
                                   amplitude=p['amplitude'], kp=p['kp'], ki=p['ki'])


POLYNOMIAL = register_compensator(CompensatorSpec(
    name='polynomial', factory=_factory,
    parameters=(
        CompensatorParameter('delay', 0.0237, 'the delay tau to compensate, s (>= 0)'),
        CompensatorParameter('order', 3, 'degree of the extrapolating polynomial, 1-3 '
                                         '(through the last order+1 targets)'),
        CompensatorParameter('amplitude', 0.93,
                             "the plant's amplitude A: the command is divided by it (> 0)"),
        CompensatorParameter('kp', 0.0, 'proportional gain of the feedback on x_d - x_m '
                                        '(>= 0; 0: none)'),
        CompensatorParameter('ki', 0.0, 'integral gain of the feedback, 1/s (>= 0; 0: none)'),
    ),
    description='polynomial extrapolation of the target over a constant delay (Horiuchi '
                'et al. 1999): u = x_d(t + delay)/A [+ kp e + ki int e]'))
