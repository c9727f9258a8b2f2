"""The integrator interface: predictor/corrector steps with trial, commit and revert.

An :class:`Integrator` splits every time step into the two halves of a pseudo-dynamic test
(thesis §3.1, Figure 3.3):

1. :meth:`Integrator.predict` computes the *target displacement* ``x_{i+1}`` that is imposed
   on the specimen (an explicit scheme needs only the committed state for this);
2. :meth:`Integrator.correct` takes the *measured restoring force* ``r_{i+1}`` at that
   displacement and the external load ``p_{i+1}`` and computes the trial acceleration and
   velocity;
3. :meth:`Integrator.commit` promotes the trial to the committed state, or
   :meth:`Integrator.revert_to_last_step` discards it.

The trial/commit bookkeeping follows OpenSees's integrators. A step is therefore in one of
four phases: ``'committed'`` (ready to predict), ``'predicted'`` (waiting for the measured
force), ``'iterating'`` (an iterative scheme needs another trial within the same step: predict
again) and ``'corrected'`` (ready to commit).

Per step the caller runs::

    target = integrator.predict()          # command (step, integrator.iteration)
    integrator.correct(r_measured, p)      # the force measured at that target
    if integrator.phase == 'corrected':
        integrator.commit()                # the step is complete
    # else: phase 'iterating' -> predict() again for the next iteration of the same step

Every scheme except the implicit one (:mod:`.implicit`) has one iteration per step and reaches
``'corrected'`` after a single :meth:`Integrator.correct`.

For a single degree of freedom the state is kept in plain Python floats, which makes the
stepping fast and keeps the arithmetic float-for-float identical to the thesis's MATLAB code
(Appendix A).
"""

from __future__ import annotations

import abc
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError, IntegratorError
from ..matrices import readonly, square_matrix
from .linalg import large_diagonal
from .parameters import SchemeParameter, check_parameter, resolve_parameters

__all__ = [
    'COMMITTED',
    'CORRECTED',
    'ITERATING',
    'PREDICTED',
    'SOFTENING_EXPLICIT',
    'SOFTENING_IMPLICIT',
    'SOFTENING_SPLIT',
    'Integrator',
]

#: What a scheme assumes of the tangent stiffness ``K_t`` when the structure may soften
#: (:attr:`Integrator.softening_note`), for the three families.
SOFTENING_EXPLICIT = (
    'a tangent below K_I lowers omega, so the limit from K_I stays sufficient; a negative '
    'tangent is a physical divergence (x ~ exp(sqrt(-k_t/m) t)), which the scheme follows')
SOFTENING_SPLIT = (
    'its unconditional stability assumes K_t <= K_I (softening); a negative tangent is '
    'the physical divergence, which the scheme follows (its error grows with K_I - K_t)')
SOFTENING_IMPLICIT = (
    'its iterations use K_I and converge while M/(beta dt^2) + gamma C/(beta dt) + K_t stays '
    'positive definite; a negative tangent is the physical divergence, which it follows')

#: Phases of a step (:attr:`Integrator.phase`).
COMMITTED = 'committed'
PREDICTED = 'predicted'
ITERATING = 'iterating'
CORRECTED = 'corrected'


class Integrator(abc.ABC):
    """Abstract predictor/corrector time integrator for ``M a + C v + r = p`` (thesis eq. 3.1).

    Subclasses implement :meth:`_setup`, :meth:`_initial_acceleration`, :meth:`_predict`
    and :meth:`_correct` (an iterative scheme also :meth:`_iterate`); this base class does the
    validation and the step bookkeeping. A scheme with parameters declares each one once in
    :attr:`PARAMETERS` (a :class:`~.parameters.SchemeParameter` with its default and range);
    the constructor, :meth:`stability_limit_for`, :meth:`amplification_matrix`,
    :attr:`parameters` and the analysis tool all take them from there. The scheme reads the
    validated values in :meth:`_apply_parameters` (called before :meth:`_setup`) and, if its
    limit or its amplification matrix depend on them, implements :meth:`_stability_limit` and
    :meth:`_amplification`.

    Attributes:
        name: Registry name of the scheme.
        stability_limit: Upper bound on ``Ω = ω_max·Δt`` for a stable linear response
            (``math.inf`` for unconditionally stable schemes). The class attribute holds the
            limit for the default parameters; an instance holds the limit of its own
            parameters (see :meth:`stability_limit_for`).
        needs_initial_stiffness: Whether the scheme requires the initial stiffness matrix.
        numerical_damping_parameter: Name of the parameter that controls the numerical
            dissipation (``'rho_inf'``, ``'alpha'``, ``'rho_b'``), or ``None``.
        iterations_per_step: Trials (commands to the specimen) per time step: 1 for all but
            the implicit scheme.
        accuracy_order: Order of accuracy at the default parameters: the displacement error
            of a linear response started with no acceleration (``a_0 = 0``) falls as
            ``Δt**accuracy_order`` (see :mod:`.model_based` for starts with ``a_0 ≠ 0``).
        external: Whether the steps come from another program (see the class attribute).
        softening_note: What the scheme assumes of the tangent stiffness when the structure
            may soften (printed with the stability line when the test states a ``collapse``
            drift; ``''``: nothing to say).

    The per-scheme facts (:attr:`name`, :attr:`stability_limit`, :attr:`accuracy_order`,
    :attr:`PARAMETERS`, :attr:`softening_note` and the closed form
    :meth:`numerical_frequency`, if any) live on the class, which is the scheme's registry
    entry (:mod:`.registry`).
    """

    name: ClassVar[str] = ''
    stability_limit: float = math.inf
    needs_initial_stiffness: ClassVar[bool] = False
    numerical_damping_parameter: ClassVar[str | None] = None
    iterations_per_step: int = 1
    accuracy_order: ClassVar[int] = 2
    softening_note: ClassVar[str] = ''
    #: The steps come from another program (OpenSees through ``opensees_element``): the
    #: scheme cannot run by itself, and whatever runs every scheme numerically skips it.
    external: ClassVar[bool] = False

    #: The scheme's parameters, each declared once (default and range).
    PARAMETERS: ClassVar[tuple[SchemeParameter, ...]] = ()

    # The committed state (x, v, a, r, p) and the trial state (…t): plain floats for an SDOF
    # (fast, and float for float the thesis's MATLAB), ``(n,)`` float arrays for an MDOF.
    _x: Any
    _v: Any
    _a: Any
    _r: Any
    _p: Any
    _xt: Any
    _vt: Any
    _at: Any
    _rt: Any
    _pt: Any

    def __init__(
        self, mass: Any, damping: Any, dt: float, initial_stiffness: Any = None,
        **parameters: Any,
    ) -> None:
        """Validate the model and precompute what every step needs.

        Args:
            mass: Mass matrix ``M`` (kg), ``n``×``n`` symmetric positive definite, or a scalar
                for an SDOF.
            damping: Damping matrix ``C`` (N·s/m), ``n``×``n`` or a scalar.
            dt: Time step ``Δt`` in s, positive and finite.
            initial_stiffness: Initial stiffness ``K`` (N/m), required only by schemes with
                ``needs_initial_stiffness``; validated if given.
            **parameters: The scheme's parameters (:attr:`PARAMETERS`; defaults if omitted).

        Raises:
            SchemeParameterError: On an unknown parameter or a value out of its range.
            ConfigError: On a non-positive or non-finite ``dt``, malformed or mismatched
                matrices, a mass matrix that is not positive definite, or a missing
                initial stiffness for a scheme that needs it.
        """
        self._parameters = self.resolve_parameters(**parameters)
        self._apply_parameters(self._parameters)
        self.stability_limit = type(self)._stability_limit(self._parameters, 0.0)
        try:
            dt_value = float(dt)
        except (TypeError, ValueError):
            msg = f'dt: expected a number, got {dt!r}'
            raise ConfigError(msg) from None
        if not (math.isfinite(dt_value) and dt_value > 0.0):
            msg = f'dt: must be positive and finite, got {dt!r}'
            raise ConfigError(msg)
        m = square_matrix(mass, 'mass')
        n: int = m.shape[0]
        c = square_matrix(damping, 'damping')
        if c.shape != (n, n):
            msg = f'damping: expected shape ({n}, {n}), got {c.shape}'
            raise ConfigError(msg)
        lumped = large_diagonal(m)  # a large lumped mass: symmetric, checked in O(n)
        if lumped is not None:
            if not bool(np.all(lumped > 0.0)):
                msg = 'mass: matrix must be positive definite'
                raise ConfigError(msg)
        else:
            if not np.allclose(m, m.T, rtol=0.0, atol=1e-10 * float(np.max(np.abs(m)))):
                msg = 'mass: matrix must be symmetric'
                raise ConfigError(msg)
            try:
                np.linalg.cholesky(m)
            except np.linalg.LinAlgError:
                msg = 'mass: matrix must be positive definite'
                raise ConfigError(msg) from None
        k: np.ndarray | None = None
        if initial_stiffness is not None:
            k = square_matrix(initial_stiffness, 'initial_stiffness')
            if k.shape != (n, n):
                msg = f'initial_stiffness: expected shape ({n}, {n}), got {k.shape}'
                raise ConfigError(msg)
        elif self.needs_initial_stiffness:
            msg = f'initial_stiffness: required by scheme {self.name!r}'
            raise ConfigError(msg)
        self._n = n
        self._scalar = n == 1
        self._dt = dt_value
        self._mass = readonly(m)
        self._damping = readonly(c)
        self._initial_stiffness = None if k is None else readonly(k)
        self._status = 'idle'
        self._phase = COMMITTED
        self._step = 0
        self._iteration = 0
        if self._scalar:
            self._x = self._v = self._a = 0.0
            self._xt = self._vt = self._at = 0.0
            self._r = self._rt = self._p = self._pt = 0.0
        else:
            zeros = np.zeros(n)
            self._x = zeros.copy()
            self._v = zeros.copy()
            self._a = zeros.copy()
            self._xt = zeros.copy()
            self._vt = zeros.copy()
            self._at = zeros.copy()
            self._r = zeros.copy()
            self._rt = zeros.copy()
            self._p = zeros.copy()
            self._pt = zeros.copy()
        self._setup()

    # ----------------------------------------------------------------- scheme hooks

    @abc.abstractmethod
    def _setup(self) -> None:
        """Precompute constants and factorisations (called once from ``__init__``)."""

    @abc.abstractmethod
    def _initial_acceleration(self, x0: Any, v0: Any, p0: Any, r0: Any) -> Any:
        """Return the initial acceleration from the equation of motion at ``t = 0``."""

    @abc.abstractmethod
    def _predict(self) -> Any:
        """Return the trial displacement ``x_{i+1}`` from the committed state."""

    @abc.abstractmethod
    def _correct(self, restoring_force: Any, load: Any) -> tuple[Any, Any]:
        """Return the trial ``(a_{i+1}, v_{i+1})`` for the stored trial displacement.

        Called with the force measured at the last target. The base class has already set
        the trial restoring force ``self._rt`` and load ``self._pt`` to the inputs; an
        operator-splitting scheme replaces ``self._xt`` and ``self._rt`` by its corrected
        displacement and force.
        """

    def _iterate(self, restoring_force: Any, load: Any) -> None:
        """Take the force measured at a non-final iteration's target (iterative schemes).

        Called instead of :meth:`_correct` while ``iteration + 1 < iterations_per_step``;
        the next :meth:`_predict` returns the following target.
        """
        msg = f'{type(self).__name__} does not iterate'
        raise NotImplementedError(msg)

    def _apply_parameters(self, parameters: Mapping[str, Any]) -> None:
        """Hook: take the validated parameter values (before :meth:`_setup`; default: none)."""

    def _on_initialize(self) -> None:
        """Hook: reset scheme-specific state after :meth:`initialize` (default: nothing)."""

    def _on_commit(self) -> None:
        """Hook: promote scheme-specific trial state in :meth:`commit` (default: nothing)."""

    def _on_revert(self) -> None:
        """Hook: discard scheme-specific trial state (default: nothing)."""

    # ----------------------------------------------------------------- scheme description

    @classmethod
    def resolve_parameters(cls, **parameters: Any) -> dict[str, Any]:
        """Every parameter's value: the given ones validated, the others at their defaults.

        Raises:
            SchemeParameterError: On an unknown parameter or a value out of its range.
        """
        return resolve_parameters(cls.name or cls.__name__, cls.PARAMETERS, parameters)

    @classmethod
    def parameter_defaults(cls) -> dict[str, Any]:
        """The declared parameters and their defaults, in declaration order."""
        return {parameter.name: parameter.default for parameter in cls.PARAMETERS}

    @classmethod
    def stability_limit_for(cls, *, xi: float = 0.0, **parameters: Any) -> float:
        """Stability limit on ``Ω`` for the given parameters (defaults if omitted).

        Args:
            xi: Viscous damping ratio of the mode, in ``[0, 1]`` (only schemes whose damping
                force is explicit depend on it).
            **parameters: The scheme's parameters.

        Raises:
            SchemeParameterError: On an unknown parameter or an invalid value.
        """
        resolved = cls.resolve_parameters(**parameters)
        return float(cls._stability_limit(resolved, check_parameter(xi, 'xi', 0.0, 1.0)))

    @classmethod
    def _stability_limit(cls, parameters: Mapping[str, Any], xi: float) -> float:
        """Hook: the limit for validated parameters (default: the class's constant limit)."""
        return float(cls.stability_limit)

    @classmethod
    def numerical_frequency(cls, omega_dt: float) -> float | None:
        """Closed-form numerical frequency ``Ω̄(Ω)`` of the undamped mode, or ``None``.

        Closed-form numerical frequency ``Ω̄(Ω)`` of the undamped mode at the default
        parameters, or ``None`` if the scheme has none (the spectral analysis is used).

        Args:
            omega_dt: ``Ω = ωΔt``.

        Returns:
            ``Ω̄`` in rad per step (NaN above the stability limit), or ``None``.
        """
        return None

    @classmethod
    def amplification_matrix(cls, omega_dt: float, xi: float = 0.0, **parameters: Any
                             ) -> np.ndarray:
        """Amplification matrix for the linear SDOF free vibration (specimen stiffness K_I).

        Acts on ``(x, Δt·v, Δt²·a)`` (unless the scheme's docstring says otherwise) with
        ``m = 1``, ``ω = Ω/Δt``, ``c = 2ξω``; the eigenvalues give the spectral radius, the
        numerical damping and the period error.

        Raises:
            SchemeParameterError: On an unknown parameter or an invalid value.
            NotImplementedError: The scheme has no amplification matrix.
        """
        return cls._amplification(float(omega_dt), float(xi), cls.resolve_parameters(**parameters))

    @classmethod
    def _amplification(cls, omega_dt: float, xi: float, parameters: Mapping[str, Any]
                       ) -> np.ndarray:
        """Hook: the amplification matrix for validated parameters."""
        msg = f'{cls.__name__} has no amplification matrix'
        raise NotImplementedError(msg)

    @property
    def parameters(self) -> dict[str, Any]:
        """The scheme's parameter values by keyword, in declaration order (for summaries)."""
        return dict(self._parameters)

    # ----------------------------------------------------------------- array helpers

    def _arr(self, value: Any) -> NDArray[np.float64]:
        """A state value as a 1-D array (a new 1-element array for an SDOF float)."""
        if self._scalar:
            return np.array((value,), dtype=float)
        array: NDArray[np.float64] = value  # an MDOF's state is an (n,) float array
        return array

    def _out(self, array: np.ndarray) -> Any:
        """Back from :meth:`_arr`: a float for an SDOF, else the array."""
        if self._scalar:
            return float(array[0])
        return array

    # ----------------------------------------------------------------- input helpers

    def _vector(self, value: Any, name: str) -> Any:
        """Validate one state/force input: a float for an SDOF, else an ``(n,)`` array."""
        if self._scalar:
            if type(value) is float:
                result = value
            else:
                try:
                    array = np.asarray(value, dtype=float)
                except (TypeError, ValueError):
                    msg = f'{name}: expected a number, got {value!r}'
                    raise IntegratorError(msg) from None
                if array.size != 1:
                    msg = f'{name}: expected 1 value for 1 DOF, got shape {array.shape}'
                    raise IntegratorError(msg)
                result = float(array.reshape(-1)[0])
            if not math.isfinite(result):
                msg = f'{name}: must be finite, got {result!r}'
                raise IntegratorError(msg)
            return result
        try:
            array = np.array(value, dtype=float)
        except (TypeError, ValueError):
            msg = f'{name}: expected {self._n} numbers, got {value!r}'
            raise IntegratorError(msg) from None
        if array.shape != (self._n,):
            msg = f'{name}: expected shape ({self._n},) for {self._n} DOF, got {array.shape}'
            raise IntegratorError(msg)
        if not np.isfinite(array).all():
            msg = f'{name}: all values must be finite, got {array.tolist()}'
            raise IntegratorError(msg)
        return array

    def _export(self, value: Any) -> np.ndarray:
        if self._scalar:
            array = np.array((value,))
        else:
            array = value.copy()
        array.setflags(write=False)
        return array

    @staticmethod
    def _finite(value: Any) -> bool:
        if type(value) is float:
            return math.isfinite(value)
        return bool(np.isfinite(value).all())  # (np.all's dispatch costs more than the test)

    # ----------------------------------------------------------------- public API

    def initialize(self, x0: Any, v0: Any, p0: Any, r0: Any) -> None:
        """Set the initial state and compute the initial acceleration.

        ``a_0 = M⁻¹ (p_0 − C v_0 − r_0)`` (Appendix A, line 64, where ``r_0 = k_ini x_0``;
        in a test ``r_0`` is the force measured at the initial displacement). Resets the step
        counter and the time to zero and the status to ``'running'``. May be called again to
        restart.

        Args:
            x0: Initial displacement (m), ``(n,)`` or a scalar for an SDOF.
            v0: Initial velocity (m/s).
            p0: External load at ``t = 0`` (N).
            r0: Restoring force at ``x0`` (N).

        Raises:
            IntegratorError: On malformed or non-finite input (the integrator is unchanged).
        """
        x0v = self._vector(x0, 'x0')
        v0v = self._vector(v0, 'v0')
        p0v = self._vector(p0, 'p0')
        r0v = self._vector(r0, 'r0')
        a0 = self._initial_acceleration(x0v, v0v, p0v, r0v)
        if not self._finite(a0):
            msg = 'initialize: the initial acceleration is not finite'
            raise IntegratorError(msg)
        if self._scalar:
            self._x, self._v, self._a = x0v, v0v, a0
            self._r, self._p = r0v, p0v
        else:
            self._x, self._v, self._a = x0v.copy(), v0v.copy(), np.array(a0, dtype=float)
            self._r, self._p = r0v.copy(), p0v.copy()
        self._xt, self._vt, self._at = self._x, self._v, self._a
        self._rt, self._pt = self._r, self._p
        self._step = 0
        self._iteration = 0
        self._phase = COMMITTED
        self._status = 'running'
        self._on_initialize()

    def predict(self) -> np.ndarray:
        """Compute the trial (target) displacement ``x_{i+1}`` of the next step.

        For an iterative scheme in phase ``'iterating'`` this is the target of the next
        iteration (:attr:`iteration`) of the same step.

        Returns:
            A new ``(n,)`` array (owned by the caller) with the displacement to impose on the
            specimen.

        Raises:
            IntegratorError: Before :meth:`initialize`, after a failure, or if the previous
                trial has not been committed or reverted.
        """
        if self._status != 'running':
            msg = f'predict: integrator is {self._status!r}; call initialize() first'
            raise IntegratorError(msg)
        if self._phase not in (COMMITTED, ITERATING):
            msg = (
                f'predict: step {self._step + 1} is already {self._phase}; '
                'commit() or revert_to_last_step() first'
            )
            raise IntegratorError(msg)
        xt = self._predict()
        if not self._finite(xt):
            self._status = 'failed'
            msg = (
                f'predict: step {self._step + 1}: the target displacement is not finite '
                '(the response diverged)'
            )
            raise IntegratorError(msg)
        self._xt = xt
        self._phase = PREDICTED
        return np.array((xt,)) if self._scalar else xt.copy()

    def correct(self, restoring_force: Any, load: Any) -> None:
        """Compute the trial acceleration and velocity from the measured restoring force.

        For an iterative scheme that needs more trials in this step, the phase becomes
        ``'iterating'`` and :attr:`iteration` advances; otherwise it becomes ``'corrected'``.

        Args:
            restoring_force: Restoring force ``r_{i+1}`` (N) measured at the predicted
                displacement, ``(n,)`` or a scalar for an SDOF.
            load: External load ``p_{i+1}`` (N) at ``t_{i+1}``.

        Raises:
            IntegratorError: If :meth:`predict` was not called for this step, or on malformed
                or non-finite input; in both cases nothing changes and the step may be
                corrected again. If finite input gives a non-finite result, the status
                becomes ``'failed'``.
        """
        if self._status != 'running' or self._phase != PREDICTED:
            state = self._status if self._status != 'running' else self._phase
            msg = (
                f'correct: step {self._step + 1} has not been predicted (state {state!r}); '
                'call predict() first'
            )
            raise IntegratorError(msg)
        r = self._vector(restoring_force, 'restoring_force')
        p = self._vector(load, 'load')
        if self._iteration + 1 < self.iterations_per_step:
            self._iterate(r, p)
            self._iteration += 1
            self._phase = ITERATING
            return
        self._rt = r
        self._pt = p
        xt = self._xt  # finite (predict checked it), as ``r`` is: checked again if replaced
        at, vt = self._correct(r, p)
        if not (self._finite(at) and self._finite(vt)
                and (self._xt is xt or self._finite(self._xt))
                and (self._rt is r or self._finite(self._rt))):
            self._status = 'failed'
            msg = (
                f'correct: step {self._step + 1}: the trial acceleration or velocity is not '
                'finite (the response diverged)'
            )
            raise IntegratorError(msg)
        self._at = at
        self._vt = vt
        self._phase = CORRECTED

    def commit(self) -> None:
        """Promote the corrected trial state: ``step += 1``, ``t = step·Δt``.

        Raises:
            IntegratorError: If the current step has not been predicted and corrected.
        """
        if self._phase != CORRECTED or self._status != 'running':
            msg = (
                f'commit: step {self._step + 1} is {self._phase} (status {self._status!r}); '
                'predict() and correct() it first'
            )
            raise IntegratorError(msg)
        self._x = self._xt
        self._v = self._vt
        self._a = self._at
        self._r = self._rt
        self._p = self._pt
        self._step += 1
        self._iteration = 0
        self._phase = COMMITTED
        self._on_commit()

    def revert_to_last_step(self) -> None:
        """Discard the trial state and any iterations of the step (a no-op if there is none).

        The committed state is untouched (and finite), so an integrator that ``'failed'`` on a
        non-finite trial is ``'running'`` again from its last committed step.
        """
        if self._status == 'failed':
            self._status = 'running'
        self._xt, self._vt, self._at = self._x, self._v, self._a
        self._rt, self._pt = self._r, self._p
        self._iteration = 0
        self._phase = COMMITTED
        self._on_revert()

    # ----------------------------------------------------------------- properties

    @property
    def n_dof(self) -> int:
        """Number of degrees of freedom."""
        return self._n

    @property
    def x(self) -> np.ndarray:
        """Committed displacement ``x_i`` (m), a read-only copy."""
        return self._export(self._x)

    def committed_state(self) -> tuple[Any, Any, Any]:
        """The committed ``x_i``, ``v_i``, ``a_i`` as held.

        Floats for one DOF, else the integrator's own arrays (no copies: read them at once, never
        write them). The values of :attr:`x`, :attr:`v`, :attr:`a` without their per-call read-only
        copies (the session records them into its history every step).
        """
        return self._x, self._v, self._a

    @property
    def v(self) -> np.ndarray:
        """Committed velocity ``v_i`` (m/s), a read-only copy."""
        return self._export(self._v)

    @property
    def a(self) -> np.ndarray:
        """Committed acceleration ``a_i`` (m/s²), a read-only copy."""
        return self._export(self._a)

    @property
    def r(self) -> np.ndarray:
        """Committed restoring force ``r_i`` (N) used in the equation of motion, read-only.

        The measured force for the explicit and model-based schemes; the corrected force
        ``r̃ + K_I (x − x̃)`` for the operator-splitting and implicit schemes; ``r_0`` as
        given to :meth:`initialize` at step 0.
        """
        return self._export(self._r)

    @property
    def step(self) -> int:
        """Number of committed steps ``i``."""
        return self._step

    @property
    def iteration(self) -> int:
        """0-based index of the current trial within the step (0 for one-iteration schemes).

        After :meth:`predict` it is the index of the target just returned; it advances when
        :meth:`correct` leaves the step ``'iterating'`` and returns to 0 on commit/revert.
        """
        return self._iteration

    @property
    def t(self) -> float:
        """Committed time ``t_i = i·Δt`` in s (computed, so it does not drift)."""
        return self._step * self._dt

    @property
    def dt(self) -> float:
        """Time step ``Δt`` in s."""
        return self._dt

    @property
    def status(self) -> str:
        """The scheme's status: ``'idle'``, ``'running'`` or ``'failed'``.

        ``'idle'`` before :meth:`initialize`, ``'running'``, or ``'failed'`` after a non-finite
        trial state (call :meth:`initialize` to restart).
        """
        return self._status

    @property
    def phase(self) -> str:
        """Phase of the current step.

        ``'committed'``, ``'predicted'``, ``'iterating'`` or ``'corrected'``.
        """
        return self._phase

    @property
    def mass(self) -> np.ndarray:
        """Mass matrix ``M`` (read-only)."""
        return self._mass

    @property
    def damping(self) -> np.ndarray:
        """Damping matrix ``C`` (read-only)."""
        return self._damping

    @property
    def initial_stiffness(self) -> np.ndarray | None:
        """Initial stiffness matrix ``K`` if given (read-only)."""
        return self._initial_stiffness

    def __repr__(self) -> str:
        """The scheme's class, size, time step, step, status and phase."""
        return (
            f'{type(self).__name__}(n_dof={self._n}, dt={self._dt!r}, step={self._step}, '
            f'status={self._status!r}, phase={self._phase!r})'
        )
