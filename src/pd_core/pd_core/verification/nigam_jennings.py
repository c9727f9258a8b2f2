"""Nigam–Jennings: the exact response of a linear SDOF to a piecewise-linear excitation.

The functions here solve the *continuous* equation of motion ``ẍ + 2ζωẋ + ω²x = f(t)``
exactly (to rounding) for an excitation that is **piecewise linear** between samples
``t_i = i·Δt``, which is how a digitised ground motion is interpreted: the exact recurrence of
Nigam & Jennings (1969), *Calculation of response spectra from strong-motion earthquake
records*, BSSA 59(2), in the form of Chopra, *Dynamics of Structures*, §5.2 (eq. 5.2.5 and
Table 5.2.1 with ``p/k`` replaced by ``f/ω²``). A step-by-step scheme driven by the same
samples must converge to these answers as ``Δt → 0`` at its order of accuracy.

:func:`transition_scalar` is the exact transition over an arbitrary interval, also used by the
event-driven elastic-perfectly-plastic solution (:mod:`.epp`).

Units are SI; numpy only.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ConfigError
from .checks import damping_ratio, finite, positive, sample_history

__all__ = [
    'SERIES_STOP',
    'SERIES_TERMS',
    'nigam_jennings',
    'nigam_jennings_coefficients',
    'transition_scalar',
]

# Below this ω·τ the coefficients come from the power series of the matrix exponential: the
# closed forms subtract terms of size 1/ω² to get results of size τ² and lose about
# (ω·τ)⁻² of the precision (1e-11 relative at ω·τ = 0.01).
_SERIES_THETA = 0.5
#: Terms of the power series; ‖G‖ ≤ 0.5·(1 + 2ζ) < 1.5, so 1.5³⁰/30! ≈ 7e-28 is negligible.
SERIES_TERMS = 30
#: A scalar series stops early once a term (entries of order one) falls below this.
SERIES_STOP = 1e-20


# --------------------------------------------------------------------------- linear SDOF


def transition_scalar(omega: float, zeta: float, tau: float) -> tuple[float, ...]:
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

    Args:
        omega: Natural circular frequency ``ω`` in rad/s, positive.
        zeta: Damping ratio ``ζ``, ``0 ≤ ζ < 1``.
        tau: Length ``τ`` of the interval in s, non-negative.

    Returns:
        The eight coefficients above, as floats.
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
    for j in range(1, SERIES_TERMS):
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
        if abs(t00) + abs(t01) + abs(t10) + abs(t11) < SERIES_STOP:
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
    """Vectorised :func:`transition_scalar` over arrays of ``omega`` and ``zeta``."""
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
    for j in range(1, SERIES_TERMS):
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
    :func:`transition_scalar`, ``B = [p1 − p2/Δt, p2/Δt]``:

    - ``A = e^{FΔt}``: ``A11 = e^{−ζωΔt}(cos ω_DΔt + ζω/ω_D sin ω_DΔt)``,
      ``A12 = e^{−ζωΔt} sin ω_DΔt / ω_D``, ``A21 = −ω²A12``,
      ``A22 = e^{−ζωΔt}(cos ω_DΔt − ζω/ω_D sin ω_DΔt)``;
    - ``B11 = −A11/ω² + 2ζ(1 − A11)/(ω³Δt) + A12/(ω²Δt)``,
      ``B12 = 1/ω² − 2ζ(1 − A11)/(ω³Δt) − A12/(ω²Δt)``,
      ``B21 = −A21/ω² − (1 − A22)/(ω²Δt) − 2ζA21/(ω³Δt)``,
      ``B22 = (1 − A22)/(ω²Δt) + 2ζA21/(ω³Δt)``.

    For ``ωΔt ≤ 0.5`` the same matrices are summed from the power series of the matrix
    exponential (see :func:`transition_scalar`), which avoids the cancellation of the
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
    dt_value = positive(dt, 'dt')
    try:
        w, z = np.broadcast_arrays(np.asarray(omega, dtype=float), np.asarray(zeta, dtype=float))
    except (TypeError, ValueError) as exc:
        msg = f'omega, zeta: expected numbers or arrays ({exc})'
        raise ConfigError(msg) from None
    if not np.all(np.isfinite(w) & (w > 0.0)):
        msg = 'omega: every frequency must be positive and finite'
        raise ConfigError(msg)
    if not np.all(np.isfinite(z) & (z >= 0.0) & (z < 1.0)):
        msg = 'zeta: every damping ratio must be in [0, 1)'
        raise ConfigError(msg)
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
    w = positive(omega, 'omega')
    z = damping_ratio(zeta, 'zeta')
    f = sample_history(excitation, 'excitation')
    xi = finite(x0, 'x0')
    vi = finite(v0, 'v0')
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
