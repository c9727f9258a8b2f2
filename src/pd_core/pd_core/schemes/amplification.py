"""Amplification matrices: the one-step recursion of a scheme on the linear SDOF.

The schemes write their linear SDOF step (``m = 1``, ``Δt = 1``, ``k = Ω²``, ``c = 2ξΩ``) as
linear relations between ``x̂_{n+1}`` and ``x̂_n``, both ``(x, Δt·v, Δt²·a)``; the
eigenvalues of the resulting matrix give the spectral radius, the numerical damping and the
period error (:mod:`pd_core.dynamics.analysis`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ['amplification_from', 'newmark_amplification', 'unit_sdof']


def amplification_from(lhs: Any, rhs: Any) -> np.ndarray:
    """Amplification matrix ``A = L⁻¹ R`` of a one-step recursion ``L x̂_{n+1} = R x̂_n``.

    The schemes write their linear SDOF step (``m = 1``, ``Δt = 1``, ``k = Ω²``,
    ``c = 2ξΩ``) as linear relations between ``x̂_{n+1}`` and ``x̂_n``, both
    ``(x, Δt·v, Δt²·a)``; this solves them.
    """
    return np.linalg.solve(np.array(lhs, dtype=float), np.array(rhs, dtype=float))


def unit_sdof(omega_dt: float, xi: float) -> tuple[float, float]:
    """``(k, c) = (Ω², 2ξΩ)`` of the amplification matrices' SDOF (``m = 1``, ``Δt = 1``)."""
    return float(omega_dt) ** 2, 2.0 * float(xi) * float(omega_dt)


def newmark_amplification(
    beta: float, gamma: float, lhs_motion: list[float], rhs_motion: list[float]
) -> np.ndarray:
    """:func:`amplification_from` with Newmark's updates.

    :func:`amplification_from` with Newmark's ``x``, ``v`` updates (``β``, ``γ``) as the
    first two rows and the scheme's equation of motion as the third.
    """
    lhs = [[1.0, 0.0, -beta], [0.0, 1.0, -gamma], lhs_motion]
    rhs = [[1.0, 1.0, 0.5 - beta], [0.0, 1.0, 1.0 - gamma], rhs_motion]
    return amplification_from(lhs, rhs)
