"""Operator-splitting (OS) schemes: α-OS and generalized-α-OS.

An OS scheme imposes an explicit *predictor* displacement ``x̃_{n+1}`` on the specimen and
corrects the measured force ``r̃_{n+1}`` for the implicit part of the displacement with the
initial stiffness ``K_I`` (Nakashima et al. 1990; Combescure & Pegon 1997)::

    x̃_{n+1} = x_n + Δt v_n + Δt² (1/2 − β) a_n          (predictor, imposed)
    ṽ_{n+1} = v_n + Δt (1 − γ) a_n
    x_{n+1} = x̃_{n+1} + β Δt² a_{n+1}                    (corrector, not imposed)
    v_{n+1} = ṽ_{n+1} + γ Δt a_{n+1}
    r_{n+1} = r̃_{n+1} + K_I (x_{n+1} − x̃_{n+1})          (corrected restoring force)

and ``a_{n+1}`` solves the (weighted) equation of motion, a linear system with the constant
matrix ``(1 − α_m) M + (1 − α_f)(γ Δt C + β Δt² K_I)`` factorised once. The committed
displacement :attr:`~.base.Integrator.x` is the corrected ``x_{n+1}``
and the committed :attr:`~.base.Integrator.r` the corrected force,
which enters the next step's equation of motion.

For a linear specimen with stiffness ``K_I`` the correction is exact and the scheme is the
underlying implicit one (HHT-α, generalized-α): unconditionally stable, second-order
accurate. For a softening specimen (tangent stiffness ≤ ``K_I``) it stays unconditionally
stable; a specimen *stiffer* than ``K_I`` can make it unstable at large ``Ω`` (Combescure &
Pegon 1997).

In the amplification matrices (``m = 1``, ``Δt = 1``, ``k = Ω²``, ``c = 2ξΩ``, specimen
stiffness ``K_I``) the state is ``(x, Δt·v, Δt²·a)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from .amplification import newmark_amplification, unit_sdof
from .array import ArrayIntegrator, GeneralizedAlphaFamily
from .base import SOFTENING_SPLIT
from .linalg import Factorization
from .parameters import SchemeParameter

__all__ = ['AlphaOS', 'GeneralizedAlphaOS']


class _OperatorSplitting(ArrayIntegrator):
    """OS predictor/corrector for the generalized-α weighting (Chung & Hulbert 1993).

    The equation of motion it satisfies::

        M [(1 − α_m) a_{n+1} + α_m a_n] + (1 − α_f)(C v_{n+1} + r_{n+1} − p_{n+1})
            + α_f (C v_n + r_n − p_n) = 0

    HHT-α (α-OS) is ``α_m = 0``, ``α_f = −α``.
    """

    stability_limit: float = math.inf
    needs_initial_stiffness: ClassVar[bool] = True
    accuracy_order: ClassVar[int] = 2
    softening_note: ClassVar[str] = SOFTENING_SPLIT

    _alpha_m: float
    _alpha_f: float
    _beta: float
    _gamma: float

    def _setup_scheme(self) -> None:
        dt = self._dt
        matrix = (1.0 - self._alpha_m) * self._mass + (1.0 - self._alpha_f) * (
            self._gamma * dt * self._damping + self._beta * dt * dt * self._k_initial
        )
        self._effective = Factorization(matrix, 'the alpha-OS effective matrix')
        self._v_predictor: np.ndarray | None = None

    def _predict(self) -> Any:
        dt = self._dt
        x, v, a = self._committed()
        self._v_predictor = v + dt * (1.0 - self._gamma) * a
        return self._out(x + dt * v + dt * dt * (0.5 - self._beta) * a)

    def _correct(self, restoring_force: Any, load: Any) -> tuple[Any, Any]:
        dt = self._dt
        x_pred = self._arr(self._xt)
        v_pred = self._v_predictor
        assert v_pred is not None
        r_meas = self._arr(restoring_force)
        rhs = self._weighted_rhs(self._alpha_f, load, r_meas, v_pred)
        if self._alpha_m != 0.0:
            rhs = rhs - self._alpha_m * (self._mass_product @ self._arr(self._a))
        a_new = self._effective.solve(rhs)
        correction = self._beta * dt * dt * a_new
        self._xt = self._out(x_pred + correction)
        self._rt = self._out(r_meas + self._k_initial_product @ correction)
        return self._out(a_new), self._out(v_pred + self._gamma * dt * a_new)

    @staticmethod
    def _generalized_matrix(
        omega_dt: float, xi: float, alpha_m: float, alpha_f: float, beta: float, gamma: float
    ) -> np.ndarray:
        k, c = unit_sdof(omega_dt, xi)
        w = 1.0 - alpha_f
        return newmark_amplification(
            beta, gamma, [w * k, w * c, 1.0 - alpha_m], [-alpha_f * k, -alpha_f * c, -alpha_m]
        )


class AlphaOS(_OperatorSplitting):
    """α-operator-splitting scheme (Nakashima et al. 1990; Combescure & Pegon 1997).

    Sources: M. Nakashima, K. Ishii and K. Ando, "Integration techniques for substructure
    pseudo dynamic test", *Proc. 4th U.S. National Conference on Earthquake Engineering*,
    Palm Springs (1990); D. Combescure and P. Pegon, "α-Operator
    splitting time integration technique for pseudodynamic testing. Error propagation
    analysis", *Soil Dynamics and Earthquake Engineering* 16 (1997) 427–443. Also the public
    documentation and source of OpenSees's ``AlphaOS`` integrator (A. Schellenberg).

    The OS predictor/corrector of the module docstring with the HHT-α equation of motion
    (Hilber, Hughes & Taylor 1977)::

        M a_{n+1} + (1 + α)(C v_{n+1} + r_{n+1} − p_{n+1}) − α (C v_n + r_n − p_n) = 0
        α ∈ [−1/3, 0],   β = (1 − α)²/4,   γ = 1/2 − α

    solved as ``[M + (1+α)(γΔt C + βΔt² K_I)] a_{n+1} = (1+α)(p_{n+1} − r̃_{n+1} − C ṽ_{n+1})
    − α (p_n − r_n − C v_n)`` with the committed, corrected ``r_n``.

    Mapping to OpenSees's ``integrator AlphaOS $alpha``: OpenSees weights the new state by
    ``α_OS`` and the old one by ``1 − α_OS`` with ``β = (2 − α_OS)²/4``, ``γ = 3/2 − α_OS``
    and ``2/3 ≤ α_OS ≤ 1``; hence ``α_OS = 1 + α`` (:meth:`alpha_to_opensees`,
    :meth:`alpha_from_opensees`): ``α = 0`` ↔ ``α_OS = 1`` (no dissipation), ``α = −1/3`` ↔
    ``α_OS = 2/3``.

    Unconditionally stable for linear and softening specimens (``stability_limit = inf``),
    second-order accurate; as for HHT-α, the spectral radius at ``Ω → ∞`` is
    ``ρ∞ = (1 + α)/(1 − α)`` (0.5 at ``α = −1/3``).
    """

    name: ClassVar[str] = 'alpha_os'
    numerical_damping_parameter: ClassVar[str | None] = 'alpha'
    PARAMETERS: ClassVar[tuple[SchemeParameter, ...]] = (
        SchemeParameter('alpha', -0.05, (
            'HHT alpha in [-1/3, 0] (OpenSees AlphaOS: 1 + alpha); 0: no dissipation'),
            low=-1.0 / 3.0, high=0.0),
    )

    def _apply_parameters(self, parameters: Mapping[str, Any]) -> None:
        self._alpha = float(parameters['alpha'])
        self._alpha_m = 0.0
        self._alpha_f = -self._alpha
        self._beta, self._gamma = self.newmark_parameters(self._alpha)

    @staticmethod
    def newmark_parameters(alpha: float) -> tuple[float, float]:
        """``(β, γ) = ((1 − α)²/4, 1/2 − α)``."""
        return (1.0 - alpha) ** 2 / 4.0, 0.5 - alpha

    @staticmethod
    def alpha_to_opensees(alpha: float) -> float:
        """OpenSees ``AlphaOS`` parameter for the HHT ``α``: ``α_OS = 1 + α``."""
        return 1.0 + float(alpha)

    @staticmethod
    def alpha_from_opensees(alpha_opensees: float) -> float:
        """HHT ``α`` for OpenSees's ``AlphaOS`` parameter: ``α = α_OS − 1``."""
        return float(alpha_opensees) - 1.0

    @classmethod
    def _amplification(cls, omega_dt: float, xi: float, parameters: Mapping[str, Any]
                       ) -> np.ndarray:
        """HHT-α with ``K = K_I`` on ``(x, Δt·v, Δt²·a)``."""
        value = float(parameters['alpha'])
        beta, gamma = cls.newmark_parameters(value)
        return cls._generalized_matrix(omega_dt, xi, 0.0, -value, beta, gamma)


class GeneralizedAlphaOS(_OperatorSplitting, GeneralizedAlphaFamily):
    """Generalized-α operator-splitting scheme, parameter ``rho_inf``.

    Sources: J. Chung and G. M. Hulbert, "A time integration algorithm for structural
    dynamics with improved numerical dissipation: the generalized-α method", *Journal of
    Applied Mechanics* 60 (1993) 371–375, for the weighting and the parameters; the OS
    predictor/corrector of Combescure & Pegon (1997) as in :class:`AlphaOS`; the public
    source of OpenSees's ``AlphaOSGeneralized`` integrator (A. Schellenberg), whose
    ``alphaI = 1 − α_m`` and ``alphaF = 1 − α_f`` for ``rhoInf``.

    The OS predictor/corrector of the module docstring with::

        M [(1 − α_m) a_{n+1} + α_m a_n] + (1 − α_f)(C v_{n+1} + r_{n+1} − p_{n+1})
            + α_f (C v_n + r_n − p_n) = 0
        α_m = (2ρ∞ − 1)/(ρ∞ + 1),  α_f = ρ∞/(ρ∞ + 1),
        γ = 1/2 − α_m + α_f,       β = (1 − α_m + α_f)²/4

    ``ρ∞ ∈ [0, 1]`` is the spectral radius as ``Ω → ∞`` (for ``K = K_I``); ``ρ∞ = 1`` is the
    average-acceleration OS scheme without dissipation. Unconditionally stable for linear and
    softening specimens, second-order accurate.
    """

    name: ClassVar[str] = 'generalized_alpha_os'

    @classmethod
    def _amplification(cls, omega_dt: float, xi: float, parameters: Mapping[str, Any]
                       ) -> np.ndarray:
        """Generalized-α with ``K = K_I`` on ``(x, Δt·v, Δt²·a)``."""
        coefficients = cls.coefficients(float(parameters['rho_inf']))
        return cls._generalized_matrix(omega_dt, xi, *coefficients)
