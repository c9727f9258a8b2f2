"""Model-based compensation.

Feed-forward through the inverse of an identified all-pole model of the transfer system, plus PI
feedback on the tracking error: ``model_based``.

The model (continuous, all-pole, order ``n`` = 1–4, the coefficient ``c_i`` in s^i)::

    G_m(s) = 1 / (c_0 + c_1 s + … + c_n s^n)

Its inverse is the polynomial ``c_0 + c_1 s + … + c_n s^n``, times ``1 + s dt/2`` for the
zero-order hold of the command (below): ``Σ_{i=0..n+1} c'_i s^i`` with
``c'_i = c_i + c_{i−1} dt/2``. Improper, it is made causal by evaluating each derivative of
the target from the last ``n + 2`` targets (the derivative of their interpolating polynomial
at the newest sample, :func:`~.polynomial.backward_derivative_weights`: no lag, exact for a
target that is a polynomial of degree ``n + 1``; the target is the smooth output of the
numerical substructure). The command::

    u[k] = Σ_i c'_i D_i x_d[k] + C(z) e[k],    e = x_d − x_m,   C(s) = k_p + k_i / s

with the PI ``C`` discretised by Tustin (:func:`scipy.signal.cont2discrete`, as PI-P), and
``e`` low-passed first (first-order, Tustin, ``feedback_cutoff`` Hz; 0: not filtered) so the
feedback does not pass the displacement sensor's white noise on to the command. The feedback
corrects what the model misses (an uncertain plant: the benchmark's perturbed plants differ by
±2.5 % in amplitude and ±1.3 ms in delay at 3.6 Hz); defaults ``k_p`` = 1, ``k_i`` = 100/s,
40 Hz, tuned on the benchmark (``bench/rths_compensators.py``).

*Identification* (:func:`identify_all_pole`): the model's coefficients by linear least
squares on an input/output record of the plant (command ``u``, displacement ``y``), with a
state-variable filter (Young 1981): both signals pass through
``F(s) = 1/(1 + s/ω_f)^{n+1}`` and the derivatives of the filtered displacement are the outputs
of ``s^i F(s)`` (proper for i ≤ n), so that ``F u = Σ c_i (s^i F) y`` holds exactly and is
linear in ``c``. :func:`identification_record` runs a band-limited random command through a
plant. The defaults are the identified model of the nominal benchmark plant (order 3,
``ω_f`` = 2π·20 Hz, 60 s of 0–20 Hz random command, 1 mm RMS):
``c = (0.98874, 2.4834e-2, 1.0088e-4, 3.6200e-7)`` — a static gain 1/c_0 = 1.011 and
a delay c_1/c_0 = 25.1 ms at low frequency. The command is held over each sample (zero-order
hold, the identification's ``'zoh'`` reading of the command), which delays it by about half
a sample: the inverse is that of ``G_m(s) e^{−s dt/2}``, ``(1 + s dt/2) Σ c_i s^i`` to first
order — a polynomial of order ``n + 1``, its derivatives from the last ``n + 2`` targets.

References: P. Young, "Parameter estimation for continuous-time models — a survey",
Automatica 17 (1981) 23–39; C. E. Silva, D. Gomez, A. Maghareh, S. J. Dyke, B. F. Spencer
Jr., "Benchmark control problem for real-time hybrid simulation", Mech. Syst. Signal Process.
135 (2020) 106381, for the feedback-plus-feed-forward scheme (its PI-P, :mod:`.pi_p`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, NoReturn

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import RthsError
from ..base import TransferSystem
from .base import Compensator, CompensatorParameter, CompensatorSpec, register_compensator
from .polynomial import backward_derivative_weights, push_and_filter

__all__ = ['MODEL_BASED', 'NOMINAL_MODEL', 'ModelBasedController', 'identification_record',
           'identify_all_pole', 'state_variable_filter']

#: The identified all-pole model of the nominal benchmark plant (order 3; module docstring).
NOMINAL_MODEL = (0.988744962, 2.48336148e-2, 1.00875466e-4, 3.62004363e-7)
#: The highest model order.
MAX_ORDER = 4


def state_variable_filter(x: ArrayLike, order: int, cutoff: float, dt: float,
                          hold: str = 'foh') -> NDArray[np.float64]:
    """The state-variable filter ``[(s^i F) x for i = 0…order]`` of ``x``.

    ``[(s^i F) x for i = 0…order]`` with ``F(s) = 1/(1 + s/ω_f)^{order+1}``,
    ``ω_f = 2π cutoff``; ``(order + 1, len(x))``.

    Each filter is discretised exactly (:func:`scipy.signal.cont2discrete`) for the samples
    ``x`` read as the continuous signal ``hold``: ``'zoh'`` a staircase (a command held over
    each sample), ``'foh'`` linear between the samples (a measured, smooth signal). In the
    normalised time ``t ω_f`` (the coefficients of ``σ^i/(1+σ)^{n+1}`` are of order one),
    scaled back by ``ω_f^i``.
    """
    from scipy import signal  # noqa: PLC0415 - 0.5 s to import: not on a node's start-up
    samples = np.asarray(x, dtype=np.float64)
    wf = 2.0 * math.pi * cutoff
    den = np.poly(-np.ones(order + 1))            # (σ + 1)^(n+1)
    rows = []
    for i in range(order + 1):
        num = np.zeros(i + 1)
        num[0] = 1.0                              # σ^i
        ss = signal.tf2ss(num, den)
        ad, bd, cd, dd, _dt = signal.cont2discrete(ss, dt * wf, method=hold)
        b, a = signal.ss2tf(ad, bd, cd, dd)
        rows.append(wf ** i * signal.lfilter(np.ravel(b), np.ravel(a), samples))
    return np.asarray(rows, dtype=np.float64)


def identify_all_pole(command: ArrayLike, displacement: ArrayLike, dt: float, order: int = 3,
                      cutoff: float = 20.0) -> tuple[float, ...]:
    """The all-pole model ``G_m = 1/Σ c_i s^i`` that fits the record best.

    The coefficients ``(c_0, …, c_n)`` of ``G_m = 1/Σ c_i s^i`` that fit the record best
    (least squares, state-variable filter of cutoff ``cutoff`` Hz; module docstring).

    Args:
        command: The command ``u[k]`` held over each sample, m.
        displacement: The plant's displacement ``y[k]``, m (same length).
        dt: Sample period, s.
        order: The model's order ``n``, 1–4.
        cutoff: The state-variable filter's corner, Hz (about the top of the band to fit).

    Raises:
        RthsError: On records of different lengths or too short, or a bad order / cutoff.
    """
    u = np.asarray(command, dtype=np.float64)
    y = np.asarray(displacement, dtype=np.float64)
    if u.ndim != 1 or u.shape != y.shape or u.size < 10 * (order + 1):
        msg = 'identify_all_pole: command and displacement must be 1-D of the same length'
        raise RthsError(msg)
    if not (isinstance(order, int) and 1 <= order <= MAX_ORDER):
        msg = f'identify_all_pole: order must be 1…{MAX_ORDER}, got {order!r}'
        raise RthsError(msg)
    if not (math.isfinite(dt) and dt > 0.0 and math.isfinite(cutoff)
            and 0.0 < cutoff < 0.25 / dt):
        msg = f'identify_all_pole: need dt > 0 and 0 < cutoff < 1/(4 dt), got {cutoff!r}'
        raise RthsError(msg)
    regressors = state_variable_filter(y, order, cutoff, dt, 'foh')
    filtered_u = state_variable_filter(u, order, cutoff, dt, 'zoh')[0]   # the same F on u
    coefficients, *_ = np.linalg.lstsq(regressors.T, filtered_u, rcond=None)
    return tuple(float(c) for c in coefficients)


def identification_record(plant: TransferSystem, seconds: float = 60.0,
                          bandwidth: float = 20.0, rms: float = 1e-3, seed: int = 1
                          ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A band-limited random command and the displacement ``plant`` gives for it.

    ``(u, y)``: a band-limited random command (white Gaussian through a 4th-order
    Butterworth low-pass at ``bandwidth`` Hz, scaled to ``rms`` m) run through ``plant``
    (reset first) at its rate, and the plant's displacement.
    """
    from scipy import signal  # noqa: PLC0415 - 0.5 s to import: not on a node's start-up
    dt = plant.dt
    n = round(seconds / dt)
    rng = np.random.default_rng(seed)
    sos = signal.butter(4, bandwidth, fs=1.0 / dt, output='sos')
    u = np.asarray(signal.sosfilt(sos, rng.standard_normal(n)), dtype=np.float64)
    u *= rms / float(np.std(u))
    y = np.empty(n)
    plant.reset()
    for k in range(n):
        y[k] = plant.output()
        plant.advance(float(u[k]))
    return u, y


def _tustin(a: float, b: float, c: float, d: float, dt: float
            ) -> tuple[float, float, float, float]:
    """The Tustin discretisation of a scalar first-order system.

    The Tustin discretisation of the scalar ``ẋ = a x + b e``, ``y = c x + d e``
    (:func:`scipy.signal.cont2discrete`): ``(a_d, b_d, c_d, d_d)``.
    """
    from scipy import signal  # noqa: PLC0415 - 0.5 s to import: not on a node's start-up
    ad, bd, cd, dd, _dt = signal.cont2discrete(
        (np.array([[a]]), np.array([[b]]), np.array([[c]]), np.array([[d]])), dt,
        method='bilinear')
    return (float(ad[0, 0]), float(bd[0, 0]), float(cd[0, 0]), float(dd[0, 0]))


def _fail(parameter: str, requirement: str, value: object) -> NoReturn:
    """Raise the one-line RthsError naming the compensator and ``parameter``."""
    msg = (f'compensator model_based: parameter {parameter} must be {requirement}, '
           f'got {value!r}')
    raise RthsError(msg)


class ModelBasedController(Compensator):
    """``u = G_m⁻¹ x_d + C(z) LP(z) (x_d − x_m)`` (module docstring)."""

    def __init__(self, dt: float, coefficients: Sequence[float] = NOMINAL_MODEL, *,
                 kp: float = 1.0, ki: float = 100.0, feedback_cutoff: float = 40.0) -> None:
        """Create it for sample period ``dt`` (s).

        Args:
            dt: Sample period, s.
            coefficients: ``(c_0, …, c_n)`` of the model, n = 1…4 (``c_0 > 0``).
            kp: Proportional gain of the feedback (>= 0).
            ki: Integral gain of the feedback, 1/s (>= 0).
            feedback_cutoff: Corner of the first-order low-pass on the error, Hz (0: none).

        Raises:
            RthsError: One line naming the parameter on a bad value.
        """
        super().__init__(dt)
        c = [float(v) for v in coefficients]
        if not 2 <= len(c) <= MAX_ORDER + 1:
            _fail('order', f'1…{MAX_ORDER}', len(c) - 1)
        for i, value in enumerate(c):
            if not math.isfinite(value):
                _fail(f'c{i}', 'finite', value)
        if c[0] <= 0.0:
            _fail('c0', '> 0 (a positive static gain)', c[0])
        for name, value in (('kp', kp), ('ki', ki)):
            if not (math.isfinite(value) and value >= 0.0):
                _fail(name, 'a finite number >= 0', value)
        if not (math.isfinite(feedback_cutoff) and 0.0 <= feedback_cutoff < 0.5 / self.dt):
            _fail('feedback_cutoff', 'in [0, Nyquist) Hz', feedback_cutoff)
        self.coefficients = tuple(c)
        self.order = len(c) - 1
        points = self.order + 2
        # (1 + s dt/2) Σ c_i s^i: the inverse of the model behind the zero-order hold.
        held = [*c, 0.0]
        for i in range(1, len(held)):
            held[i] += 0.5 * self.dt * c[i - 1]
        stencil = np.zeros(points)
        for i, ci in enumerate(held):
            stencil += ci * np.asarray(backward_derivative_weights(i, points, self.dt))
        #: The feed-forward as one FIR filter on x_d[k], x_d[k−1], …
        self.feedforward = tuple(float(v) for v in stencil)
        self.kp, self.ki = float(kp), float(ki)
        self.feedback = self.kp > 0.0 or self.ki > 0.0
        # x⁺ = a x + b e, output c x + d e: the PI (kp + ki/s) and the low-pass wc/(s + wc).
        self._pi = _tustin(0.0, self.ki, 1.0, self.kp, self.dt)
        wc = 2.0 * math.pi * feedback_cutoff
        self._lp = (_tustin(-wc, wc, 1.0, 0.0, self.dt) if feedback_cutoff > 0.0
                    else (0.0, 0.0, 0.0, 1.0))
        self.reset()

    def reset(self) -> None:
        """Forget the past."""
        self._history = [0.0] * len(self.feedforward)
        self._lp_state = 0.0
        self._pi_state = 0.0

    def command(self, target: float, measured: float) -> float:
        """``u[k]`` for ``x_d[k]`` and ``x_m[k]``."""
        u = push_and_filter(self._history, self.feedforward, target)
        if self.feedback:
            raw = target - measured
            a, b, c, d = self._lp
            error = c * self._lp_state + d * raw
            self._lp_state = a * self._lp_state + b * raw
            a, b, c, d = self._pi
            u += c * self._pi_state + d * error
            self._pi_state = a * self._pi_state + b * error
        return u


def _factory(dt: float, p: Mapping[str, Any]) -> Compensator:
    """``model_based`` from its resolved parameters."""
    order = p['order']
    if not (isinstance(order, int) and 1 <= order <= MAX_ORDER):
        _fail('order', f'1…{MAX_ORDER}', order)
    coefficients = [p[f'c{i}'] for i in range(order + 1)]
    return ModelBasedController(dt, coefficients, kp=p['kp'], ki=p['ki'],
                                feedback_cutoff=p['feedback_cutoff'])


_C_UNITS = ('', ', s', ', s^2', ', s^3', ', s^4')
MODEL_BASED = register_compensator(CompensatorSpec(
    name='model_based', factory=_factory,
    parameters=(
        CompensatorParameter('order', 3, f'order n of the all-pole model, 1-{MAX_ORDER} '
                                         '(uses c0..cn)'),
        *(CompensatorParameter(f'c{i}', NOMINAL_MODEL[i] if i < len(NOMINAL_MODEL) else 0.0,
                               f'coefficient of s^{i} of the model G = 1/sum(c_i s^i)'
                               f'{_C_UNITS[i]} (default: the nominal plant identified)')
          for i in range(MAX_ORDER + 1)),
        CompensatorParameter('kp', 1.0, 'proportional gain of the PI feedback on x_d - x_m '
                                        '(>= 0)'),
        CompensatorParameter('ki', 100.0, 'integral gain of the PI feedback, 1/s (>= 0)'),
        CompensatorParameter('feedback_cutoff', 40.0,
                             'corner of the low-pass on the tracking error, Hz (0: none)'),
    ),
    description='feed-forward through the inverse of an identified all-pole plant model '
                '(target derivatives by backward differences) plus PI feedback'))
