"""Implicit Newmark scheme with a fixed number of (by default forward-only) iterations per step.

Registry names: ``newmark_implicit`` (parameters ``beta``, ``gamma``, ``iterations``,
``increment_reduction``, ``forward_only``) and its aliases ``average_acceleration``
(``β = 1/4``) and ``linear_acceleration`` (``β = 1/6``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from .amplification import newmark_amplification, unit_sdof
from .array import ArrayIntegrator
from .base import SOFTENING_IMPLICIT
from .linalg import Factorization
from .parameters import SchemeParameter

__all__ = ['AverageAcceleration', 'LinearAcceleration', 'NewmarkImplicit']

#: Most iterations per step accepted (each one is a command to the specimen).
MAX_ITERATIONS = 50
#: A reversed increment component within this many ulp of the position is rounding noise of
#: converged iterations (measured: at most 3 ulp), not counted in ``reversals``.
_NOISE_ULPS = 64

_ITERATIONS = SchemeParameter('iterations', 3, 'trials (commands to the specimen) per step',
                              low=1, high=MAX_ITERATIONS, integer=True)
_INCREMENT_REDUCTION = SchemeParameter(
    'increment_reduction', 0.9, 'factor s on the imposed increments (1: plain modified Newton)',
    low=0.0, high=1.0, low_open=True)
_FORWARD_ONLY = SchemeParameter(
    'forward_only', True,
    'true: a DOF holds rather than reverse within a step; false: it may reverse and the '
    'iterations converge (specimens evaluated from their committed state, or elastic)')


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

    Forward only (``forward_only = True``, the default: no actuator back-and-forth within a
    step, which would unload and reload an inelastic specimen). Each DOF's direction is fixed
    by its first move of the step (``x^(−1) → x^(0)``, or the first non-zero one): a later
    increment component pointing back is set to zero (that actuator holds its position) and
    the residual it leaves is taken by the final, non-imposed correction, i.e. that step is
    completed like an operator-splitting step. So every commanded path
    ``x^(−1), x^(0), …, x^(N−1)`` is monotonic per DOF.

    When the iterations are one-sided anyway. Let ``x*`` be the step's implicit solution and
    ``K_t`` the specimen's secant stiffness from the iterate to ``x*`` (its stiffness, for a
    linear specimen), ``K̂_t = M/(βΔt²) + γ C/(βΔt) + K_t``. A correction (``k ≥ 1``, exact
    load) multiplies the error ``x* − x^(k)`` by ``I − s K̂⁻¹ K̂_t``, whose eigenvalues lie in
    ``[1 − s, 1)`` for ``0 ≤ K_t ≤ K_I``: the corrections approach ``x*`` from one side
    without passing it (for an SDOF strictly monotonically), and stay one-sided up to
    ``K̂_t < K̂/s`` (mild stiffening). The predictor is different: its load is extrapolated,
    so (SDOF) its move is ``d = s (K̂_t e + δp)/K̂`` with ``e = x* − x^(−1)`` and the
    extrapolation error ``δp = (2 p_n − p_{n−1}) − p_{n+1}`` (minus the load's second
    difference). It stops short of ``x*`` (``0 ≤ d/e ≤ 1``) if and only if
    ``−K̂_t ≤ δp/e ≤ K̂/s − K̂_t``. So ``s < 1`` keeps the predictor short when the specimen is
    linear between ``x^(−1)`` and ``x*`` with ``K_t ≤ K_I`` and the extrapolation is exact
    (``δp = 0``: the load linear over the two steps; then ``d/e = s K̂_t/K̂ < 1``), and
    otherwise while ``|δp|`` stays within the margin ``(K̂/s − K̂_t)|e| ≥ (1/s − 1) K̂ |e|``.
    It cannot at a turning point: where the velocity reverses, the step's move ``e`` is
    small (``≈ Δt·v → 0``, or even against the previous motion) while ``δp ≈ −Δt² p̈`` does
    not shrink with it, so for any fixed ``s`` the bounds are exceeded once ``|δp|`` is large
    against ``K̂|e|``: the predictor passes ``x*`` (or moves away from it) and the
    corrections must come back; ``s`` only scales the overshoot. Inside a yielding step (the
    predictor moving the specimen along its plastic branch) the overshoot is plastic
    deformation: the specimen yields to ``x^(0)``, the converged point is behind the
    actuator, the backward corrections are held, and the final correction
    (``r^(N−1) + K_I Δx``, the elastic unloading from the overshoot) commits a state with
    the overshoot's plastic offset. The difference from the implicit solution stays for the
    rest of the test and more iterations do not remove it. Measured (EPP SDOF, ``T = 1`` s,
    ``u_y = 0.025`` m, El Centro NS, ``Δt = 0.02`` s, ``average_acceleration``): the history
    error against Newton's solution plateaus at 2.6e-4, 1.66e-4, 6.1e-5 and 1.6e-5 m for
    ``s = 1, 0.9, 0.7, 0.5`` (at ``t = 4.50`` s: ``v`` turns, ``δp = 1.0`` N at a kink of
    the record against a margin of 0.25 N, the actuator stays 6.7e-5 m beyond ``x*``); at
    ``Δt = 0.01`` s no yielding step overshoots and the iterations converge
    (``tests/pd_core/test_implicit_convergence.py``, ``bench/iterations_table.py``).
    The default ``s = 0.9`` is this implementation's choice (it keeps ~all predictor moves of
    linear steps short of the solution at ``Ω ≤ 0.3``; the papers' own values could not be
    checked); ``s = 1`` gives plain modified-Newton iterations.

    Reversible increments (``forward_only = False``, an explicit choice): every increment is
    imposed, backward ones included, so the iterations are plain (scaled) modified-Newton
    iterations and converge to the implicit solution, geometrically with the factor above
    (measured on the case above: ``≈ 1 − s`` per iteration, within 1e-9 m from ``N = 8`` at
    ``s = 0.9``). That holds only if the specimen's force at every trial is the one from the
    state the step started in: a numerical specimen evaluated from its committed state and
    committed at the step's end (the structure model's numerical springs, OpenSees-like
    trial/commit), or a physical specimen within its elastic range (where the path does not
    matter). A physical specimen beyond it is unloaded and reloaded by each reversal (and keeps
    the overshoot's plastic deformation: no convergence to the implicit solution, and a
    non-monotonic load path). So is the simulated site
    (:class:`pd_common.specimen.SpecimenServer`) by default, which commits every command as a
    physical specimen moves: with it the plateau above stays; with ``specimen.commit:
    per_step`` it takes a step's iterations as trials from the step's start and the iterations
    converge through the whole test. :attr:`reversals` counts the reversed
    increment components (held or commanded).

    With a linear specimen of stiffness ``K_I`` the result is the exact Newmark solution for
    any ``N ≥ 1`` (the final correction is exact); for ``K ≠ K_I`` the committed step
    approaches the exact implicit solution as ``N`` grows (error factor ``I − s K̂⁻¹ K̂_t``
    per iteration) while the safeguard does not act, or with ``forward_only = False`` and a
    specimen evaluated from its committed state. The amplification matrix is that of the
    Newmark scheme (converged iterations, specimen stiffness ``K_I``), on
    ``(x, Δt·v, Δt²·a)``.
    """

    name: ClassVar[str] = 'newmark_implicit'
    stability_limit: float = math.inf
    accuracy_order: ClassVar[int] = 2  # for gamma = 1/2 (the default); 1 otherwise
    softening_note: ClassVar[str] = SOFTENING_IMPLICIT
    needs_initial_stiffness: ClassVar[bool] = True
    numerical_damping_parameter: ClassVar[str | None] = None
    iterations_per_step: int = 3

    #: ``β`` of the aliases (``None``: free parameter).
    FIXED_BETA: ClassVar[float | None] = None
    PARAMETERS: ClassVar[tuple[SchemeParameter, ...]] = (
        SchemeParameter('beta', 0.25, 'Newmark beta (1/4 average, 1/6 linear acceleration)',
                        low=0.0, high=0.5, low_open=True),
        SchemeParameter('gamma', 0.5, 'Newmark gamma (1/2: no numerical damping, second order)',
                        low=0.5, high=1.0),
        _ITERATIONS,
        _INCREMENT_REDUCTION,
        _FORWARD_ONLY,
    )

    def _apply_parameters(self, parameters: Mapping[str, Any]) -> None:
        self._beta, self._gamma = self._newmark_coefficients(parameters)
        self.iterations_per_step = int(parameters['iterations'])
        self._reduction = float(parameters['increment_reduction'])
        self._forward_only = bool(parameters['forward_only'])

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
        self._reversals = 0  # reversed increment components of the committed steps
        self._reversals_trial = 0  # ... of the current step

    def _on_initialize(self) -> None:
        self._x_cmd = self._arr(self._x).copy()
        self._r_cmd = self._arr(self._r).copy()
        self._p_previous = self._arr(self._p).copy()
        self._reversals = 0
        self._reversals_trial = 0

    def _on_commit(self) -> None:
        self._x_cmd = self._x_cmd_trial
        self._r_cmd = self._r_cmd_trial
        self._p_previous = self._p_previous_trial
        self._reversals += self._reversals_trial
        self._reversals_trial = 0

    def _on_revert(self) -> None:
        self._reversals_trial = 0

    @property
    def forward_only(self) -> bool:
        """Whether increments that would reverse a DOF within a step are held (set to zero)."""
        return self._forward_only

    @property
    def reversals(self) -> int:
        """Increment components of the committed steps that pointed back within their step.

        A component counts when it points against the DOF's previous non-zero move of the same
        step (the step's first move, ``x^(−1) → x^(0)``, sets no count) and exceeds 64 ulp of
        the position (smaller ones are the rounding noise of converged iterations). With
        ``forward_only`` each was held (set to zero, the actuator stayed; a DOF held at several
        iterations counts at each); without, each was commanded, i.e. the actuator reversed (an
        unloading of an inelastic specimen that is not evaluated from its committed state).
        Reset by :meth:`initialize`; a reverted step does not count.
        """
        return self._reversals

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

    def _forward(self, position: np.ndarray, increment: np.ndarray) -> np.ndarray:
        """The imposed increment from ``position``.

        With ``forward_only``, components that would reverse a DOF's motion within the step are
        dropped; reversals are counted.
        """
        backwards = self._direction * increment < 0.0
        noise = np.abs(increment) <= _NOISE_ULPS * np.spacing(np.abs(position))
        self._reversals_trial += int(np.count_nonzero(backwards & ~noise))
        result = np.where(backwards, 0.0, increment) if self._forward_only else increment
        # The sign of each DOF's last non-zero move (with forward_only: its first move).
        self._direction = np.where(result != 0.0, np.sign(result), self._direction)
        return result

    def _predict(self) -> Any:
        if self._iteration == 0:
            dt = self._dt
            x, v, a = self._committed()
            self._x_pred = x + dt * v + (0.5 - self._beta) * dt * dt * a
            self._v_pred = v + (1.0 - self._gamma) * dt * a
            self._direction = np.zeros(self._n)
            self._reversals_trial = 0
            p = self._arr(self._p)
            p_guess = 2.0 * p - self._p_previous
            start = self._x_cmd
            increment = self._reduction * self._increment(start, self._r_cmd, p_guess)
            self._next_target = start + self._forward(start, increment)
        self._target = self._next_target
        return self._out(self._target.copy())

    def _iterate(self, restoring_force: Any, load: Any) -> None:
        increment = self._increment(self._target, self._arr(restoring_force), self._arr(load))
        self._next_target = self._target + self._forward(self._target,
                                                         self._reduction * increment)

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
    PARAMETERS: ClassVar[tuple[SchemeParameter, ...]] = (
        _ITERATIONS, _INCREMENT_REDUCTION, _FORWARD_ONLY)

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
