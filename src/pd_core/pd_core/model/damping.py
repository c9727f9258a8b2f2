"""Classical damping matrices: Rayleigh damping and modal damping.

* Rayleigh damping ``C = a0 M + a1 K`` matching the damping ratios of two modes
  (:func:`rayleigh_coefficients`, :func:`rayleigh_damping`);
* modal damping with a prescribed ratio in every mode (:func:`modal_damping`).

All quantities are SI (N, m, kg, s). Only numpy is used.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..dynamics.structure import modal_analysis, rayleigh_frequencies
from ..errors import ConfigError
from .checks import mass_and_stiffness, positive

__all__ = [
    'modal_damping',
    'rayleigh_coefficients',
    'rayleigh_damping',
]


def _ratio(value: Any, name: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        msg = f'{name}: expected a damping ratio, got {value!r}'
        raise ConfigError(msg) from None
    if not math.isfinite(number) or number < 0.0:
        msg = f'{name}: damping ratio must be finite and >= 0, got {value!r}'
        raise ConfigError(msg)
    return number


def rayleigh_coefficients(
    omega_i: float, omega_j: float, zeta_i: float, zeta_j: float
) -> tuple[float, float]:
    """Rayleigh coefficients ``(a0, a1)`` of ``C = a0 M + a1 K``.

    The damping ratio of a mode of circular frequency ``ω`` is ``ζ(ω) = a0/(2ω) + a1 ω/2``;
    imposing ``ζ(ω_i) = ζ_i`` and ``ζ(ω_j) = ζ_j`` gives

        a0 = 2 ω_i ω_j (ζ_i ω_j − ζ_j ω_i) / (ω_j² − ω_i²),
        a1 = 2 (ζ_j ω_j − ζ_i ω_i) / (ω_j² − ω_i²).

    Args:
        omega_i: First circular frequency in rad/s, positive.
        omega_j: Second circular frequency in rad/s, positive and different from ``omega_i``.
        zeta_i: Damping ratio at ``omega_i`` (≥ 0).
        zeta_j: Damping ratio at ``omega_j`` (≥ 0).

    Returns:
        ``(a0, a1)`` in 1/s and s. Either may be negative for unusual ratio pairs.

    Raises:
        ConfigError: On non-positive or equal frequencies or a negative ratio.
    """
    w_i = positive(omega_i, 'rayleigh', 'omega_i')
    w_j = positive(omega_j, 'rayleigh', 'omega_j')
    z_i = _ratio(zeta_i, 'rayleigh: zeta_i')
    z_j = _ratio(zeta_j, 'rayleigh: zeta_j')
    if math.isclose(w_i, w_j, rel_tol=1e-9):
        msg = f'rayleigh: omega_i and omega_j must differ, got {w_i:.6g} and {w_j:.6g} rad/s'
        raise ConfigError(msg)
    denominator = w_j**2 - w_i**2
    a0 = 2.0 * w_i * w_j * (z_i * w_j - z_j * w_i) / denominator
    a1 = 2.0 * (z_j * w_j - z_i * w_i) / denominator
    return float(a0), float(a1)


def rayleigh_damping(
    M: Any,
    K: Any,
    modes: Sequence[int] = (1, 2),
    ratios: float | Sequence[float] = (0.05, 0.05),
) -> np.ndarray:
    """Rayleigh damping ``C = a0 M + a1 K`` matching two modal damping ratios.

    Args:
        M: Mass matrix (symmetric positive definite).
        K: Stiffness matrix (symmetric positive semi-definite).
        modes: Two distinct 1-based mode numbers ``(i, j)``.
        ratios: ``(ζ_i, ζ_j)``, or one ratio used at both modes. Default 5 % at both.

    Returns:
        The dense damping matrix. Other modes get ``ζ(ω) = a0/(2ω) + a1 ω/2``.

    Raises:
        ConfigError: On bad modes (out of range, equal, or a zero/duplicate frequency) or
            ratios.
    """
    m, k = mass_and_stiffness(M, K)
    w_i, w_j = rayleigh_frequencies(m, k, modes)
    pair = np.atleast_1d(np.asarray(ratios, dtype=object)).reshape(-1)
    if pair.size not in (1, 2):
        msg = f'damping_ratio: expected one ratio or a pair, got {ratios!r}'
        raise ConfigError(msg)
    z_i = _ratio(pair[0], 'damping_ratio')
    z_j = _ratio(pair[-1], 'damping_ratio')
    a0, a1 = rayleigh_coefficients(w_i, w_j, z_i, z_j)
    return a0 * m + a1 * k


def modal_damping(M: Any, K: Any, ratios: Sequence[float]) -> np.ndarray:
    """Classical damping with a prescribed ratio in every mode.

    ``C = M Φ diag(2 ζ_j ω_j) Φᵀ M`` with ``Φ`` mass-normalised (``Φᵀ M Φ = I``), so
    that ``Φᵀ C Φ = diag(2 ζ_j ω_j)`` exactly.

    Args:
        M: Mass matrix (symmetric positive definite).
        K: Stiffness matrix (symmetric positive semi-definite).
        ratios: Damping ratios ``ζ_1, ζ_2, …`` in mode order (ascending frequency), at least
            one and at most ``n``. **If fewer ratios than modes are given, the last ratio
            applies to all remaining (higher) modes**; a single value damps every mode alike.

    Returns:
        The dense, symmetric damping matrix.

    Raises:
        ConfigError: On empty, negative, non-finite or too many ratios.
    """
    m, k = mass_and_stiffness(M, K)
    n = m.shape[0]
    if isinstance(ratios, (str, bytes)):
        msg = f'damping_ratios: expected a list of ratios, got {ratios!r}'
        raise ConfigError(msg)
    if np.ndim(ratios) == 0:
        values = [ratios]
    else:
        values = list(np.asarray(ratios, dtype=object).reshape(-1))
    if not values:
        msg = 'damping_ratios: at least one ratio is required'
        raise ConfigError(msg)
    if len(values) > n:
        msg = f'damping_ratios: {len(values)} ratios given but the model has only {n} modes'
        raise ConfigError(msg)
    zetas = np.array([_ratio(v, 'damping_ratios') for v in values])
    zetas = np.concatenate([zetas, np.full(n - zetas.size, zetas[-1])])
    omegas, shapes = modal_analysis(m, k)
    m_phi = m @ shapes
    damping = (m_phi * (2.0 * zetas * omegas)) @ m_phi.T
    return 0.5 * (damping + damping.T)
