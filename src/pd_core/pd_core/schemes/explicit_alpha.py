"""Explicit schemes with numerical dissipation (no initial stiffness needed).

* :class:`ExplicitGeneralizedAlpha` — Hulbert & Chung (1996), parameter ``rho_b``;
* :class:`ModifiedNewmark` — the α-modified Newmark explicit scheme of Shing & Mahin (1987),
  parameter ``alpha``.

Both use only the mass and damping matrices and the measured restoring forces, like the
thesis's Newmark explicit scheme (:class:`~.newmark_explicit.NewmarkExplicit`), and
are conditionally stable; their committed restoring force :attr:`r` is the measured one.

In the amplification matrices (``m = 1``, ``Δt = 1``, ``k = Ω²``, ``c = 2ξΩ``) the state is
``(x, Δt·v, Δt²·a)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
import scipy.linalg

from ..errors import ConfigError
from .amplification import amplification_from, newmark_amplification, unit_sdof
from .array import ArrayIntegrator
from .base import SOFTENING_EXPLICIT
from .linalg import Factorization
from .parameters import SchemeParameter

__all__ = ['ExplicitGeneralizedAlpha', 'ModifiedNewmark']


class ExplicitGeneralizedAlpha(ArrayIntegrator):
    """Explicit generalized-α scheme of Hulbert & Chung (1996), parameter ``rho_b``.

    Source: G. M. Hulbert and J. Chung, "Explicit time integration algorithms for structural
    dynamics with optimal numerical dissipation", *Computer Methods in Applied Mechanics and
    Engineering* 137 (1996) 175–188. The algorithm is the generalized-α method of Chung &
    Hulbert (1993) with the internal and external forces taken at ``t_n`` (``α_f = 1``), so
    the restoring force measured at the previous target gives the next one::

        M [(1 − α_m) a_{n+1} + α_m a_n] = p_n − C v_n − r_n                        (1)
        x_{n+1} = x_n + Δt v_n + Δt² [(1/2 − β) a_n + β a_{n+1}]                    (2)
        v_{n+1} = v_n + Δt [(1 − γ) a_n + γ a_{n+1}]                                (3)

    with the optimal-dissipation parameters of the paper as functions of the spectral radius
    ``ρ_b`` at the bifurcation frequency::

        α_m = (2ρ_b − 1)/(1 + ρ_b),  β = (5 − 3ρ_b)/((1 + ρ_b)² (2 − ρ_b)),  γ = 3/2 − α_m

    (the same values as OpenSees's ``HHTGeneralizedExplicit`` with ``rhoB`` and
    ``alphaF = 0``, i.e. the internal force at ``t_n``). ``ρ_b = 1`` gives ``α_m = 1/2``,
    ``β = 1/2``, ``γ = 1``: no dissipation and the central-difference stability limit 2.

    Pseudo-dynamic step: :meth:`predict` solves (1) with the committed ``r_n`` (measured at
    ``x_n``) and ``p_n``, then returns the target ``x_{n+1}`` of (2); :meth:`correct` only
    records ``r_{n+1}`` and ``p_{n+1}`` for the next step (``a_{n+1}``, ``v_{n+1}`` are already
    known). ``a_0`` comes from the equation of motion at ``t_0``, so the first step has
    ``a_1 = a_0``.

    Stability and accuracy (derived here from the characteristic polynomial of (1)–(3),
    ``(λ − 1)² [(1 − α_m) λ + α_m] + Ω² [β λ² + (γ + 1/2 − 2β) λ + (1/2 − γ + β)] = 0``):

    * the three roots coincide at ``λ = −ρ_b`` for ``Ω_b = (1 + ρ_b) √(2 − ρ_b)`` (the
      bifurcation frequency of the paper, :meth:`bifurcation_limit`);
    * a real root leaves the unit circle through ``λ = −1`` at
      ``Ω_s² = 2 (1 − 2α_m)/(2β − γ) = 12 (1 + ρ_b)(2 − ρ_b)/(10 − 5ρ_b + ρ_b²)``, the
      stability limit (:meth:`stability_limit_for`): 2 for ``ρ_b = 1``, √2.4 ≈ 1.549 for
      ``ρ_b = 0``; ``Ω_s ≥ Ω_b``;
    * second-order accurate (``γ = 1/2 − α_m + α_f`` with ``α_f = 1``), with or without
      viscous damping.

    Viscous damping lowers the limit (the damping force ``C v_n`` is explicit): for
    ``ρ_b < 1`` the limit ``Ω_s(ρ_b, ξ)`` decreases with the damping ratio ``ξ`` (e.g.
    ``ρ_b = 0.5``: 1.867 undamped, 1.70 at ``ξ = 5 %``; ``ρ_b = 0.9``: 1.994 and 1.39), and for
    ``ρ_b = 1`` the spurious root ``−α_m/(1 − α_m) = −1`` leaves the unit circle for any
    ``ξ > 0``: the non-dissipative member is unstable with viscous damping. So an instance
    with a non-zero damping matrix takes the damping ratio ``ξ_max`` of its most damped mode
    (``φᵀCφ/(2ω)`` of the modes of ``K_I``, ``M``) and declares
    ``stability_limit = Ω_s(ρ_b, ξ_max)`` (computed from the amplification matrix by
    :meth:`stability_limit_for`), which bounds every mode since ``Ω_s`` decreases with ``ξ``;
    ``ρ_b = 1`` with damping is refused (ConfigError). Without ``K_I`` the modal damping is
    unknown and the undamped limit is declared.
    """

    name: ClassVar[str] = 'explicit_generalized_alpha'
    stability_limit: float = 2.0
    accuracy_order: ClassVar[int] = 2
    softening_note: ClassVar[str] = SOFTENING_EXPLICIT
    needs_initial_stiffness: ClassVar[bool] = False
    numerical_damping_parameter: ClassVar[str | None] = 'rho_b'
    PARAMETERS: ClassVar[tuple[SchemeParameter, ...]] = (
        SchemeParameter('rho_b', 1.0, (
            'spectral radius at the bifurcation frequency (1: no dissipation; < 1 with '
            'viscous damping)'), low=0.0, high=1.0),
    )

    def _apply_parameters(self, parameters: Mapping[str, Any]) -> None:
        self._rho_b = float(parameters['rho_b'])
        self._alpha_m, self._beta, self._gamma = self.coefficients(self._rho_b)

    def _check_damping(self) -> None:
        """Declare the limit of the most damped mode; refuse ``ρ_b = 1`` with damping."""
        xi_max = self._max_damping_ratio()
        if self._rho_b == 1.0 and (xi_max > 0.0 or np.any(self._damping != 0.0)):
            msg = ('rho_b: 1 is unstable with viscous damping (the spurious root -1 leaves the '
                   'unit circle); use rho_b < 1 (e.g. 0.9) or no damping')
            raise ConfigError(msg)
        self.stability_limit = self.stability_limit_for(rho_b=self._rho_b, xi=xi_max)

    def _max_damping_ratio(self) -> float:
        """Largest modal damping ratio ``φᵀCφ/(2ω)`` of the modes of ``(K_I, M)`` (0 if none)."""
        if self._initial_stiffness is None or not np.any(self._damping != 0.0):
            return 0.0
        try:
            eigenvalues, modes = scipy.linalg.eigh(self._initial_stiffness, self._mass)
        except (np.linalg.LinAlgError, ValueError):
            return 0.0
        ratios = [
            float(modes[:, j] @ self._damping @ modes[:, j]) / (2.0 * math.sqrt(value))
            for j, value in enumerate(eigenvalues)
            if value > 0.0
        ]
        return max([0.0, *ratios])

    @staticmethod
    def coefficients(rho_b: float) -> tuple[float, float, float]:
        """``(α_m, β, γ)`` of Hulbert & Chung (1996) for ``ρ_b``."""
        alpha_m = (2.0 * rho_b - 1.0) / (1.0 + rho_b)
        beta = (5.0 - 3.0 * rho_b) / ((1.0 + rho_b) ** 2 * (2.0 - rho_b))
        gamma = 1.5 - alpha_m
        return alpha_m, beta, gamma

    @classmethod
    def _stability_limit(cls, parameters: Mapping[str, Any], xi: float) -> float:
        """Stability limit ``Ω_s(ρ_b, ξ)``.

        Undamped (``ξ = 0``): ``Ω_s = √(12 (1 + ρ_b)(2 − ρ_b)/(10 − 5ρ_b + ρ_b²))`` (see the
        class docstring). Damped: the largest ``Ω`` such that the spectral radius of
        :meth:`amplification_matrix` stays ≤ 1 on ``(0, Ω]``, found by a scan and bisection;
        0 for ``ρ_b = 1`` (unstable at any ``Ω > 0``).
        """
        rho = float(parameters['rho_b'])
        damping = xi
        undamped = math.sqrt(12.0 * (1.0 + rho) * (2.0 - rho) / (10.0 - 5.0 * rho + rho * rho))
        if damping == 0.0:
            return undamped
        if rho == 1.0:
            return 0.0

        def stable(omega: float) -> bool:
            matrix = cls.amplification_matrix(omega, damping, rho_b=rho)
            return float(np.max(np.abs(np.linalg.eigvals(matrix)))) <= 1.0 + 1e-12

        grid = np.linspace(0.0, undamped, 401)[1:]
        low = 0.0
        for omega in grid:
            if not stable(float(omega)):
                high = float(omega)
                break
            low = float(omega)
        else:
            return undamped
        for _ in range(60):
            middle = 0.5 * (low + high)
            if stable(middle):
                low = middle
            else:
                high = middle
        return low

    @classmethod
    def bifurcation_limit(cls, rho_b: float = 1.0) -> float:
        """``Ω_b = (1 + ρ_b) √(2 − ρ_b)``, where the spectral radius is ``ρ_b``."""
        rho = float(cls.resolve_parameters(rho_b=rho_b)['rho_b'])
        return (1.0 + rho) * math.sqrt(2.0 - rho)

    @classmethod
    def _amplification(cls, omega_dt: float, xi: float, parameters: Mapping[str, Any]
                       ) -> np.ndarray:
        """Eqs. (1)–(3) of the class docstring on ``(x, Δt·v, Δt²·a)``."""
        alpha_m, beta, gamma = cls.coefficients(float(parameters['rho_b']))
        k, c = unit_sdof(omega_dt, xi)
        return newmark_amplification(beta, gamma, [0.0, 0.0, 1.0 - alpha_m], [-k, -c, -alpha_m])

    def _setup_scheme(self) -> None:
        self._check_damping()
        self._a_next: Any = None
        self._v_next: Any = None

    def _predict(self) -> Any:
        dt = self._dt
        x, v, a = self._committed()
        rhs = self._motion_rhs(self._arr(self._p), v, self._arr(self._r))
        a_new = (self._mass_factor.solve(rhs) - self._alpha_m * a) / (1.0 - self._alpha_m)
        x_new = x + dt * v + dt * dt * ((0.5 - self._beta) * a + self._beta * a_new)
        v_new = v + dt * ((1.0 - self._gamma) * a + self._gamma * a_new)
        self._a_next = self._out(a_new)
        self._v_next = self._out(v_new)
        return self._out(x_new)

    def _correct(self, restoring_force: Any, load: Any) -> tuple[Any, Any]:
        return self._a_next, self._v_next


class ModifiedNewmark(ArrayIntegrator):
    """Modified Newmark explicit scheme with numerical dissipation (Shing & Mahin 1987).

    Source: P. B. Shing and S. A. Mahin, "Elimination of spurious higher-mode response in
    pseudodynamic tests", *Earthquake Engineering & Structural Dynamics* 15 (1987) 425–445,
    which proposes an explicit algorithm whose numerical damping acts through the measured
    restoring forces (so it follows the specimen's actual, unmeasurable tangent stiffness,
    unlike an initial-stiffness-proportional viscous damping).

    Formulation implemented (the paper itself could not be consulted for this implementation;
    this is the explicit Newmark scheme of the thesis, eqs. 3.20–3.22, with the equation of
    motion weighted as in
    Hilber, Hughes & Taylor's α-method — the same structure as OpenSees's ``HHTExplicit``
    with ``gamma = 1/2`` and ``alpha_OpenSees = 1 + α``)::

        x_{i+1} = x_i + Δt v_i + Δt²/2 a_i                                         (1)
        v_{i+1} = v_i + Δt/2 (a_i + a_{i+1})                                       (2)
        M a_{i+1} + (1 + α)(C v_{i+1} + r_{i+1} − p_{i+1})
                  − α (C v_i + r_i − p_i) = 0                                      (3)

    so ``a_{i+1} = [M + (1+α) Δt/2 C]⁻¹ [(1+α)(p_{i+1} − r_{i+1}) − α (p_i − r_i) − C v_i
    − (1+α) Δt/2 C a_i]``. ``α = 0`` is exactly the thesis's Newmark explicit scheme.
    The extra term ``α (r_{i+1} − r_i) ≈ α Δt K_t v`` is a damping proportional to the
    *tangent* stiffness, which is what removes spurious higher-mode response.

    Why ``α ≥ 0`` here, unlike the HHT range ``−1/3 ≤ α ≤ 0``: with ``β = 0`` the displacement
    recursion of (1)–(3) is ``x_{i+1} − 2x_i + x_{i−1} = −Ω² [(1+α) x_i − α x_{i−1}]``
    (undamped), with characteristic polynomial ``λ² + [(1+α) Ω² − 2] λ + (1 − α Ω²)``
    (the third root of the 3×3 amplification matrix is 0). Its product of roots
    ``1 − α Ω²`` exceeds 1 for any ``α < 0``, so dissipation needs ``α > 0``; the HHT pairing
    ``γ = 1/2 − α`` that would keep second order makes the explicit scheme unstable for every
    ``Ω`` (Jury test), so the scheme keeps ``γ = 1/2``.

    Properties (from that polynomial, no viscous damping):

    * stable for ``Ω ≤ Ω_s = 2/√(1 + 2α)`` (the root at ``λ = −1``); :meth:`stability_limit_for`;
    * spectral radius of the principal roots ``√(1 − α Ω²)``: numerical damping
      ``ξ̄ ≈ α Ω/2`` for small ``Ω``, growing with frequency;
    * first-order accurate for ``α > 0`` (the numerical damping is ``O(Δt)``), second order
      for ``α = 0``.

    The committed restoring force :attr:`r` is the measured one.
    """

    name: ClassVar[str] = 'modified_newmark'
    stability_limit: float = 2.0 / math.sqrt(1.1)
    accuracy_order: ClassVar[int] = 1  # first order for alpha > 0 (the default 0.05)
    softening_note: ClassVar[str] = SOFTENING_EXPLICIT
    needs_initial_stiffness: ClassVar[bool] = False
    numerical_damping_parameter: ClassVar[str | None] = 'alpha'

    #: Largest accepted ``α`` (``Ω_s = √2`` there).
    ALPHA_MAX: ClassVar[float] = 0.5
    PARAMETERS: ClassVar[tuple[SchemeParameter, ...]] = (
        SchemeParameter('alpha', 0.05, 'dissipation parameter (0: Newmark explicit)',
                        low=0.0, high=ALPHA_MAX),
    )

    def _apply_parameters(self, parameters: Mapping[str, Any]) -> None:
        self._alpha = float(parameters['alpha'])

    @classmethod
    def _stability_limit(cls, parameters: Mapping[str, Any], xi: float) -> float:
        """``Ω_s = 2/√(1 + 2α)``."""
        return 2.0 / math.sqrt(1.0 + 2.0 * float(parameters['alpha']))

    @classmethod
    def _amplification(cls, omega_dt: float, xi: float, parameters: Mapping[str, Any]
                       ) -> np.ndarray:
        """Eqs. (1)–(3) of the class docstring on ``(x, Δt·v, Δt²·a)``."""
        value = float(parameters['alpha'])
        k, c = unit_sdof(omega_dt, xi)
        w = 1.0 + value
        lhs = [[1.0, 0.0, 0.0], [0.0, 1.0, -0.5], [w * k, w * c, 1.0]]
        rhs = [[1.0, 1.0, 0.5], [0.0, 1.0, 0.5], [value * k, value * c, 0.0]]
        return amplification_from(lhs, rhs)

    def _setup_scheme(self) -> None:
        w = 1.0 + self._alpha
        self._lhs = Factorization(
            self._mass + w * 0.5 * self._dt * self._damping, 'M + (1+alpha) dt/2 C'
        )

    def _predict(self) -> Any:
        dt = self._dt
        x, v, a = self._committed()
        return self._out(x + dt * v + a * dt * dt * 0.5)

    def _correct(self, restoring_force: Any, load: Any) -> tuple[Any, Any]:
        alpha = self._alpha
        w = 1.0 + alpha
        v = self._arr(self._v)
        a = self._arr(self._a)
        c = self._damping_product
        rhs = (
            w * (self._arr(load) - self._arr(restoring_force))
            - alpha * (self._arr(self._p) - self._arr(self._r))
            - c @ v
            - w * 0.5 * self._dt * (c @ a)
        )
        a_new = self._lhs.solve(rhs)
        v_new = v + 0.5 * self._dt * (a + a_new)
        return self._out(a_new), self._out(v_new)
