"""Exact reference solutions for verifying the integration schemes.

Every function here solves the *continuous* equation of motion exactly (to rounding) for an
excitation that is **piecewise linear** between samples ``t_i = i·Δt``, which is how a digitised
ground motion is interpreted. A step-by-step scheme driven by the same samples must converge to
these answers as ``Δt → 0`` at its order of accuracy; they are the yardsticks of the
verification tests.

* :func:`nigam_jennings` — linear SDOF ``ẍ + 2ζωẋ + ω²x = f(t)``, the exact recurrence of
  Nigam & Jennings (1969), *Calculation of response spectra from strong-motion earthquake
  records*, BSSA 59(2), in the form of Chopra, *Dynamics of Structures*, §5.2 (eq. 5.2.5 and
  Table 5.2.1 with ``p/k`` replaced by ``f/ω²``).
* :func:`modal_superposition` — classically damped linear MDOF ``M ẍ + C ẋ + K x = p(t)``,
  decoupled with the mass-normalised modes (modal analysis, Chopra ch. 10 and 12) and each
  modal equation solved by :func:`nigam_jennings`.
* :func:`epp_exact` — elastic-perfectly-plastic SDOF, event-driven: on each branch (elastic or
  plastic) the equation is linear with a linear load and is integrated in closed form; the
  yield and unloading events are located by root finding on the closed form (the
  elastoplastic system of Chopra ch. 7, integrated branch by branch without time-stepping
  error).
* :func:`free_vibration` and :func:`harmonic_response` — the closed forms of Chopra eqs.
  2.2.4 and 3.2.1–3.2.4, used by the tests.

Units are SI; numpy/scipy only.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
import scipy.linalg
import scipy.optimize

from .errors import ConfigError, IntegratorError

__all__ = [
    'EPPResponse',
    'epp_exact',
    'free_vibration',
    'harmonic_response',
    'modal_superposition',
    'nigam_jennings',
    'nigam_jennings_coefficients',
]

# Below this ω·τ the coefficients come from the power series of the matrix exponential: the
# closed forms subtract terms of size 1/ω² to get results of size τ² and lose about
# (ω·τ)⁻² of the precision (1e-11 relative at ω·τ = 0.01).
_SERIES_THETA = 0.5
# Terms of the power series; ‖G‖ ≤ 0.5·(1 + 2ζ) < 1.5, so 1.5³⁰/30! ≈ 7e-28 is negligible.
_SERIES_TERMS = 30
# A scalar series stops early once a term (entries of order one) falls below this.
_SERIES_STOP = 1e-20
# |z| below which φ_k(z) is summed as a power series (plastic branch).
_PHI_SERIES_Z = 1.0
# Largest angle ω_d·h (rad) of one scan sub-interval of the elastic branch; < π is required
# so that the acceleration (a damped sinusoid) has at most one zero in a sub-interval.
_SCAN_ANGLE = 1.0
# Events allowed within one load segment before the solution is declared chattering.
_MAX_EVENTS_PER_SEGMENT = 1000


# --------------------------------------------------------------------------- validation


def _positive(value: Any, name: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f'{name}: expected a number, got {value!r}') from None
    if not (math.isfinite(number) and number > 0.0):
        raise ConfigError(f'{name}: must be positive and finite, got {value!r}')
    return number


def _non_negative(value: Any, name: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f'{name}: expected a number, got {value!r}') from None
    if not (math.isfinite(number) and number >= 0.0):
        raise ConfigError(f'{name}: must be non-negative and finite, got {value!r}')
    return number


def _finite(value: Any, name: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f'{name}: expected a number, got {value!r}') from None
    if not math.isfinite(number):
        raise ConfigError(f'{name}: must be finite, got {value!r}')
    return number


def _history(value: Any, name: str) -> np.ndarray:
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f'{name}: expected a 1-D array of numbers') from None
    if array.ndim != 1 or array.size == 0:
        raise ConfigError(f'{name}: expected a non-empty 1-D array, got shape {array.shape}')
    if not np.all(np.isfinite(array)):
        raise ConfigError(f'{name}: all values must be finite')
    return array


def _damping_ratio(value: Any, name: str) -> float:
    number = _non_negative(value, name)
    if number >= 1.0:
        raise ConfigError(f'{name}: must be below 1 (underdamped), got {value!r}')
    return number


# --------------------------------------------------------------------------- linear SDOF


def _transition_scalar(omega: float, zeta: float, tau: float) -> tuple[float, ...]:
    """Exact transition of ``ẍ + 2ζωẋ + ω²x = f0 + s·σ`` over ``σ ∈ [0, τ]`` (floats).

    Returns ``(a11, a12, a21, a22, p1x, p1v, p2x, p2v)`` such that::

        x(τ) = a11 x0 + a12 v0 + p1x f0 + p2x s
        v(τ) = a21 x0 + a22 v0 + p1v f0 + p2v s

    ``[a]`` is the free-vibration matrix ``e^{Fτ}``, ``F = [[0, 1], [−ω², −2ζω]]``, and by
    variation of constants ``p1 = τ φ₁(Fτ) e₂``, ``p2 = τ² φ₂(Fτ) e₂`` with
    ``φ_k(X) = Σ_j X^j/(j+k)!``.

    For ``ωτ > 0.5`` the closed forms are used: the free vibration of Chopra eq. 2.2.4 and,
    for the load, the particular solutions ``x_p = f0/ω²`` (constant) and
    ``x_p = s(σ − 2ζ/ω)/ω²`` (ramp) with the homogeneous part fixed by zero initial
    conditions (Chopra §4.3–4.4, the derivation of Table 5.2.1). For smaller ``ωτ`` those
    forms cancel catastrophically and the power series of the scaled matrix
    ``G = ωτ [[0, 1], [−1, −2ζ]]`` acting on ``(ωx, v)`` is summed instead.
    """
    theta = omega * tau
    if theta > _SERIES_THETA:
        wd = omega * math.sqrt(1.0 - zeta * zeta)
        e = math.exp(-zeta * omega * tau)
        cs = math.cos(wd * tau)
        sn = math.sin(wd * tau)
        r = zeta * omega / wd
        a11 = e * (cs + r * sn)
        a12 = e * sn / wd
        a21 = -e * omega * omega / wd * sn
        a22 = e * (cs - r * sn)
        w2 = omega * omega
        w3 = w2 * omega
        p1x = (1.0 - a11) / w2
        p1v = -a21 / w2
        p2x = (tau - a12) / w2 - 2.0 * zeta * (1.0 - a11) / w3
        p2v = (1.0 - a22) / w2 + 2.0 * zeta * a21 / w3
        return a11, a12, a21, a22, p1x, p1v, p2x, p2v
    # Power series: T_j = G^j / j!, e^G = Σ T_j, φ1 e2 = Σ T_j e2 / (j+1),
    # φ2 e2 = Σ T_j e2 / ((j+1)(j+2)).
    g01 = theta
    g10 = -theta
    g11 = -2.0 * zeta * theta
    t00, t01, t10, t11 = 1.0, 0.0, 0.0, 1.0
    e00, e01, e10, e11 = 1.0, 0.0, 0.0, 1.0
    f1x, f1v = 0.0, 1.0
    f2x, f2v = 0.0, 0.5
    for j in range(1, _SERIES_TERMS):
        # T_j = T_{j-1} G / j
        n00 = (t01 * g10) / j
        n01 = (t00 * g01 + t01 * g11) / j
        n10 = (t11 * g10) / j
        n11 = (t10 * g01 + t11 * g11) / j
        t00, t01, t10, t11 = n00, n01, n10, n11
        e00 += t00
        e01 += t01
        e10 += t10
        e11 += t11
        d1 = 1.0 / (j + 1)
        d2 = d1 / (j + 2)
        f1x += t01 * d1
        f1v += t11 * d1
        f2x += t01 * d2
        f2v += t11 * d2
        if abs(t00) + abs(t01) + abs(t10) + abs(t11) < _SERIES_STOP:
            break
    return (
        e00,
        e01 / omega,
        e10 * omega,
        e11,
        tau * f1x / omega,
        tau * f1v,
        tau * tau * f2x / omega,
        tau * tau * f2v,
    )


def _transition_arrays(
    omega: np.ndarray, zeta: np.ndarray, tau: float
) -> tuple[np.ndarray, ...]:
    """Vectorised :func:`_transition_scalar` over arrays of ``omega`` and ``zeta``."""
    theta = omega * tau
    with np.errstate(all='ignore'):
        wd = omega * np.sqrt(1.0 - zeta * zeta)
        e = np.exp(-zeta * omega * tau)
        cs = np.cos(wd * tau)
        sn = np.sin(wd * tau)
        r = zeta * omega / wd
        a11 = e * (cs + r * sn)
        a12 = e * sn / wd
        a21 = -e * omega * omega / wd * sn
        a22 = e * (cs - r * sn)
        w2 = omega * omega
        w3 = w2 * omega
        closed = (
            a11,
            a12,
            a21,
            a22,
            (1.0 - a11) / w2,
            -a21 / w2,
            (tau - a12) / w2 - 2.0 * zeta * (1.0 - a11) / w3,
            (1.0 - a22) / w2 + 2.0 * zeta * a21 / w3,
        )
    small = theta <= _SERIES_THETA
    if not np.any(small):
        return closed
    g01 = theta
    g10 = -theta
    g11 = -2.0 * zeta * theta
    ones = np.ones_like(theta)
    zeros = np.zeros_like(theta)
    t00, t01, t10, t11 = ones, zeros, zeros, ones
    e00, e01, e10, e11 = ones.copy(), zeros.copy(), zeros.copy(), ones.copy()
    f1x, f1v = zeros.copy(), ones.copy()
    f2x, f2v = zeros.copy(), 0.5 * ones
    for j in range(1, _SERIES_TERMS):
        t00, t01, t10, t11 = (
            (t01 * g10) / j,
            (t00 * g01 + t01 * g11) / j,
            (t11 * g10) / j,
            (t10 * g01 + t11 * g11) / j,
        )
        e00 = e00 + t00
        e01 = e01 + t01
        e10 = e10 + t10
        e11 = e11 + t11
        d1 = 1.0 / (j + 1)
        d2 = d1 / (j + 2)
        f1x = f1x + t01 * d1
        f1v = f1v + t11 * d1
        f2x = f2x + t01 * d2
        f2v = f2v + t11 * d2
    series = (
        e00,
        e01 / omega,
        e10 * omega,
        e11,
        tau * f1x / omega,
        tau * f1v,
        tau * tau * f2x / omega,
        tau * tau * f2v,
    )
    return tuple(np.where(small, s, c) for s, c in zip(series, closed))


def nigam_jennings_coefficients(
    omega: Any, zeta: Any, dt: float
) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients of the exact recurrence for a linear SDOF under a piecewise-linear load.

    For ``ẍ + 2ζωẋ + ω²x = f(t)`` with ``f`` linear on ``[t_i, t_{i+1}]``::

        [x_{i+1}, v_{i+1}]ᵀ = A [x_i, v_i]ᵀ + B [f_i, f_{i+1}]ᵀ

    (Nigam & Jennings 1969; Chopra eq. 5.2.5 with the coefficients of Table 5.2.1 divided by
    ``k``, i.e. written for the load per unit mass). In terms of the transition of
    :func:`_transition_scalar`, ``B = [p1 − p2/Δt, p2/Δt]``:

    - ``A = e^{FΔt}``: ``A11 = e^{−ζωΔt}(cos ω_DΔt + ζω/ω_D sin ω_DΔt)``,
      ``A12 = e^{−ζωΔt} sin ω_DΔt / ω_D``, ``A21 = −ω²A12``,
      ``A22 = e^{−ζωΔt}(cos ω_DΔt − ζω/ω_D sin ω_DΔt)``;
    - ``B11 = −A11/ω² + 2ζ(1 − A11)/(ω³Δt) + A12/(ω²Δt)``,
      ``B12 = 1/ω² − 2ζ(1 − A11)/(ω³Δt) − A12/(ω²Δt)``,
      ``B21 = −A21/ω² − (1 − A22)/(ω²Δt) − 2ζA21/(ω³Δt)``,
      ``B22 = (1 − A22)/(ω²Δt) + 2ζA21/(ω³Δt)``.

    For ``ωΔt ≤ 0.5`` the same matrices are summed from the power series of the matrix
    exponential (see :func:`_transition_scalar`), which avoids the cancellation of the
    closed forms at small ``ωΔt``.

    Args:
        omega: Natural circular frequency ``ω`` (rad/s), positive; a scalar or an array.
        zeta: Damping ratio ``ζ``, ``0 ≤ ζ < 1``; broadcast against ``omega``.
        dt: Sample spacing ``Δt`` in s, positive.

    Returns:
        ``(A, B)``, each of shape ``broadcast(omega, zeta).shape + (2, 2)``.

    Raises:
        ConfigError: On a non-positive ``omega`` or ``dt``, or ``zeta`` outside ``[0, 1)``.
    """
    dt_value = _positive(dt, 'dt')
    try:
        w, z = np.broadcast_arrays(np.asarray(omega, dtype=float), np.asarray(zeta, dtype=float))
    except (TypeError, ValueError) as exc:
        raise ConfigError(f'omega, zeta: expected numbers or arrays ({exc})') from None
    if not np.all(np.isfinite(w) & (w > 0.0)):
        raise ConfigError('omega: every frequency must be positive and finite')
    if not np.all(np.isfinite(z) & (z >= 0.0) & (z < 1.0)):
        raise ConfigError('zeta: every damping ratio must be in [0, 1)')
    a11, a12, a21, a22, p1x, p1v, p2x, p2v = _transition_arrays(w, z, dt_value)
    a = np.stack([np.stack([a11, a12], -1), np.stack([a21, a22], -1)], -2)
    b = np.stack(
        [
            np.stack([p1x - p2x / dt_value, p2x / dt_value], -1),
            np.stack([p1v - p2v / dt_value, p2v / dt_value], -1),
        ],
        -2,
    )
    return a, b


def nigam_jennings(
    omega: float,
    zeta: float,
    dt: float,
    excitation: Any,
    x0: float = 0.0,
    v0: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact response of a linear SDOF to a piecewise-linear excitation (Nigam–Jennings).

    Solves ``ẍ + 2ζωẋ + ω²x = f(t)``, ``x(0) = x0``, ``ẋ(0) = v0``, where ``f`` (the load per
    unit mass, ``p/m``; ``−a_g`` for a ground motion) is the linear interpolation of
    ``excitation[i]`` at ``t_i = i·Δt``. The recurrence of :func:`nigam_jennings_coefficients`
    is exact for such an ``f``: the only error is rounding. The acceleration follows from the
    equation of motion, ``a = f − 2ζωv − ω²x`` (Chopra eq. 5.2.5 and the remark after it).

    Args:
        omega: Natural circular frequency ``ω`` in rad/s (positive).
        zeta: Damping ratio, ``0 ≤ ζ < 1``.
        dt: Sample spacing in s.
        excitation: ``f_i`` in m/s², shape ``(n_samples,)``.
        x0: Initial displacement in m.
        v0: Initial velocity in m/s.

    Returns:
        ``(x, v, a)`` at the sample times, each of shape ``(n_samples,)``.

    Raises:
        ConfigError: On invalid parameters or a non-finite excitation.
    """
    w = _positive(omega, 'omega')
    z = _damping_ratio(zeta, 'zeta')
    f = _history(excitation, 'excitation')
    xi = _finite(x0, 'x0')
    vi = _finite(v0, 'v0')
    a_mat, b_mat = nigam_jennings_coefficients(w, z, dt)
    a11, a12, a21, a22 = (float(value) for value in a_mat.reshape(4))
    b11, b12, b21, b22 = (float(value) for value in b_mat.reshape(4))
    gx = (b11 * f[:-1] + b12 * f[1:]).tolist()
    gv = (b21 * f[:-1] + b22 * f[1:]).tolist()
    xs = [xi]
    vs = [vi]
    for gxi, gvi in zip(gx, gv):
        xi, vi = a11 * xi + a12 * vi + gxi, a21 * xi + a22 * vi + gvi
        xs.append(xi)
        vs.append(vi)
    x = np.array(xs)
    v = np.array(vs)
    a = f - 2.0 * z * w * v - w * w * x
    return x, v, a


def free_vibration(
    omega: float, zeta: float, t: Any, x0: float, v0: float
) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form free vibration of an underdamped SDOF (Chopra eq. 2.2.4).

    ``x(t) = e^{−ζωt} [x0 cos ω_D t + (v0 + ζω x0)/ω_D sin ω_D t]``, ``ω_D = ω√(1 − ζ²)``.

    Args:
        omega: Natural circular frequency in rad/s.
        zeta: Damping ratio in ``[0, 1)``.
        t: Times in s (scalar or array).
        x0: Initial displacement in m.
        v0: Initial velocity in m/s.

    Returns:
        ``(x, v)`` at ``t``.
    """
    w = _positive(omega, 'omega')
    z = _damping_ratio(zeta, 'zeta')
    times = np.asarray(t, dtype=float)
    wd = w * math.sqrt(1.0 - z * z)
    e = np.exp(-z * w * times)
    cs = np.cos(wd * times)
    sn = np.sin(wd * times)
    b = (v0 + z * w * x0) / wd
    x = e * (x0 * cs + b * sn)
    v = e * ((wd * b - z * w * x0) * cs - (wd * x0 + z * w * b) * sn)
    return x, v


def harmonic_response(
    omega: float,
    zeta: float,
    t: Any,
    amplitude: float,
    frequency: float,
    x0: float = 0.0,
    v0: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form response to ``f(t) = amplitude·sin(Ω t)`` (per unit mass), Chopra §3.2.

    Steady state (Chopra eqs. 3.2.2–3.2.4 divided by ``m``)::

        x_ss = F [(ω² − Ω²) sin Ωt − 2ζωΩ cos Ωt] / [(ω² − Ω²)² + (2ζωΩ)²]

    plus the free vibration (:func:`free_vibration`) that makes up the initial conditions
    (the transient of Chopra eq. 3.2.1).

    Args:
        omega: Natural circular frequency in rad/s.
        zeta: Damping ratio in ``[0, 1)``.
        t: Times in s.
        amplitude: ``F`` in m/s².
        frequency: Forcing circular frequency ``Ω`` in rad/s (not at an undamped resonance).
        x0: Initial displacement in m.
        v0: Initial velocity in m/s.

    Returns:
        ``(x, v)`` at ``t``.

    Raises:
        ConfigError: At undamped resonance (``ζ = 0`` and ``Ω = ω``).
    """
    w = _positive(omega, 'omega')
    z = _damping_ratio(zeta, 'zeta')
    big_w = _non_negative(frequency, 'frequency')
    f = _finite(amplitude, 'amplitude')
    den = (w * w - big_w * big_w) ** 2 + (2.0 * z * w * big_w) ** 2
    if den == 0.0:
        raise ConfigError('frequency: undamped resonance has no steady state')
    cs_coef = -f * 2.0 * z * w * big_w / den
    sn_coef = f * (w * w - big_w * big_w) / den
    times = np.asarray(t, dtype=float)
    x_ss = sn_coef * np.sin(big_w * times) + cs_coef * np.cos(big_w * times)
    v_ss = big_w * (sn_coef * np.cos(big_w * times) - cs_coef * np.sin(big_w * times))
    xt, vt = free_vibration(w, z, times, x0 - cs_coef, v0 - big_w * sn_coef)
    return x_ss + xt, v_ss + vt


# --------------------------------------------------------------------------- linear MDOF


def modal_superposition(
    mass: Any,
    stiffness: Any,
    damping_ratios: Any = None,
    dt: float | None = None,
    load: Any = None,
    x0: Any = None,
    v0: Any = None,
    *,
    damping_matrix: Any = None,
    classical_tol: float = 1e-8,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact response of a classically damped linear MDOF to a piecewise-linear load.

    ``M ẍ + C ẋ + K x = p(t)`` is decoupled with the mass-normalised modes of
    ``K φ = ω² M φ`` (``Φᵀ M Φ = I``, ``Φᵀ K Φ = Ω²``; Chopra ch. 10): ``x = Φ q`` and
    ``q̈_n + 2ζ_nω_n q̇_n + ω_n² q_n = φ_nᵀ p(t)`` (the modal equations of Chopra ch. 12 with
    ``M_n = 1``). Each modal load is piecewise linear, so :func:`nigam_jennings` solves each
    mode exactly; the initial modal coordinates are ``q(0) = Φᵀ M x0``. The acceleration is
    ``Φ q̈`` with ``q̈`` from the modal equations.

    The modal damping is either given (``damping_ratios``, one per mode in ascending frequency
    order, or one number for all; this implies ``C = M Φ diag(2ζω) Φᵀ M``) or taken from a
    damping matrix: ``ζ_n = (ΦᵀCΦ)_nn / (2ω_n)``, after checking that ``ΦᵀCΦ`` is diagonal
    (classical damping, e.g. Rayleigh ``C = a₀M + a₁K``, Chopra ch. 11).

    Args:
        mass: Mass matrix ``M`` (kg), symmetric positive definite (or a scalar).
        stiffness: Stiffness matrix ``K`` (N/m), symmetric positive definite (or a scalar).
        damping_ratios: Modal damping ratios in ``[0, 1)``; omit when ``damping_matrix`` is
            given.
        dt: Sample spacing of the load in s.
        load: External load ``p`` in N, shape ``(n_samples, n)`` (``(n_samples,)`` for
            ``n = 1``), linear between samples.
        x0: Initial displacement ``(n,)`` in m (zeros if omitted).
        v0: Initial velocity ``(n,)`` in m/s (zeros if omitted).
        damping_matrix: Damping matrix ``C`` (N·s/m), used instead of ``damping_ratios``.
        classical_tol: Largest allowed ``|(ΦᵀCΦ)_ij|`` (i ≠ j) relative to
            ``max |(ΦᵀCΦ)_nn|``.

    Returns:
        ``(x, v, a)``, each of shape ``(n_samples, n)``.

    Raises:
        ConfigError: On malformed matrices or load, a zero-frequency mode, both or neither of
            ``damping_ratios`` and ``damping_matrix``, a non-classical damping matrix, or a
            modal damping ratio outside ``[0, 1)``.
    """
    m = np.atleast_2d(np.array(mass, dtype=float))
    k = np.atleast_2d(np.array(stiffness, dtype=float))
    n = m.shape[0]
    if m.ndim != 2 or m.shape != (n, n) or k.shape != (n, n):
        raise ConfigError(f'mass, stiffness: expected square matrices of one shape, '
                          f'got {m.shape} and {k.shape}')
    if not (np.all(np.isfinite(m)) and np.all(np.isfinite(k))):
        raise ConfigError('mass, stiffness: all values must be finite')
    if not (np.allclose(m, m.T, rtol=1e-12, atol=0.0) and np.allclose(k, k.T, rtol=1e-12,
                                                                      atol=0.0)):
        raise ConfigError('mass, stiffness: matrices must be symmetric')
    try:
        eigenvalues, phi = scipy.linalg.eigh(k, m)
    except np.linalg.LinAlgError:
        raise ConfigError('mass: matrix must be positive definite') from None
    if not np.all(eigenvalues > 0.0):
        raise ConfigError(
            f'stiffness: every mode needs a positive frequency, got ω² = {eigenvalues.min():.6g}'
        )
    omegas = np.sqrt(eigenvalues)
    dt_value = _positive(dt, 'dt')

    if (damping_ratios is None) == (damping_matrix is None):
        raise ConfigError('damping: give exactly one of damping_ratios and damping_matrix')
    if damping_matrix is not None:
        c = np.atleast_2d(np.array(damping_matrix, dtype=float))
        if c.shape != (n, n) or not np.all(np.isfinite(c)):
            raise ConfigError(f'damping_matrix: expected a finite ({n}, {n}) matrix')
        modal_c = phi.T @ c @ phi
        diag = np.diag(modal_c).copy()
        scale = float(np.max(np.abs(diag)))
        off = modal_c - np.diag(diag)
        worst = float(np.max(np.abs(off))) if n > 1 else 0.0
        if worst > classical_tol * scale:
            raise ConfigError(
                f'damping_matrix: not classical: off-diagonal modal damping {worst:.3g} '
                f'exceeds {classical_tol:g} x {scale:.3g} (ΦᵀCΦ must be diagonal)'
            )
        zetas = diag / (2.0 * omegas)
    else:
        zetas = np.array(damping_ratios, dtype=float).reshape(-1)
        if zetas.size == 1:
            zetas = np.full(n, float(zetas[0]))
        if zetas.size != n:
            raise ConfigError(f'damping_ratios: expected 1 or {n} values, got {zetas.size}')
    if not np.all(np.isfinite(zetas) & (zetas >= 0.0) & (zetas < 1.0)):
        raise ConfigError(f'damping: modal damping ratios must be in [0, 1), got {zetas}')

    p = np.array(load, dtype=float)
    if p.ndim == 1 and n == 1:
        p = p.reshape(-1, 1)
    if p.ndim != 2 or p.shape[1] != n or p.shape[0] == 0:
        raise ConfigError(f'load: expected shape (n_samples, {n}), got {p.shape}')
    if not np.all(np.isfinite(p)):
        raise ConfigError('load: all values must be finite')
    x_init = np.zeros(n) if x0 is None else np.array(x0, dtype=float).reshape(-1)
    v_init = np.zeros(n) if v0 is None else np.array(v0, dtype=float).reshape(-1)
    if x_init.shape != (n,) or v_init.shape != (n,):
        raise ConfigError(f'x0, v0: expected shape ({n},)')

    modal_load = p @ phi  # (n_samples, n): f_n = φ_nᵀ p
    q0 = phi.T @ (m @ x_init)
    qd0 = phi.T @ (m @ v_init)
    q = np.empty_like(modal_load)
    qd = np.empty_like(modal_load)
    qdd = np.empty_like(modal_load)
    for j in range(n):
        q[:, j], qd[:, j], qdd[:, j] = nigam_jennings(
            float(omegas[j]), float(zetas[j]), dt_value, modal_load[:, j], q0[j], qd0[j]
        )
    return q @ phi.T, qd @ phi.T, qdd @ phi.T


# --------------------------------------------------------------------------- EPP SDOF


class EPPResponse(NamedTuple):
    """Response of :func:`epp_exact` at the sample times (all arrays ``(n_samples,)``).

    Attributes:
        x: Displacement in m.
        v: Velocity in m/s.
        a: Acceleration in m/s².
        r: Restoring force in N, ``k (x − x_p)`` clipped to ``±f_y``.
        plastic_displacement: Plastic offset ``x_p`` in m.
        hysteretic_energy: Energy dissipated by yielding since ``t = 0``, ``f_y Σ|Δx_p|``, in J.
        events: ``(time, kind)`` of each branch change, ``kind`` one of ``'yield+'``,
            ``'yield-'`` and ``'unload'``.
    """

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    r: np.ndarray
    plastic_displacement: np.ndarray
    hysteretic_energy: np.ndarray
    events: tuple[tuple[float, str], ...]


def _phi123(z: float) -> tuple[float, float, float]:
    """``φ₁, φ₂, φ₃`` of a scalar: ``φ_k(z) = Σ_j z^j/(j+k)!`` (``φ₁ = (e^z − 1)/z``, ...)."""
    if abs(z) < _PHI_SERIES_Z:
        p1 = p2 = p3 = 0.0
        term = 1.0  # z^j / j!
        for j in range(_SERIES_TERMS):
            p1 += term / (j + 1)
            p2 += term / ((j + 1) * (j + 2))
            p3 += term / ((j + 1) * (j + 2) * (j + 3))
            term *= z / (j + 1)
            if abs(term) < _SERIES_STOP:
                break
        return p1, p2, p3
    p1 = math.expm1(z) / z
    p2 = (p1 - 1.0) / z
    p3 = (p2 - 0.5) / z
    return p1, p2, p3


def _root(func: Any, lo: float, hi: float, scale: float) -> float:
    """First root of a function with ``func(lo) ≤ 0 < func(hi)`` (or the reverse)."""
    f_lo = func(lo)
    if f_lo == 0.0:
        return lo
    return scipy.optimize.brentq(func, lo, hi, xtol=1e-15 * scale, rtol=4.0 * np.finfo(float).eps)


def epp_exact(
    mass: float,
    stiffness: float,
    yield_force: float,
    damping: float,
    dt: float,
    load: Any,
    x0: float = 0.0,
    v0: float = 0.0,
) -> EPPResponse:
    """Event-driven exact response of an elastic-perfectly-plastic SDOF.

    Solves ``m ẍ + c ẋ + r = p(t)`` with ``p`` linear between the samples ``load[i]`` at
    ``t_i = i·Δt`` and ``r`` elastic-perfectly-plastic: ``r = k (x − x_p)`` with
    ``|r| ≤ f_y``; ``x_p`` changes only while ``r = ±f_y`` and the velocity has the sign of
    ``r``. Within one load segment the motion follows one linear branch at a time, each solved
    in closed form from the state at the branch start (time ``σ`` from there, load
    ``p = p₀ + sσ``):

    * **elastic** (``u = x − x_p``): ``ü + 2ζωu̇ + ω²u = p/m`` with ``ω² = k/m``,
      ``ζ = c/(2mω)`` — the exact transition of :func:`nigam_jennings` over an arbitrary
      interval (Chopra §5.2, eq. 2.2.4 and §4.3–4.4).
    * **plastic** (``r = ±f_y``): ``m v̇ + c v = g(σ) = p₀ ∓ f_y + sσ``; with ``λ = c/m``
      (variation of constants, valid for ``c = 0`` too)::

          v(σ) = v₀ e^{−λσ} + (g₀/m) σ φ₁(−λσ) + (s/m) σ² φ₂(−λσ)
          x(σ) = x₀ + v₀ σ φ₁(−λσ) + (g₀/m) σ² φ₂(−λσ) + (s/m) σ³ φ₃(−λσ)

      where ``φ₁(z) = (e^z − 1)/z``, ``φ₂ = (e^z − 1 − z)/z²``, ``φ₃ = (e^z − 1 − z − z²/2)/z³``.

    Events (located with :func:`scipy.optimize.brentq` on the closed forms):

    * **yield**: on the elastic branch ``|u|`` reaches ``u_y = f_y/k`` while moving outward;
      the motion continues on the plastic branch of that sign.
    * **unload**: on the plastic branch the velocity changes sign; the motion continues on
      the elastic branch with the new plastic offset.

    Roots are isolated exactly rather than by a blind scan: on the elastic branch the
    acceleration is a damped sinusoid (its zeros are ``π/ω_D`` apart), so on scan
    sub-intervals shorter than ``1/ω_D`` it has at most one zero; splitting there makes the
    velocity monotone, splitting at the velocity's zeros makes ``u`` monotone, and a threshold
    crossing is then a sign change at the ends. On the plastic branch
    ``v = α + βσ + γe^{−λσ}``, so the acceleration ``β − λγe^{−λσ}`` is monotone and the
    velocity has at most one extremum per segment.

    Args:
        mass: ``m`` in kg, positive.
        stiffness: Elastic stiffness ``k`` in N/m, positive.
        yield_force: ``f_y`` in N, positive.
        damping: Viscous damping ``c`` in N·s/m, ``0 ≤ c < 2√(km)``.
        dt: Load sample spacing in s.
        load: ``p_i`` in N (``−m a_g`` for a ground motion), shape ``(n_samples,)``.
        x0: Initial displacement in m. If ``|k x0| > f_y`` the spring starts yielded with
            ``x_p = x0 ∓ u_y``.
        v0: Initial velocity in m/s.

    Returns:
        An :class:`EPPResponse` with the state at the sample times, the plastic offset, the
        cumulative hysteretic energy and the list of events.

    Raises:
        ConfigError: On invalid parameters (including an overdamped elastic branch).
        IntegratorError: If the branches chatter (more than 1000 events in one segment).
    """
    m = _positive(mass, 'mass')
    k = _positive(stiffness, 'stiffness')
    fy = _positive(yield_force, 'yield_force')
    c = _non_negative(damping, 'damping')
    h = _positive(dt, 'dt')
    p = _history(load, 'load')
    x = _finite(x0, 'x0')
    v = _finite(v0, 'v0')
    omega = math.sqrt(k / m)
    zeta = c / (2.0 * m * omega)
    if zeta >= 1.0:
        raise ConfigError(
            f'damping: c = {c!r} gives ζ = {zeta:.4g} ≥ 1; the elastic branch must be '
            'underdamped'
        )
    wd = omega * math.sqrt(1.0 - zeta * zeta)
    lam = c / m
    uy = fy / k
    # Most elastic segments start at a sample and span dt: cache those transitions.
    cache: dict[float, tuple[float, ...]] = {}

    def transition(sigma: float) -> tuple[float, ...]:
        found = cache.get(sigma)
        if found is None:
            found = _transition_scalar(omega, zeta, sigma)
            if len(cache) < 16:
                cache[sigma] = found
        return found

    # Initial branch: 0 elastic, +1/-1 plastic in that direction.
    xp = 0.0
    branch = 0
    if abs(k * x) >= fy:
        sign = 1 if x > 0.0 else -1
        xp = x - sign * uy
        if sign * v > 0.0:
            branch = sign
    energy = 0.0
    events: list[tuple[float, str]] = []

    n_samples = p.size
    xs = np.empty(n_samples)
    vs = np.empty(n_samples)
    rs = np.empty(n_samples)
    xps = np.empty(n_samples)
    es = np.empty(n_samples)

    def restoring(x_now: float, xp_now: float, branch_now: int) -> float:
        if branch_now != 0:
            return branch_now * fy
        return min(fy, max(-fy, k * (x_now - xp_now)))

    xs[0], vs[0], xps[0], es[0] = x, v, xp, energy
    rs[0] = restoring(x, xp, branch)

    for i in range(n_samples - 1):
        slope = (p[i + 1] - p[i]) / h
        t_seg = i * h
        tau = 0.0  # local time within the segment
        n_events = 0
        while True:
            remaining = h - tau
            p0 = p[i] + slope * tau
            if branch == 0:
                sigma, u_end, v_end, kind = _elastic_branch(
                    transition, omega, zeta, wd, uy, x - xp, v, p0 / m, slope / m, remaining
                )
                x = xp + u_end
                v = v_end
                if kind is None:
                    break
                branch = 1 if kind == 'yield+' else -1
            else:
                sigma, x_end, v_end, kind = _plastic_branch(
                    lam, m, branch, fy, x, v, p0, slope, remaining
                )
                energy += fy * abs(x_end - x)
                x = x_end
                xp = x - branch * uy
                v = v_end
                if kind is None:
                    break
                branch = 0
            tau += sigma
            events.append((t_seg + tau, kind))
            n_events += 1
            if n_events > _MAX_EVENTS_PER_SEGMENT:
                raise IntegratorError(
                    f'epp_exact: more than {_MAX_EVENTS_PER_SEGMENT} yield/unload events '
                    f'between t = {t_seg!r} s and {t_seg + h!r} s (chattering)'
                )
            if tau >= h:
                break
        xs[i + 1], vs[i + 1], xps[i + 1], es[i + 1] = x, v, xp, energy
        rs[i + 1] = restoring(x, xp, branch)

    acc = (p - c * vs - rs) / m
    return EPPResponse(xs, vs, acc, rs, xps, es, tuple(events))


def _elastic_branch(
    transition: Callable[[float], tuple[float, ...]],
    omega: float,
    zeta: float,
    wd: float,
    uy: float,
    u0: float,
    v0: float,
    f0: float,
    s: float,
    span: float,
) -> tuple[float, float, float, str | None]:
    """Follow the elastic branch for up to ``span`` s; stop at the first yield event.

    Returns ``(σ, u(σ), v(σ), kind)`` with ``kind`` ``None`` if no event occurred (``σ`` is
    then ``span``), else ``'yield+'`` / ``'yield-'`` (and ``u(σ) = ±u_y`` exactly).
    """
    two_zw = 2.0 * zeta * omega
    w2 = omega * omega

    def state(sigma: float) -> tuple[float, float, float]:
        a11, a12, a21, a22, p1x, p1v, p2x, p2v = transition(sigma)
        u = a11 * u0 + a12 * v0 + p1x * f0 + p2x * s
        v = a21 * u0 + a22 * v0 + p1v * f0 + p2v * s
        return u, v, f0 + s * sigma - two_zw * v - w2 * u

    n_sub = max(1, math.ceil(span * wd / _SCAN_ANGLE))
    left = 0.0
    u_l, v_l, a_l = u0, v0, f0 - two_zw * v0 - w2 * u0
    for j in range(1, n_sub + 1):
        right = span if j == n_sub else span * j / n_sub
        u_r, v_r, a_r = state(right)
        # Break [left, right] into pieces on which u is monotone.
        cuts = [(left, u_l, v_l)]
        if a_l * a_r < 0.0:
            ta = _root(lambda t: state(t)[2], left, right, span)
            ua, va, _ = state(ta)
            cuts.append((ta, ua, va))
        cuts.append((right, u_r, v_r))
        pieces = [cuts[0]]
        for (ta, ua, va), (tb, ub, vb) in zip(cuts[:-1], cuts[1:]):
            if va * vb < 0.0:
                tv = _root(lambda t: state(t)[1], ta, tb, span)
                uv, vv, _ = state(tv)
                pieces.append((tv, uv, vv))
            pieces.append((tb, ub, vb))
        for (ta, ua, _va), (tb, ub, _vb) in zip(pieces[:-1], pieces[1:]):
            if ub > uy:
                te = _root(lambda t: state(t)[0] - uy, ta, tb, span) if ua < uy else ta
                _, ve, _ = state(te)
                return te, uy, ve, 'yield+'
            if ub < -uy:
                te = _root(lambda t: state(t)[0] + uy, ta, tb, span) if ua > -uy else ta
                _, ve, _ = state(te)
                return te, -uy, ve, 'yield-'
        left, u_l, v_l, a_l = right, u_r, v_r, a_r
    return span, u_l, v_l, None


def _plastic_branch(
    lam: float,
    m: float,
    sign: int,
    fy: float,
    x0: float,
    v0: float,
    p0: float,
    s: float,
    span: float,
) -> tuple[float, float, float, str | None]:
    """Follow the plastic branch of the given sign for up to ``span`` s; stop at unloading.

    Returns ``(σ, x(σ), v(σ), kind)`` with ``kind`` ``None`` (``σ = span``) or ``'unload'``
    (and ``v(σ) = 0`` exactly).
    """
    g0 = (p0 - sign * fy) / m
    sm = s / m

    def state(sigma: float) -> tuple[float, float, float]:
        z = -lam * sigma
        p1, p2, p3 = _phi123(z)
        v = v0 * math.exp(z) + g0 * sigma * p1 + sm * sigma * sigma * p2
        x = x0 + v0 * sigma * p1 + g0 * sigma * sigma * p2 + sm * sigma ** 3 * p3
        return x, v, g0 + sm * sigma - lam * v

    x_r, v_r, a_r = state(span)
    a_l = g0 - lam * v0
    cuts = [(0.0, v0)]
    if a_l * a_r < 0.0:
        ta = _root(lambda t: state(t)[2], 0.0, span, span)
        cuts.append((ta, state(ta)[1]))
    cuts.append((span, v_r))
    for (ta, va), (tb, vb) in zip(cuts[:-1], cuts[1:]):
        if sign * vb < 0.0:
            te = _root(lambda t: state(t)[1], ta, tb, span) if sign * va > 0.0 else ta
            return te, state(te)[0], 0.0, 'unload'
    return span, x_r, v_r, None
