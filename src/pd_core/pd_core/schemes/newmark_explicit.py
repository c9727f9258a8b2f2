"""Newmark explicit (``β = 0``, ``γ = 1/2``): the thesis's scheme (eqs. 3.20–3.22).

Also the closed forms of its stability analysis (thesis §3.3.1): the amplification matrix of
eq. 3.7 and the numerical frequency of eq. 3.19.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
import scipy.linalg
import scipy.sparse

from ..errors import ConfigError
from .amplification import amplification_from
from .base import COMMITTED, CORRECTED, PREDICTED, SOFTENING_EXPLICIT, Integrator
from .linalg import (
    LARGE_MODEL_DOF,
    Tridiagonal,
    cholesky_or_lu,
    is_sparse_structure,
    large_bands,
    large_diagonal,
    operator,
    solve_factored,
)

__all__ = [
    'NewmarkExplicit',
    'amplification_matrix_newmark_explicit',
    'newmark_explicit_numerical_frequency',
]


def amplification_matrix_newmark_explicit(
    omega_dt: float, dt: float = 1.0, xi: float = 0.0
) -> np.ndarray:
    """Amplification matrix ``A`` of the Newmark explicit scheme (thesis eq. 3.7).

    With ``ω = omega_dt/dt`` the matrix acts on ``x̂ = (x, v, a)``. The default ``dt = 1``
    gives the Δt-normalised form, which acts on ``(x, Δt·v, Δt²·a)``; all choices of ``dt``
    give similar matrices (``D A D⁻¹`` with ``D = diag(1, Δt, Δt²)``), so the eigenvalues and
    the spectral radius depend on ``Ω = ωΔt`` (and ``ξ``) only.

    With viscous damping (``m = 1``, ``c = 2ξω``) the step of eqs. 3.20–3.22 reads, with
    ``d = 1 + ξΩ``: ``a_{i+1} = −(ω² x_{i+1} + c v_i + c Δt/2 a_i)/d``; ``ξ = 0`` gives eq. 3.7
    exactly.

    Args:
        omega_dt: ``Ω = ωΔt`` (≥ 0).
        dt: Time step in s used to dimension the matrix (positive).
        xi: Viscous damping ratio ``ξ`` (≥ 0).

    Returns:
        The 3×3 amplification matrix.
    """
    if not (dt > 0.0 and math.isfinite(dt)):
        msg = f'dt: must be positive and finite, got {dt!r}'
        raise ConfigError(msg)
    w = float(omega_dt) / dt
    w2 = w * w
    c = 2.0 * float(xi) * w
    d = 1.0 + c * dt / 2.0
    return np.array(
        [
            [1.0, dt, dt**2 / 2.0],
            [
                -w2 * dt / 2.0 / d,
                1.0 - (w2 * dt**2 + c * dt) / (2.0 * d),
                dt / 2.0 - (w2 * dt**3 / 2.0 + c * dt**2 / 2.0) / (2.0 * d),
            ],
            [-w2 / d, -(w2 * dt + c) / d, -(w2 * dt**2 / 2.0 + c * dt / 2.0) / d],
        ]
    )


def newmark_explicit_numerical_frequency(omega_dt: float) -> float:
    """Numerical frequency ``Ω̄ = ω̄Δt`` of the Newmark explicit scheme (thesis eq. 3.19).

    ``Ω̄ = atan2(B, A)`` with ``A = 1 − Ω²/2`` (eq. 3.11) and
    ``B = √(4 − (Ω² − 2)²)/2 = Ω √(4 − Ω²)/2`` (eq. 3.12, factored to avoid cancellation).
    The two-argument arctangent keeps the right branch for ``√2 < Ω ≤ 2``, where ``A < 0``
    and ``Ω̄`` lies in ``(π/2, π]``.

    Args:
        omega_dt: ``Ω = ωΔt`` (≥ 0).

    Returns:
        ``Ω̄`` in rad per step, or NaN above the stability limit ``Ω > 2`` (no oscillatory
        solution exists there).
    """
    omega = float(omega_dt)
    if not (omega >= 0.0) or omega > 2.0:
        return math.nan
    a = 1.0 - omega * omega / 2.0
    b = omega * math.sqrt(4.0 - omega * omega) / 2.0
    return math.atan2(b, a)


class NewmarkExplicit(Integrator):
    """Newmark explicit scheme (``β = 0``, ``γ = 1/2``), thesis eqs. 3.20–3.22.

    Per step, in the operation order of Appendix A (lines 72, 76, 77)::

        x_{i+1} = x_i + Δt v_i + a_i Δt Δt 0.5                               (3.21)
        a_{i+1} = (p_{i+1} − r_{i+1} − C v_i − Δt 0.5 C a_i) / (M + Δt 0.5 C)  (3.22)
        v_{i+1} = v_i + Δt 0.5 (a_i + a_{i+1})                               (3.20)

    For an MDOF the division is a solve with ``M + Δt/2·C``, factorised once. The scheme has
    no numerical damping and is stable for ``ω_max·Δt ≤ 2`` (eq. 3.14); it is second-order
    accurate. The committed restoring force :attr:`r` is the measured one.
    """

    name: ClassVar[str] = 'newmark_explicit'
    stability_limit: float = 2.0
    needs_initial_stiffness: ClassVar[bool] = False
    accuracy_order: ClassVar[int] = 2
    softening_note: ClassVar[str] = SOFTENING_EXPLICIT

    @classmethod
    def numerical_frequency(cls, omega_dt: float) -> float:
        """Thesis eq. 3.19 (:func:`newmark_explicit_numerical_frequency`)."""
        return newmark_explicit_numerical_frequency(omega_dt)

    @classmethod
    def _amplification(cls, omega_dt: float, xi: float, parameters: Mapping[str, Any]
                       ) -> np.ndarray:
        """The scheme's amplification matrix.

        Thesis eq. 3.7 on ``(x, Δt·v, Δt²·a)``; with damping, eqs. 3.20–3.22 with ``c = 2ξω``
        (:func:`amplification_matrix_newmark_explicit` for ``ξ = 0``).
        """
        if xi == 0.0:
            return amplification_matrix_newmark_explicit(omega_dt)
        k = float(omega_dt) ** 2
        c = 2.0 * float(xi) * float(omega_dt)
        # x1 = x0 + v0 + a0/2;  v1 = v0 + (a0 + a1)/2;  a1 + c v0 + c/2 a0 + k x1 = ... (3.22)
        lhs = [[1.0, 0.0, 0.0], [0.0, 1.0, -0.5], [k, 0.0, 1.0 + 0.5 * c]]
        rhs = [[1.0, 1.0, 0.5], [0.0, 1.0, 0.5], [0.0, -c, -0.5 * c]]
        return amplification_from(lhs, rhs)

    def _setup(self) -> None:
        dt = self._dt
        self._half_dt = dt * 0.5
        if self._scalar:
            m = float(self._mass[0, 0])
            c = float(self._damping[0, 0])
            self._m = m
            self._c = c
            self._half_dt_c = dt * 0.5 * c
            self._lhs = m + dt * 0.5 * c
            if not (self._lhs > 0.0):
                msg = f'damping: m + dt/2*c = {self._lhs!r} must be positive'
                raise ConfigError(msg)
            return
        c_matrix = self._damping
        # A large model takes C v_i + Δt/2 C a_i as one product C (v_i + Δt/2 a_i).
        self._one_product = self._n >= LARGE_MODEL_DOF
        if not self._one_product:
            self._half_dt_c_matrix = operator(dt * 0.5 * c_matrix)
        lhs = self._mass + dt * 0.5 * c_matrix
        c_bands = large_bands(c_matrix) if self._one_product else None
        self._damping_operator = (operator(c_matrix) if c_bands is None
                                  else Tridiagonal(*c_bands))  # (operator's bands, not recounted)
        if c_bands is not None:  # the off-diagonals say it: O(n)
            symmetric = bool(np.array_equal(c_bands[0], c_bands[2]))
        elif self._one_product and is_sparse_structure(c_matrix):  # no n×n transposed pass
            sparse = scipy.sparse.csr_matrix(c_matrix)
            symmetric = (sparse != sparse.T).nnz == 0
        else:
            symmetric = bool(np.array_equal(c_matrix, c_matrix.T))
        self._factor = cholesky_or_lu(lhs, symmetric,
                                      large_bands(lhs) if c_bands is not None else None)
        if self._factor[0] == 'lu' and np.any(np.diag(self._factor[1][0]) == 0.0):
            msg = 'damping: M + dt/2*C is singular'
            raise ConfigError(msg)
        # a_0 = M⁻¹ (…): a large lumped mass divides (no dense Cholesky of n² entries).
        self._mass_diagonal = large_diagonal(self._mass)
        if self._mass_diagonal is None:
            self._mass_factor = scipy.linalg.cho_factor(self._mass)

    def _solve(self, rhs: np.ndarray) -> np.ndarray:
        return solve_factored(self._factor, rhs)

    def _initial_acceleration(self, x0: Any, v0: Any, p0: Any, r0: Any) -> Any:
        if self._scalar:
            return (p0 - self._c * v0 - r0) / self._m
        if self._mass_diagonal is not None:
            return (p0 - self._damping_operator @ v0 - r0) / self._mass_diagonal
        return scipy.linalg.cho_solve(self._mass_factor, p0 - self._damping @ v0 - r0)

    def _predict(self) -> Any:
        dt = self._dt
        return self._x + dt * self._v + self._a * dt * dt * 0.5

    def _correct(self, restoring_force: Any, load: Any) -> tuple[Any, Any]:
        v = self._v
        a = self._a
        if self._scalar:
            a_new = (load - restoring_force - self._c * v - self._half_dt_c * a) / self._lhs
        elif self._one_product:
            a_new = self._solve(
                load - restoring_force - self._damping_operator @ (v + self._half_dt * a))
        else:
            a_new = self._solve(
                load - restoring_force - self._damping_operator @ v
                - self._half_dt_c_matrix @ a
            )
        v_new = v + self._half_dt * (a + a_new)
        return a_new, v_new

    def predict(self) -> np.ndarray:
        """Compute the trial displacement of the next step (an SDOF fast path)."""
        # SDOF fast path: same checks and arithmetic as the generic path, fewer calls.
        if self._scalar and self._status == 'running' and self._phase == COMMITTED:
            dt = self._dt
            xt = self._x + dt * self._v + self._a * dt * dt * 0.5
            if xt - xt == 0.0:  # finite
                self._xt = xt
                self._phase = PREDICTED
                return np.array((xt,))
        return super().predict()

    def correct(self, restoring_force: Any, load: Any) -> None:
        """Compute the trial acceleration and velocity (an SDOF fast path)."""
        # SDOF fast path for float inputs (numpy float64 and one-element arrays included);
        # anything else goes through the validating path of the base class.
        if self._scalar:
            if type(restoring_force) is np.ndarray and restoring_force.size == 1:
                restoring_force = restoring_force.item()
            elif type(restoring_force) is not float and isinstance(restoring_force, float):
                restoring_force = float(restoring_force)
            if type(load) is np.ndarray and load.size == 1:
                load = load.item()
            elif type(load) is not float and isinstance(load, float):
                load = float(load)
        if (
            self._scalar
            and type(restoring_force) is float
            and type(load) is float
            and self._phase == PREDICTED
            and self._status == 'running'
            and restoring_force - restoring_force == 0.0
            and load - load == 0.0
        ):
            v = self._v
            a = self._a
            a_new = (load - restoring_force - self._c * v - self._half_dt_c * a) / self._lhs
            v_new = v + self._half_dt * (a + a_new)
            if a_new - a_new == 0.0 and v_new - v_new == 0.0:
                self._at = a_new
                self._vt = v_new
                self._rt = restoring_force
                self._pt = load
                self._phase = CORRECTED
                return
        super().correct(restoring_force, load)
