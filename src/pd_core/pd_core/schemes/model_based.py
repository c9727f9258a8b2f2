"""Explicit model-based schemes: Chen–Ricles (CR) and Kolay–Ricles KR-α.

Both are explicit in displacement *and* velocity, with integration-parameter matrices built
once from ``M``, ``C`` and the initial stiffness ``K_I``::

    x_{n+1} = x_n + Δt v_n + Δt² α₂ a_n                                     (target)
    v_{n+1} = v_n + Δt α₁ a_n

so the target needs no restoring force; the measured ``r_{n+1}`` then gives ``a_{n+1}``
from the equation of motion. No correction is applied to the measured force: the committed
:attr:`~.base.Integrator.r` is the measured one.

For a linear specimen with stiffness ``K_I`` the schemes are unconditionally stable and
second-order accurate; they stay unconditionally stable for softening specimens, while a
specimen stiffer than ``K_I`` makes them conditionally stable (unstable at large ``Ω``).

Order of accuracy, precisely: the displacement *recurrence* is second order (the
definition used by the papers), but at low frequency ``α₂ → (1/2 + γ) I`` (``I`` for CR),
not ``I/2``, so the self-starting first step ``x_1 = x_0 + Δt v_0 + Δt² α₂ a_0`` carries an
``O(Δt²)`` error whenever ``a_0 ≠ 0``, which makes the global displacement error ``O(Δt)``
for such starts (e.g. a free vibration from a displaced position). A test that starts from
rest (``a_0 = 0``) keeps second order; the tests check both.

In the amplification matrices (``m = 1``, ``Δt = 1``, ``k = Ω²``, ``c = 2ξΩ``, specimen
stiffness ``K_I``) the state is ``(x, Δt·v, Δt²·a)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from .amplification import amplification_from, unit_sdof
from .array import ArrayIntegrator, GeneralizedAlphaFamily
from .base import SOFTENING_SPLIT
from .linalg import Factorization, is_sparse_structure, operator

__all__ = ['ChenRicles', 'KRAlpha']


class _ModelBased(ArrayIntegrator):
    """The predictor of the module docstring: target ``x_{n+1}``, ``v_{n+1}`` kept.

    ``α₁ = s₁ D⁻¹ M`` and ``α₂ = s₂ D⁻¹ M`` for a model matrix ``D``. Small models keep
    ``α₁``, ``α₂`` as dense matrices; a large sparse model (see :func:`~.linalg.operator`)
    applies them as one sparse solve per step instead (the inverse of a sparse matrix is
    dense: O(n²) per product).
    """

    accuracy_order: ClassVar[int] = 2
    softening_note: ClassVar[str] = SOFTENING_SPLIT.replace(
        'its unconditional', 'its (model-based) unconditional')

    _alpha1: np.ndarray
    _alpha2: np.ndarray
    _v_next: Any = None
    _sparse_model: Factorization | None = None
    _alpha_scales: tuple[float, float] = (1.0, 1.0)

    def _set_alphas(self, model: Factorization, d_matrix: np.ndarray,
                    scales: tuple[float, float]) -> None:
        """``α₁ = s₁ D⁻¹ M``, ``α₂ = s₂ D⁻¹ M`` (matrices, or the sparse factor of ``D``)."""
        if is_sparse_structure(d_matrix):
            self._sparse_model = model
            self._alpha_scales = scales
            return
        base = model.solve(self._mass)
        self._alpha1 = scales[0] * base
        self._alpha2 = base if scales[1] == 1.0 else scales[1] * base
        if scales[0] == scales[1]:
            self._alpha2 = self._alpha1

    def _predict(self) -> Any:
        dt = self._dt
        x, v, a = self._committed()
        if self._sparse_model is not None:
            base = self._sparse_model.solve(self._mass_product @ a)
            alpha1_a = self._alpha_scales[0] * base
            alpha2_a = self._alpha_scales[1] * base
        else:
            alpha1_a = self._alpha1 @ a
            alpha2_a = self._alpha2 @ a
        self._v_next = self._out(v + dt * alpha1_a)
        return self._out(x + dt * v + dt * dt * alpha2_a)


class ChenRicles(_ModelBased):
    """CR explicit model-based scheme (Chen & Ricles 2008).

    Source: C. Chen and J. M. Ricles, "Development of direct integration algorithms for
    structural dynamics using discrete control theory", *Journal of Engineering Mechanics*
    (ASCE) 134(8) (2008) 676–683. The algorithm::

        v_{n+1} = v_n + Δt α₁ a_n                                                  (1)
        x_{n+1} = x_n + Δt v_n + Δt² α₂ a_n                                        (2)
        M a_{n+1} + C v_{n+1} + r_{n+1} = p_{n+1}                                  (3)
        α₁ = α₂ = 4 (4M + 2Δt C + Δt² K_I)⁻¹ M

    For a linear system with ``K = K_I`` the displacements obey
    ``x_{n+1} − 2x_n + x_{n−1} = Δt² α a_n`` with ``a_n = −M⁻¹K x_n``: central differences
    with ``Ω²/(1 + Ω²/4)``, i.e. the poles of the average-acceleration (trapezoidal) method:
    unconditionally stable, no numerical dissipation, second-order recurrence (but see the
    module docstring on starts with ``a_0 ≠ 0``). :meth:`predict` returns (2) and stores
    (1), :meth:`correct` solves (3) with ``M`` (factorised once).
    """

    name: ClassVar[str] = 'cr'
    stability_limit: float = math.inf
    needs_initial_stiffness: ClassVar[bool] = True
    numerical_damping_parameter: ClassVar[str | None] = None

    @classmethod
    def _amplification(cls, omega_dt: float, xi: float, parameters: Mapping[str, Any]
                       ) -> np.ndarray:
        """Eqs. (1)–(3) of the class docstring with ``K = K_I`` on ``(x, Δt·v, Δt²·a)``."""
        k, c = unit_sdof(omega_dt, xi)
        alpha = 4.0 / (4.0 + 2.0 * c + k)
        lhs = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [k, c, 1.0]]
        rhs = [[1.0, 1.0, alpha], [0.0, 1.0, alpha], [0.0, 0.0, 0.0]]
        return amplification_from(lhs, rhs)

    def _setup_scheme(self) -> None:
        dt = self._dt
        d_matrix = 4.0 * self._mass + 2.0 * dt * self._damping + dt * dt * self._k_initial
        model = Factorization(d_matrix, '4M + 2 dt C + dt^2 K_I')
        self._set_alphas(model, d_matrix, (4.0, 4.0))

    def _correct(self, restoring_force: Any, load: Any) -> tuple[Any, Any]:
        rhs = self._motion_rhs(
            self._arr(load), self._arr(self._v_next), self._arr(restoring_force)
        )
        return self._out(self._mass_factor.solve(rhs)), self._v_next


class KRAlpha(_ModelBased, GeneralizedAlphaFamily):
    """KR-α explicit model-based scheme (Kolay & Ricles 2014), parameter ``rho_inf``.

    Source: C. Kolay and J. M. Ricles, "Development of a family of unconditionally stable
    explicit direct integration algorithms with controllable numerical energy dissipation",
    *Earthquake Engineering & Structural Dynamics* 43 (2014) 1361–1380; the public source of
    OpenSees's ``KRAlphaExplicit`` integrator. The algorithm::

        v_{n+1} = v_n + Δt α₁ a_n                                                  (1)
        x_{n+1} = x_n + Δt v_n + Δt² α₂ a_n                                        (2)
        M [(I − α₃) a_{n+1} + α₃ a_n] + C v_{n+1−α_f} + r_{n+1−α_f} = p_{n+1−α_f}  (3)

    with ``(·)_{n+1−α_f} = (1 − α_f)(·)_{n+1} + α_f (·)_n`` and::

        α_m = (2ρ∞ − 1)/(ρ∞ + 1),  α_f = ρ∞/(ρ∞ + 1),
        γ = 1/2 − α_m + α_f,       β = (1 − α_m + α_f)²/4
        D = M + γΔt C + βΔt² K_I
        α₁ = D⁻¹ M,  α₂ = (1/2 + γ) α₁,  α₃ = D⁻¹ (α_m M + α_f γΔt C + α_f βΔt² K_I)

    For ``K = K_I`` it is spectrally the generalized-α method: unconditionally stable,
    second-order recurrence (see the module docstring on starts with ``a_0 ≠ 0``), spectral
    radius ``ρ∞`` at ``Ω → ∞`` (``ρ∞ = 1``: no dissipation, and then ``α₃ = I/2``). (3) is
    solved with ``M (I − α₃)``, factorised once.
    """

    name: ClassVar[str] = 'kr_alpha'

    @classmethod
    def _amplification(cls, omega_dt: float, xi: float, parameters: Mapping[str, Any]
                       ) -> np.ndarray:
        """Eqs. (1)–(3) of the class docstring with ``K = K_I`` on ``(x, Δt·v, Δt²·a)``."""
        alpha_m, alpha_f, beta, gamma = cls.coefficients(float(parameters['rho_inf']))
        k, c = unit_sdof(omega_dt, xi)
        d = 1.0 + gamma * c + beta * k
        alpha1 = 1.0 / d
        alpha2 = (0.5 + gamma) * alpha1
        alpha3 = (alpha_m + alpha_f * gamma * c + alpha_f * beta * k) / d
        w = 1.0 - alpha_f
        lhs = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [w * k, w * c, 1.0 - alpha3]]
        rhs = [[1.0, 1.0, alpha2], [0.0, 1.0, alpha1], [-alpha_f * k, -alpha_f * c, -alpha3]]
        return amplification_from(lhs, rhs)

    def _setup_scheme(self) -> None:
        dt = self._dt
        m, c, k = self._mass, self._damping, self._k_initial
        gamma, beta, alpha_f = self._gamma, self._beta, self._alpha_f
        d_matrix = m + gamma * dt * c + beta * dt * dt * k
        model = Factorization(d_matrix, 'M + gamma dt C + beta dt^2 K_I')
        self._set_alphas(model, d_matrix, (1.0, 0.5 + gamma))
        b_matrix = self._alpha_m * m + alpha_f * gamma * dt * c + alpha_f * beta * dt * dt * k
        if self._sparse_model is not None:
            # α₃ = D⁻¹ B, and M − M α₃ = M D⁻¹ (D − B): both applied by sparse solves.
            self._b_product = operator(b_matrix)
            self._d_product = operator(d_matrix)
            self._d_minus_b = Factorization(d_matrix - b_matrix, 'D - B (M (I - alpha3))')
            return
        self._alpha3 = model.solve(b_matrix)
        self._m_alpha3 = m @ self._alpha3
        self._effective_mass = Factorization(m - self._m_alpha3, 'M (I - alpha3)')

    def _correct(self, restoring_force: Any, load: Any) -> tuple[Any, Any]:
        rhs = self._weighted_rhs(
            self._alpha_f, load, self._arr(restoring_force), self._arr(self._v_next)
        )
        a = self._arr(self._a)
        if self._sparse_model is not None:
            rhs = rhs - self._mass_product @ self._sparse_model.solve(self._b_product @ a)
            a_new = self._d_minus_b.solve(self._d_product @ self._mass_factor.solve(rhs))
            return self._out(a_new), self._v_next
        rhs = rhs - self._m_alpha3 @ a
        return self._out(self._effective_mass.solve(rhs)), self._v_next
