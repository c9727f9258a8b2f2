"""Common bases of the array-based scheme families (every scheme but Newmark explicit)."""

from __future__ import annotations

import abc
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from .base import Integrator
from .linalg import Factorization, operator
from .parameters import SchemeParameter

__all__ = ['ArrayIntegrator', 'GeneralizedAlphaFamily']


class ArrayIntegrator(Integrator):
    """Common base of the scheme families other than Newmark explicit.

    Works on 1-D arrays for SDOF and MDOF alike (an SDOF's float state is converted with
    :meth:`Integrator._arr` / :meth:`Integrator._out`), factorises ``M`` once and takes the
    initial acceleration from the equation of motion, ``a_0 = M⁻¹ (p_0 − C v_0 − r_0)``.
    Subclasses implement :meth:`_setup_scheme` instead of :meth:`_setup`.
    """

    #: ``(p, r, v, p − r − C v)`` of the last :meth:`_weighted_rhs` (MDOF only).
    _kept_bracket: tuple[Any, Any, Any, NDArray[np.float64]] | None = None

    def _setup(self) -> None:
        self._mass_factor = Factorization(self._mass, 'mass')
        self._k_initial = (
            np.zeros_like(self._mass) if self._initial_stiffness is None
            else self._initial_stiffness
        )
        # Products every step: sparse when the model is large and sparse (see ``operator``).
        self._mass_product = operator(self._mass)
        self._damping_product = operator(self._damping)
        self._k_initial_product = operator(self._k_initial)
        self._setup_scheme()

    @abc.abstractmethod
    def _setup_scheme(self) -> None:
        """Precompute the scheme's constants and factorisations."""

    def _initial_acceleration(self, x0: Any, v0: Any, p0: Any, r0: Any) -> Any:
        rhs = self._motion_rhs(self._arr(p0), self._arr(v0), self._arr(r0))
        return self._out(self._mass_factor.solve(rhs))

    def _committed(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The committed ``(x, v, a)`` as arrays."""
        return self._arr(self._x), self._arr(self._v), self._arr(self._a)

    def _motion_rhs(
        self, p: NDArray[np.float64], v: NDArray[np.float64], r: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """``p − C v − r``, the right-hand side of ``M a = p − C v − r`` (arrays)."""
        return p - self._damping_product @ v - r

    def _weighted_rhs(
        self, alpha_f: float, load: Any, r_new: NDArray[np.float64], v_new: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """The weighted right-hand side of HHT-α and generalized-α.

        ``(1 − α_f)(p_{n+1} − r_{n+1} − C v_{n+1}) + α_f (p_n − r_n − C v_n)`` (HHT-α,
        generalized-α), with the committed state at ``t_n``.

        An MDOF keeps ``p_{n+1} − r_{n+1} − C v_{n+1}`` with the arrays it was made of: when
        those very arrays are committed (a scheme that commits the measured force and the
        predicted velocity, as KR-α), the next step's ``p_n − r_n − C v_n`` is that one (the
        same floats, one product and two passes fewer).
        """
        c = self._damping_product
        p_new = self._arr(load)
        bracket = p_new - r_new - c @ v_new
        kept = self._kept_bracket
        if kept is not None and kept[0] is self._p and kept[1] is self._r and (
                kept[2] is self._v):
            old = kept[3]
        else:
            old = self._arr(self._p) - self._arr(self._r) - c @ self._arr(self._v)
        if not self._scalar:
            self._kept_bracket = (p_new, r_new, v_new, bracket)
        return (1.0 - alpha_f) * bracket + alpha_f * old


class GeneralizedAlphaFamily(ArrayIntegrator):
    """Common base of the schemes with Chung & Hulbert's (1993) parameters.

    Parameters of ``rho_inf`` (:class:`.GeneralizedAlphaOS`, :class:`.KRAlpha`): unconditionally
    stable for specimens not stiffer than ``K_I`` (required).
    """

    stability_limit: float = math.inf
    needs_initial_stiffness: ClassVar[bool] = True
    numerical_damping_parameter: ClassVar[str | None] = 'rho_inf'
    PARAMETERS: ClassVar[tuple[SchemeParameter, ...]] = (
        SchemeParameter('rho_inf', 0.5,
                        'spectral radius at infinite frequency (1: no dissipation)',
                        low=0.0, high=1.0),
    )

    def _apply_parameters(self, parameters: Mapping[str, Any]) -> None:
        """Set ``α_m``, ``α_f``, ``β``, ``γ`` from ``rho_inf``."""
        self._rho_inf = float(parameters['rho_inf'])
        self._alpha_m, self._alpha_f, self._beta, self._gamma = self.coefficients(self._rho_inf)

    @staticmethod
    def coefficients(rho_inf: float) -> tuple[float, float, float, float]:
        """``(α_m, α_f, β, γ)`` of the generalized-α method for ``ρ∞``."""
        alpha_m = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
        alpha_f = rho_inf / (rho_inf + 1.0)
        gamma = 0.5 - alpha_m + alpha_f
        beta = 0.25 * (1.0 - alpha_m + alpha_f) ** 2
        return alpha_m, alpha_f, beta, gamma
