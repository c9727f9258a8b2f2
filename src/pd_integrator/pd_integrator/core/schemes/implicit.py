"""Implicit Newmark scheme with a fixed number of forward-only iterations per step.

Registry names: ``newmark_implicit`` (parameters ``beta``, ``gamma``, ``iterations``,
``increment_reduction``) and its aliases ``average_acceleration`` (``β = 1/4``) and
``linear_acceleration`` (``β = 1/6``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from .amplification import newmark_amplification, unit_sdof
from .array import ArrayIntegrator
from .linalg import Factorization
from .parameters import SchemeParameter

__all__ = ['AverageAcceleration', 'LinearAcceleration', 'NewmarkImplicit']

#: Most iterations per step accepted (each one is a command to the specimen).
MAX_ITERATIONS = 50

_ITERATIONS = SchemeParameter('iterations', 3, 1, MAX_ITERATIONS, integer=True,
                              description='trials (commands to the specimen) per step')
_INCREMENT_REDUCTION = SchemeParameter(
    'increment_reduction', 0.9, 0.0, 1.0, low_open=True,
    description='factor s on the imposed increments (1: plain modified Newton)')


class NewmarkImplicit(ArrayIntegrator):
    """Implicit Newmark scheme for pseudo-dynamic tests, fixed iterations per step.

    Sources: P. B. Shing, M. T. Vannan and E. Cater, "Implicit time integration for
    pseudodynamic tests", *Earthquake Engineering & Structural Dynamics* 20 (1991) 551–576,
    and P. B. Shing and M. T. Vannan, "Implicit time integration for pseudodynamic tests:
    convergence and energy dissipation", *EESD* 20 (1991) (iterations with the
    initial stiffness, scaled-down increments to avoid loading/unloading cycles, and an
    initial-stiffness correction of the last measured force); N. M. Newmark, "A method of
    computation for structural dynamics", *J. Eng. Mech. Div.* (ASCE) 85 (1959) 67–94, and
    the thesis's eqs. 3.2–3.3 for the scheme itself::

        x_{n+1} = x̃ + β Δt² a_{n+1},   x̃ = x_n + Δt v_n + (1/2 − β) Δt² a_n        (1)
        v_{n+1} = ṽ + γ Δt a_{n+1},    ṽ = v_n + (1 − γ) Δt a_n                   (2)
        M a_{n+1} + C v_{n+1} + r(x_{n+1}) = p_{n+1}                             (3)

    ``β = 1/4`` (average acceleration) is unconditionally stable, ``β = 1/6`` (linear
    acceleration) stable for ``Ω ≤ √12``; in general (``γ ≥ 1/2``) ``Ω ≤ 1/√(γ/2 − β)``
    unless ``2β ≥ γ``. Second-order accurate for ``γ = 1/2``. These limits hold when the
    iterations converge (exactly so for a linear specimen with stiffness ``K_I``).

    Iterations (what is implemented). With (1)–(2), (3) is ``R(x) = 0`` with the residual
    ``R(x, r) = p_{n+1} − M (x − x̃)/(βΔt²) − C [ṽ + γ (x − x̃)/(βΔt)] − r``; the
    iteration matrix uses the initial stiffness,
    ``K̂ = M/(βΔt²) + γ C/(βΔt) + K_I`` (factorised once). Each step has ``iterations = N``
    trials, each a command to the specimen with the measured force as answer:

    * the iterations start from where the actuator is, the last commanded target ``x^(−1)``
      of the previous step with its measured force ``r^(−1)`` (at step 1: the initial
      displacement and ``r_0``);
    * trial ``k`` commands ``x^(k) = x^(k−1) + s Δx^(k−1)`` with the modified-Newton
      increment ``Δx^(k−1) = K̂⁻¹ R(x^(k−1), r^(k−1))`` scaled down by the displacement-
      increment reduction factor ``s = increment_reduction ∈ (0, 1]`` (Shing & Vannan 1991).
      The load ``p_{n+1}`` only arrives with the first measurement of the step, so the first
      increment (``k = 0``, the step's predictor) uses the linearly extrapolated load
      ``2 p_n − p_{n−1}`` (``p_0`` at step 1); the corrections ``k ≥ 1`` use ``p_{n+1}``;
    * after the ``N``-th measurement the step is completed without moving the actuator:
      ``x_{n+1} = x^(N−1) + Δx^(N−1)`` (full increment, not imposed) with the force
      extrapolated by the initial stiffness, ``r_{n+1} = r^(N−1) + K_I Δx^(N−1)``, and
      ``a_{n+1}``, ``v_{n+1}`` from (1)–(2). Then (3) holds exactly with that ``r_{n+1}``
      (the committed :attr:`r`).

    Forward only (no actuator back-and-forth within a step, which would unload and reload an
    inelastic specimen). For a specimen whose tangent stiffness ``K_t`` does not exceed
    ``K_I``, each scaled increment multiplies the error of the iterate by
    ``I − s K̂⁻¹ K̂_t``, whose eigenvalues lie in ``[1 − s, 1)``: starting from the
    actuator's position the targets approach the converged displacement from that side
    without passing it (for an SDOF strictly monotonically). ``s < 1`` also makes the
    predictor (whose load is extrapolated) stop short of the converged point rather than
    overshoot it, and keeps the corrections one-sided for a tangent stiffness up to
    ``K̂_t < K̂/s`` (mild stiffening). The default ``s = 0.9`` is this implementation's
    choice (it keeps ~all predictor moves short of the solution at ``Ω ≤ 0.3``; the papers'
    own values could not be checked); ``s = 1`` gives plain modified-Newton iterations. As a
    safeguard for stiffening specimens, MDOF coupling and response reversals, each DOF's
    direction is
    fixed by its first move of the step (``x^(−1) → x^(0)``, or the first non-zero one): a
    later increment component pointing back is set to zero (that actuator holds its
    position) and the residual it leaves is taken by the final, non-imposed correction,
    i.e. that step is completed like an operator-splitting step. So every commanded path
    ``x^(−1), x^(0), …, x^(N−1)`` is monotonic per DOF.

    With a linear specimen of stiffness ``K_I`` the result is the exact Newmark solution for
    any ``N ≥ 1`` (the final correction is exact); for ``K ≠ K_I`` the committed step
    approaches the exact implicit solution as ``N`` grows (error factor ``I − s K̂⁻¹ K̂_t``
    per iteration). The amplification matrix is that of the Newmark scheme (converged iterations,
    specimen stiffness ``K_I``), on ``(x, Δt·v, Δt²·a)``.
    """

    name: ClassVar[str] = 'newmark_implicit'
    stability_limit: float = math.inf
    needs_initial_stiffness: ClassVar[bool] = True
    numerical_damping_parameter: ClassVar[str | None] = None
    iterations_per_step: int = 3

    #: ``β`` of the aliases (``None``: free parameter).
    FIXED_BETA: ClassVar[float | None] = None
    PARAMETERS: ClassVar[tuple[SchemeParameter, ...]] = (
        SchemeParameter('beta', 0.25, 0.0, 0.5, low_open=True,
                        description='Newmark beta (1/4 average, 1/6 linear acceleration)'),
        SchemeParameter('gamma', 0.5, 0.5, 1.0,
                        description='Newmark gamma (1/2: no numerical damping, second order)'),
        _ITERATIONS,
        _INCREMENT_REDUCTION,
    )

    def _apply_parameters(self, parameters: Mapping[str, Any]) -> None:
        self._beta, self._gamma = self._newmark_coefficients(parameters)
        self.iterations_per_step = int(parameters['iterations'])
        self._reduction = float(parameters['increment_reduction'])

    @classmethod
    def _newmark_coefficients(cls, parameters: Mapping[str, Any]) -> tuple[float, float]:
        """``(β, γ)``: the given ones (the aliases fix them)."""
        return float(parameters['beta']), float(parameters['gamma'])

    @classmethod
    def _stability_limit(cls, parameters: Mapping[str, Any], xi: float) -> float:
        """``inf`` if ``2β ≥ γ``, else ``1/√(γ/2 − β)`` (``√12`` for ``β = 1/6``)."""
        beta, gamma = cls._newmark_coefficients(parameters)
        if 2.0 * beta >= gamma:
            return math.inf
        return 1.0 / math.sqrt(gamma / 2.0 - beta)

    @classmethod
    def _amplification(cls, omega_dt: float, xi: float, parameters: Mapping[str, Any]
                       ) -> np.ndarray:
        """Newmark's scheme (1)–(3) with ``K = K_I`` on ``(x, Δt·v, Δt²·a)``."""
        beta, gamma = cls._newmark_coefficients(parameters)
        k, c = unit_sdof(omega_dt, xi)
        return newmark_amplification(beta, gamma, [k, c, 1.0], [0.0, 0.0, 0.0])

    # ----------------------------------------------------------------- stepping

    def _setup_scheme(self) -> None:
        dt = self._dt
        beta, gamma = self._beta, self._gamma
        self._c_acc = 1.0 / (beta * dt * dt)  # a = c_acc (x - x̃)
        self._c_vel = gamma / (beta * dt)  # v = ṽ + c_vel (x - x̃)
        self._iteration_matrix = Factorization(
            self._c_acc * self._mass + self._c_vel * self._damping + self._k_initial,
            'M/(beta dt^2) + gamma C/(beta dt) + K_I',
        )
        n = self._n
        # Where the actuator is (last commanded target) and the force measured there.
        self._x_cmd = np.zeros(n)
        self._r_cmd = np.zeros(n)
        self._x_cmd_trial = np.zeros(n)
        self._r_cmd_trial = np.zeros(n)
        self._x_pred = np.zeros(n)
        self._v_pred = np.zeros(n)
        self._target = np.zeros(n)
        self._next_target = np.zeros(n)
        self._direction = np.zeros(n)
        self._p_previous = np.zeros(n)  # p_{n-1}, for the predictor's load extrapolation
        self._p_previous_trial = np.zeros(n)

    def _on_initialize(self) -> None:
        self._x_cmd = self._arr(self._x).copy()
        self._r_cmd = self._arr(self._r).copy()
        self._p_previous = self._arr(self._p).copy()

    def _on_commit(self) -> None:
        self._x_cmd = self._x_cmd_trial
        self._r_cmd = self._r_cmd_trial
        self._p_previous = self._p_previous_trial

    def _increment(self, x: np.ndarray, r: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Modified-Newton increment ``K̂⁻¹ R(x, r)`` for the step's load ``p``."""
        offset = x - self._x_pred
        residual = (
            p
            - self._c_acc * (self._mass_product @ offset)
            - self._damping_product @ (self._v_pred + self._c_vel * offset)
            - r
        )
        return self._iteration_matrix.solve(residual)

    def _forward(self, increment: np.ndarray) -> np.ndarray:
        """Drop increment components that would reverse a DOF's motion within the step."""
        backwards = self._direction * increment < 0.0
        result = np.where(backwards, 0.0, increment)
        unset = self._direction == 0.0
        self._direction = np.where(unset, np.sign(result), self._direction)
        return result

    def _predict(self) -> Any:
        if self._iteration == 0:
            dt = self._dt
            x, v, a = self._committed()
            self._x_pred = x + dt * v + (0.5 - self._beta) * dt * dt * a
            self._v_pred = v + (1.0 - self._gamma) * dt * a
            self._direction = np.zeros(self._n)
            p = self._arr(self._p)
            p_guess = 2.0 * p - self._p_previous
            start = self._x_cmd
            increment = self._reduction * self._increment(start, self._r_cmd, p_guess)
            self._next_target = start + self._forward(increment)
        self._target = self._next_target
        return self._out(self._target.copy())

    def _iterate(self, restoring_force: Any, load: Any) -> None:
        increment = self._increment(self._target, self._arr(restoring_force), self._arr(load))
        self._next_target = self._target + self._forward(self._reduction * increment)

    def _correct(self, restoring_force: Any, load: Any) -> tuple[Any, Any]:
        r_measured = self._arr(restoring_force)
        increment = self._increment(self._target, r_measured, self._arr(load))
        x_new = self._target + increment
        a_new = self._c_acc * (x_new - self._x_pred)
        v_new = self._v_pred + self._gamma * self._dt * a_new
        self._x_cmd_trial = self._target.copy()
        self._r_cmd_trial = r_measured.copy()
        self._p_previous_trial = self._arr(self._p).copy()
        self._xt = self._out(x_new)
        self._rt = self._out(r_measured + self._k_initial_product @ increment)
        return self._out(a_new), self._out(v_new)


class AverageAcceleration(NewmarkImplicit):
    """Alias of :class:`NewmarkImplicit` with ``β = 1/4``, ``γ = 1/2`` (unconditionally stable).

    See :class:`NewmarkImplicit` for the sources, the equations and the iterations.
    """

    name: ClassVar[str] = 'average_acceleration'
    stability_limit: float = math.inf
    FIXED_BETA: ClassVar[float | None] = 0.25
    #: ``β`` and ``γ = 1/2`` are fixed by the name.
    PARAMETERS: ClassVar[tuple[SchemeParameter, ...]] = (_ITERATIONS, _INCREMENT_REDUCTION)

    @classmethod
    def _newmark_coefficients(cls, parameters: Mapping[str, Any]) -> tuple[float, float]:
        """The alias's fixed ``β`` and ``γ = 1/2``."""
        return cls.FIXED_BETA or 0.25, 0.5


class LinearAcceleration(AverageAcceleration):
    """Alias of :class:`NewmarkImplicit` with ``β = 1/6``, ``γ = 1/2`` (stable for ``Ω ≤ √12``).

    See :class:`NewmarkImplicit` for the sources, the equations and the iterations.
    """

    name: ClassVar[str] = 'linear_acceleration'
    stability_limit: float = math.sqrt(12.0)
    FIXED_BETA: ClassVar[float | None] = 1.0 / 6.0
