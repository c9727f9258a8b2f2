"""Modal superposition: the exact response of a classically damped linear MDOF.

``M ẍ + C ẋ + K x = p(t)`` with ``p`` piecewise linear between samples is decoupled with the
mass-normalised modes (modal analysis, Chopra ch. 10 and 12) and each modal equation solved
exactly by :func:`~.nigam_jennings.nigam_jennings`.

Units are SI; numpy/scipy only.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg

from ..errors import ConfigError
from .checks import positive
from .nigam_jennings import nigam_jennings

__all__ = [
    'modal_superposition',
]


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
        msg = (
            f'mass, stiffness: expected square matrices of one shape, '
                          f'got {m.shape} and {k.shape}'
        )
        raise ConfigError(msg)
    if not (np.all(np.isfinite(m)) and np.all(np.isfinite(k))):
        msg = 'mass, stiffness: all values must be finite'
        raise ConfigError(msg)
    if not (np.allclose(m, m.T, rtol=1e-12, atol=0.0) and np.allclose(k, k.T, rtol=1e-12,
                                                                      atol=0.0)):
        msg = 'mass, stiffness: matrices must be symmetric'
        raise ConfigError(msg)
    try:
        eigenvalues, phi = scipy.linalg.eigh(k, m)
    except np.linalg.LinAlgError:
        msg = 'mass: matrix must be positive definite'
        raise ConfigError(msg) from None
    if not np.all(eigenvalues > 0.0):
        msg = f'stiffness: every mode needs a positive frequency, got ω² = {eigenvalues.min():.6g}'
        raise ConfigError(msg)
    omegas = np.sqrt(eigenvalues)
    dt_value = positive(dt, 'dt')

    if (damping_ratios is None) == (damping_matrix is None):
        msg = 'damping: give exactly one of damping_ratios and damping_matrix'
        raise ConfigError(msg)
    if damping_matrix is not None:
        c = np.atleast_2d(np.array(damping_matrix, dtype=float))
        if c.shape != (n, n) or not np.all(np.isfinite(c)):
            msg = f'damping_matrix: expected a finite ({n}, {n}) matrix'
            raise ConfigError(msg)
        modal_c = phi.T @ c @ phi
        diag = np.diag(modal_c).copy()
        scale = float(np.max(np.abs(diag)))
        off = modal_c - np.diag(diag)
        worst = float(np.max(np.abs(off))) if n > 1 else 0.0
        if worst > classical_tol * scale:
            msg = (
                f'damping_matrix: not classical: off-diagonal modal damping {worst:.3g} '
                f'exceeds {classical_tol:g} x {scale:.3g} (ΦᵀCΦ must be diagonal)'
            )
            raise ConfigError(msg)
        zetas = diag / (2.0 * omegas)
    else:
        zetas = np.array(damping_ratios, dtype=float).reshape(-1)
        if zetas.size == 1:
            zetas = np.full(n, float(zetas[0]))
        if zetas.size != n:
            msg = f'damping_ratios: expected 1 or {n} values, got {zetas.size}'
            raise ConfigError(msg)
    if not np.all(np.isfinite(zetas) & (zetas >= 0.0) & (zetas < 1.0)):
        msg = f'damping: modal damping ratios must be in [0, 1), got {zetas}'
        raise ConfigError(msg)

    p = np.array(load, dtype=float)
    if p.ndim == 1 and n == 1:
        p = p.reshape(-1, 1)
    if p.ndim != 2 or p.shape[1] != n or p.shape[0] == 0:
        msg = f'load: expected shape (n_samples, {n}), got {p.shape}'
        raise ConfigError(msg)
    if not np.all(np.isfinite(p)):
        msg = 'load: all values must be finite'
        raise ConfigError(msg)
    x_init = np.zeros(n) if x0 is None else np.array(x0, dtype=float).reshape(-1)
    v_init = np.zeros(n) if v0 is None else np.array(v0, dtype=float).reshape(-1)
    if x_init.shape != (n,) or v_init.shape != (n,):
        msg = f'x0, v0: expected shape ({n},)'
        raise ConfigError(msg)

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
