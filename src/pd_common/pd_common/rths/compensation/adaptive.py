"""The adaptive time-series (ATS) compensator (Chae, Kazemibidokhti & Ricles 2013): ``adaptive``.

The command is a linear combination of the target and its first two derivatives::

    u[k] = a_0 x_d[k] + a_1 ẋ_d[k] + a_2 ẍ_d[k]

(the derivatives from the last four targets: the derivatives of their interpolating cubic at
the newest sample, no lag). For a plant that is an amplitude ``A`` and a delay ``τ``,
``u = x_d(t + τ)/A ≈ (x_d + τ ẋ_d + τ² ẍ_d / 2)/A``. The initial coefficients are the
first-order part, ``a = (1/A, τ/A, 0)`` from the parameters ``amplitude`` and ``delay``:
``a_2`` starts at 0 and is left to the estimation — the pure delay's ``τ²/(2A)`` overestimates
the curvature of a plant whose amplitude falls with frequency (3.3e-4 s² against the
1.0e-4 s² the benchmark's plant gives) and, held through the 5 s of quiet before the record
(no excitation, no update), destabilises the loop of Case 4 on some perturbed plants. The
defaults are the nominal benchmark plant's low-frequency amplitude and delay, ``1/c_0`` =
1.011 and ``c_1/c_0`` = 25.1 ms of its identified model (:mod:`.model_based`); the estimates
settle within about a second of the record's start.

The coefficients are the inverse model of the plant, estimated online: every
``update_interval`` seconds, by least squares over the moving window of the last ``window``
seconds of the commands sent and the displacements measured,

    â = argmin Σ_window (u_f[j] − a_0 y_f[j] − a_1 ẏ_f[j] − a_2 ÿ_f[j])²

(``â = (Φᵀ Φ)⁻¹ Φᵀ U``, ``Φ`` the rows ``[y_f, ẏ_f, ÿ_f]``), then each coefficient clipped to its
bounds ``[a_i,min, a_i,max]``. ``u_f`` and ``y_f`` are the command and the measurement through
the same second-order Butterworth low-pass (``cutoff`` Hz; the relation ``u = a·[y, ẏ, ÿ]`` is
linear, so it holds for the filtered signals too, while the filter keeps the displacement
sensor's noise out of the differentiated regressors — the bias of least squares with noisy
regressors); ``ẏ_f``, ``ÿ_f`` by three-point backward differences. No update while the
window's RMS of ``y_f`` is below ``min_amplitude`` (no excitation: the normal equations are
singular).

Reference: C. Chae, K. Kazemibidokhti, J. M. Ricles, "Adaptive time series compensator for
delay compensation of servo-hydraulic actuator systems for real-time hybrid simulation",
Earthquake Engng Struct. Dyn. 42 (2013) 1697–1715.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, NoReturn

import numpy as np

from ...errors import RthsError
from .base import Compensator, CompensatorParameter, CompensatorSpec, register_compensator
from .polynomial import backward_derivative_weights

__all__ = ['ADAPTIVE', 'AdaptiveTimeSeries', 'initial_coefficients']

Bounds = tuple[tuple[float, float], tuple[float, float], tuple[float, float]]


def initial_coefficients(amplitude: float, delay: float) -> tuple[float, float, float]:
    """``(1/A, τ/A, 0)``: the first-order Taylor inverse of an amplitude and a delay."""
    return (1.0 / amplitude, delay / amplitude, 0.0)


def _fail(parameter: str, requirement: str, value: object) -> NoReturn:
    """Raise the one-line RthsError naming the compensator and ``parameter``."""
    msg = (f'compensator adaptive: parameter {parameter} must be {requirement}, '
           f'got {value!r}')
    raise RthsError(msg)


class AdaptiveTimeSeries(Compensator):
    """``u = a_0 x_d + a_1 ẋ_d + a_2 ẍ_d`` with ``a`` by moving-window least squares."""

    def __init__(self, dt: float, *, amplitude: float = 1.011, delay: float = 0.0251,
                 window: float = 1.5, update_interval: float = 0.05, cutoff: float = 10.0,
                 min_amplitude: float = 1e-4, bounds: Bounds = ((0.5, 2.0), (0.0, 0.1),
                                                                (0.0, 2e-3))) -> None:
        """Create it for sample period ``dt`` (s).

        Args:
            dt: Sample period, s.
            amplitude: The plant's amplitude A for the initial coefficients, > 0.
            delay: The plant's delay τ for the initial coefficients, s (>= 0).
            window: Length of the least-squares window, s (at least 16 samples).
            update_interval: Time between two estimates, s (at least one sample).
            cutoff: Corner of the low-pass on command and measurement, Hz (< Nyquist).
            min_amplitude: RMS of the filtered measurement over the window below which the
                coefficients are not updated, m (>= 0).
            bounds: ``((a0_min, a0_max), (a1_min, a1_max), (a2_min, a2_max))``; the initial
                coefficients must lie within them.

        Raises:
            RthsError: One line naming the parameter on a bad value.
        """
        super().__init__(dt)
        if not (math.isfinite(amplitude) and amplitude > 0.0):
            _fail('amplitude', 'a finite number > 0', amplitude)
        if not (math.isfinite(delay) and delay >= 0.0):
            _fail('delay', 'a finite number >= 0', delay)
        if not (math.isfinite(window) and window >= 16 * self.dt):
            _fail('window', f'at least 16 samples ({16 * self.dt!r} s)', window)
        if not (math.isfinite(update_interval) and update_interval >= self.dt):
            _fail('update_interval', f'at least one sample ({self.dt!r} s)',
                        update_interval)
        if not (math.isfinite(cutoff) and 0.0 < cutoff < 0.5 / self.dt):
            _fail('cutoff', 'in (0, Nyquist) Hz', cutoff)
        if not (math.isfinite(min_amplitude) and min_amplitude >= 0.0):
            _fail('min_amplitude', 'a finite number >= 0', min_amplitude)
        initial = initial_coefficients(amplitude, delay)
        for i, ((low, high), a) in enumerate(zip(bounds, initial, strict=True)):
            if not (math.isfinite(low) and math.isfinite(high) and low <= high):
                _fail(f'a{i}_min/a{i}_max', 'finite with min <= max', (low, high))
            if not low <= a <= high:
                _fail(f'a{i}_min/a{i}_max', f'around the initial a{i} = {a!r}',
                            (low, high))
        self.initial = initial
        self.bounds: Bounds = (
            (float(bounds[0][0]), float(bounds[0][1])), (float(bounds[1][0]),
                                                         float(bounds[1][1])),
            (float(bounds[2][0]), float(bounds[2][1])))
        self.window = max(16, round(window / self.dt))
        self.update_every = max(1, round(update_interval / self.dt))
        self.min_amplitude = float(min_amplitude)
        self._d1 = tuple(backward_derivative_weights(1, 4, self.dt))
        self._d2 = tuple(backward_derivative_weights(2, 4, self.dt))
        self._r1 = tuple(backward_derivative_weights(1, 3, self.dt))
        self._r2 = tuple(backward_derivative_weights(2, 3, self.dt))
        from scipy import signal  # noqa: PLC0415 - 0.5 s to import: not on a node's start-up
        sos = signal.butter(2, cutoff, fs=1.0 / self.dt, output='sos')
        b0, b1, b2, _a0, a1, a2 = (float(v) for v in sos[0])
        self._biquad = (b0, b1, b2, a1, a2)
        self.reset()

    @property
    def coefficients(self) -> tuple[float, float, float]:
        """The current ``(a_0, a_1, a_2)``."""
        return (self._a0, self._a1, self._a2)

    @property
    def updates(self) -> int:
        """How many least-squares estimates have been applied since the reset."""
        return self._updates

    def reset(self) -> None:
        """Back to the initial coefficients; forget the window."""
        self._a0, self._a1, self._a2 = self.initial
        self._targets = [0.0, 0.0, 0.0, 0.0]
        self._yf = [0.0, 0.0, 0.0]
        self._fu = [0.0, 0.0]            # the biquads' states (transposed direct form II)
        self._fy = [0.0, 0.0]
        self._phi = np.zeros((self.window, 3))
        self._rhs = np.zeros(self.window)
        self._row = 0
        self._filled = 0
        self._since = 0
        self._updates = 0

    def _filter(self, state: list[float], x: float) -> float:
        b0, b1, b2, a1, a2 = self._biquad
        y = b0 * x + state[0]
        state[0] = b1 * x - a1 * y + state[1]
        state[1] = b2 * x - a2 * y
        return y

    def _record(self, command: float, measured: float) -> None:
        """Add the sample (command, measurement) to the window."""
        uf = self._filter(self._fu, command)
        yf = self._filter(self._fy, measured)
        history = self._yf
        history.pop()
        history.insert(0, yf)
        r1, r2 = self._r1, self._r2
        velocity = r1[0] * history[0] + r1[1] * history[1] + r1[2] * history[2]
        acceleration = r2[0] * history[0] + r2[1] * history[1] + r2[2] * history[2]
        row = self._row
        self._phi[row, 0] = yf
        self._phi[row, 1] = velocity
        self._phi[row, 2] = acceleration
        self._rhs[row] = uf
        self._row = (row + 1) % self.window
        self._filled = min(self._filled + 1, self.window)

    def _update(self) -> None:
        """The least-squares estimate over the window, clipped to the bounds."""
        if self._filled < self.window:
            return
        phi, rhs = self._phi, self._rhs
        gram = phi.T @ phi  # ΦᵀΦ (3 × 3, one BLAS call: no window-size temporaries)
        if math.sqrt(float(gram[0, 0]) / self.window) < self.min_amplitude:
            return
        scale = np.sqrt(np.diag(gram))
        if not np.all(scale > 0.0):
            return
        normal = gram / np.outer(scale, scale)   # the normal equations of the scaled columns
        if np.linalg.cond(normal) > 1e12:
            return
        estimate = np.linalg.solve(normal, (phi.T @ rhs) / scale) / scale
        (l0, h0), (l1, h1), (l2, h2) = self.bounds
        self._a0 = min(max(float(estimate[0]), l0), h0)
        self._a1 = min(max(float(estimate[1]), l1), h1)
        self._a2 = min(max(float(estimate[2]), l2), h2)
        self._updates += 1

    def command(self, target: float, measured: float) -> float:
        """``u[k]`` for ``x_d[k]`` and ``x_m[k]``; then ``(u[k], x_m[k])`` joins the window."""
        targets = self._targets
        targets.pop()
        targets.insert(0, target)
        d1, d2 = self._d1, self._d2
        velocity = (d1[0] * targets[0] + d1[1] * targets[1] + d1[2] * targets[2]
                    + d1[3] * targets[3])
        acceleration = (d2[0] * targets[0] + d2[1] * targets[1] + d2[2] * targets[2]
                        + d2[3] * targets[3])
        u = self._a0 * target + self._a1 * velocity + self._a2 * acceleration
        self._record(u, measured)
        self._since += 1
        if self._since >= self.update_every:
            self._since = 0
            self._update()
        return u


def _factory(dt: float, p: Mapping[str, Any]) -> Compensator:
    """``adaptive`` from its resolved parameters."""
    bounds: Bounds = ((p['a0_min'], p['a0_max']), (p['a1_min'], p['a1_max']),
                      (p['a2_min'], p['a2_max']))
    return AdaptiveTimeSeries(dt, amplitude=p['amplitude'], delay=p['delay'],
                              window=p['window'], update_interval=p['update_interval'],
                              cutoff=p['cutoff'], min_amplitude=p['min_amplitude'],
                              bounds=bounds)


ADAPTIVE = register_compensator(CompensatorSpec(
    name='adaptive', factory=_factory,
    parameters=(
        CompensatorParameter('amplitude', 1.011, "the plant's amplitude A: initial a0 = 1/A"),
        CompensatorParameter('delay', 0.0251,
                             "the plant's delay tau, s: initial a1 = tau/A (a2 starts at 0)"),
        CompensatorParameter('window', 1.5, 'length of the least-squares window, s'),
        CompensatorParameter('update_interval', 0.05, 'time between two estimates, s'),
        CompensatorParameter('cutoff', 10.0, 'corner of the low-pass on command and '
                                             'measurement before the regression, Hz'),
        CompensatorParameter('min_amplitude', 1e-4,
                             'no update while the RMS of the filtered measurement over the '
                             'window is below this, m'),
        CompensatorParameter('a0_min', 0.5, 'lower bound of a0'),
        CompensatorParameter('a0_max', 2.0, 'upper bound of a0'),
        CompensatorParameter('a1_min', 0.0, 'lower bound of a1, s'),
        CompensatorParameter('a1_max', 0.1, 'upper bound of a1, s'),
        CompensatorParameter('a2_min', 0.0, 'lower bound of a2, s^2'),
        CompensatorParameter('a2_max', 2e-3, 'upper bound of a2, s^2'),
    ),
    description='adaptive time series (Chae, Kazemibidokhti & Ricles 2013): u = a0 x_d + '
                'a1 v_d + a2 a_d, a by moving-window least squares on u and x_m, bounded'))
