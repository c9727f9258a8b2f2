"""Step-by-step time-integration schemes for the pseudo-dynamic loop.

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

Every scheme except the implicit one (:mod:`.scheme_implicit`) has one iteration per step
and reaches ``'corrected'`` after a single :meth:`Integrator.correct`.

The schemes are registered in :data:`SCHEMES` (bottom of this module): Newmark explicit here,
the other families in their own modules (:mod:`.scheme_explicit_alpha`,
:mod:`.scheme_operator_splitting`, :mod:`.scheme_model_based`, :mod:`.scheme_implicit`).

For a single degree of freedom the state is kept in plain Python floats, which makes the
stepping fast and keeps the arithmetic float-for-float identical to the thesis's MATLAB code
(Appendix A).
"""

from __future__ import annotations

import abc
import math
import warnings
from typing import Any, ClassVar

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from .errors import ConfigError, IntegratorError

__all__ = [
    'SCHEMES',
    'ArrayIntegrator',
    'Factorization',
    'Integrator',
    'NewmarkExplicit',
    'amplification_from',
    'check_parameter',
    'make_integrator',
]

_COMMITTED = 'committed'
_PREDICTED = 'predicted'
_ITERATING = 'iterating'
_CORRECTED = 'corrected'


def _square_matrix(value: Any, name: str) -> np.ndarray:
    """Coerce a scalar or a square array-like to a finite 2-D float array (ConfigError)."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f'{name}: expected a number or a square matrix ({exc})') from None
    if array.ndim == 0:
        array = array.reshape(1, 1)
    if array.ndim != 2 or array.shape[0] != array.shape[1] or array.shape[0] == 0:
        raise ConfigError(f'{name}: expected a square matrix, got shape {array.shape}')
    if not np.all(np.isfinite(array)):
        raise ConfigError(f'{name}: all values must be finite')
    return array


def _readonly(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


def check_parameter(
    value: Any, name: str, low: float, high: float, *, low_open: bool = False
) -> float:
    """Validate a scheme parameter: a finite real number in ``[low, high]`` (ConfigError).

    Args:
        value: The value given.
        name: Parameter name for the message.
        low: Lower bound (inclusive unless ``low_open``).
        high: Upper bound (inclusive).
        low_open: Exclude ``low`` itself.

    Returns:
        The value as a float.
    """
    if isinstance(value, bool):
        raise ConfigError(f'{name}: expected a number, got {value!r}')
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f'{name}: expected a number, got {value!r}') from None
    # Values within rounding of a closed bound (e.g. 2/3 - 1 for -1/3) are taken as the bound.
    slack = 1e-12 * max(1.0, abs(low), abs(high))
    if math.isfinite(number) and not low_open and low - slack <= number < low:
        number = low
    if math.isfinite(number) and high < number <= high + slack:
        number = high
    below = number <= low if low_open else number < low
    if not math.isfinite(number) or below or number > high:
        bracket = '(' if low_open else '['
        raise ConfigError(f'{name}: must be in {bracket}{low:g}, {high:g}], got {value!r}')
    return number


class Factorization:
    """A matrix factorised once for repeated solves (Cholesky if SPD, else LU).

    Used by the schemes for their constant effective matrices (``M``, ``M + Δt/2·C``,
    ``M + γΔt C + βΔt² K_I``, ...), computed once per test.
    """

    def __init__(self, matrix: np.ndarray, name: str) -> None:
        """Factorise ``matrix``.

        Args:
            matrix: Square matrix.
            name: Description used in the error message.

        Raises:
            ConfigError: If the matrix is singular.
        """
        matrix = np.array(matrix, dtype=float)
        if matrix.shape == (1, 1):  # an SDOF: a division (fast and exact)
            value = float(matrix[0, 0])
            if value == 0.0 or not math.isfinite(value):
                raise ConfigError(f'{name} is singular')
            self._factor: tuple[str, Any] = ('scalar', value)
            return
        self._factor = _cholesky_or_lu(
            matrix, bool(np.allclose(matrix, matrix.T, rtol=1e-12, atol=0.0))
        )
        if self._factor[0] == 'lu':
            diagonal = np.abs(np.diag(self._factor[1][0]))
            if not np.all(diagonal > 1e-13 * max(float(np.max(diagonal)), 1e-300)):
                raise ConfigError(f'{name} is singular')

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve ``matrix · x = rhs`` (``rhs`` a vector or a matrix of columns)."""
        return _solve_factored(self._factor, rhs)


#: Matrices of at least this many DOFs that are mostly zeros (a shear building, a frame) are
#: factorised and multiplied as sparse matrices: a step then costs O(nnz) instead of O(n²).
SPARSE_MIN_DOF = 64
SPARSE_MAX_DENSITY = 0.1


def _is_sparse_structure(matrix: np.ndarray) -> bool:
    n = matrix.shape[0]
    return n >= SPARSE_MIN_DOF and np.count_nonzero(matrix) <= SPARSE_MAX_DENSITY * n * n


def operator(matrix: np.ndarray) -> Any:
    """``matrix`` for repeated products: CSR when it is large and sparse, else itself."""
    if matrix.ndim == 2 and _is_sparse_structure(matrix):
        return scipy.sparse.csr_matrix(matrix)
    return matrix


def _cholesky_or_lu(matrix: np.ndarray, symmetric: bool) -> tuple[str, Any]:
    """``('cholesky', …)`` if ``symmetric`` and positive definite, else ``('lu', …)``.

    Large sparse matrices get a sparse LU (``('sparse', splu)``), which raises ``ConfigError``
    when singular. The dense LU factors are not checked for singularity: the caller does that.
    """
    if _is_sparse_structure(matrix):
        try:
            return ('sparse', scipy.sparse.linalg.splu(scipy.sparse.csc_matrix(matrix)))
        except RuntimeError as err:  # "Factor is exactly singular"
            raise ConfigError(f'matrix of {matrix.shape[0]} DOFs is singular ({err})') from None
    if symmetric:
        try:
            return ('cholesky', scipy.linalg.cho_factor(matrix, check_finite=False))
        except np.linalg.LinAlgError:
            pass  # not positive definite: fall back to LU
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', scipy.linalg.LinAlgWarning)
        return ('lu', scipy.linalg.lu_factor(matrix, check_finite=False))


def _solve_factored(factor: tuple[str, Any], rhs: np.ndarray) -> np.ndarray:
    """Solve with a ``(kind, factor)`` of :class:`Factorization` or :func:`_cholesky_or_lu`."""
    kind, value = factor
    if kind == 'scalar':
        return np.asarray(rhs, dtype=float) / value
    if kind == 'cholesky':
        return scipy.linalg.cho_solve(value, rhs, check_finite=False)
    if kind == 'sparse':
        return value.solve(np.asarray(rhs, dtype=float))
    return scipy.linalg.lu_solve(value, rhs, check_finite=False)


def amplification_from(lhs: Any, rhs: Any) -> np.ndarray:
    """Amplification matrix ``A = L⁻¹ R`` of a one-step recursion ``L x̂_{n+1} = R x̂_n``.

    The schemes write their linear SDOF step (``m = 1``, ``Δt = 1``, ``k = Ω²``,
    ``c = 2ξΩ``) as linear relations between ``x̂_{n+1}`` and ``x̂_n``, both
    ``(x, Δt·v, Δt²·a)``; this solves them.
    """
    return np.linalg.solve(np.array(lhs, dtype=float), np.array(rhs, dtype=float))


def _unit_sdof(omega_dt: float, xi: float) -> tuple[float, float]:
    """``(k, c) = (Ω², 2ξΩ)`` of the amplification matrices' SDOF (``m = 1``, ``Δt = 1``)."""
    return float(omega_dt) ** 2, 2.0 * float(xi) * float(omega_dt)


def _newmark_amplification(
    beta: float, gamma: float, lhs_motion: list[float], rhs_motion: list[float]
) -> np.ndarray:
    """:func:`amplification_from` with Newmark's ``x``, ``v`` updates (``β``, ``γ``) as the
    first two rows and the scheme's equation of motion as the third."""
    lhs = [[1.0, 0.0, -beta], [0.0, 1.0, -gamma], lhs_motion]
    rhs = [[1.0, 1.0, 0.5 - beta], [0.0, 1.0, 1.0 - gamma], rhs_motion]
    return amplification_from(lhs, rhs)


class Integrator(abc.ABC):
    """Abstract predictor/corrector time integrator for ``M a + C v + r = p`` (thesis eq. 3.1).

    Subclasses implement :meth:`_setup`, :meth:`_initial_acceleration`, :meth:`_predict`
    and :meth:`_correct` (an iterative scheme also :meth:`_iterate`); this base class does the
    validation and the step bookkeeping. A scheme with parameters takes them as keyword-only
    constructor arguments after the base ones, validates them *before* calling
    ``super().__init__`` (which calls :meth:`_setup`), and returns them from :attr:`parameters`.

    Attributes:
        name: Registry name of the scheme.
        stability_limit: Upper bound on ``Ω = ω_max·Δt`` for a stable linear response
            (``math.inf`` for unconditionally stable schemes). The class attribute holds the
            limit for the default parameters; an instance whose limit depends on its
            parameters overrides it in ``__init__`` (see :meth:`stability_limit_for`).
        needs_initial_stiffness: Whether the scheme requires the initial stiffness matrix.
        numerical_damping_parameter: Name of the parameter that controls the numerical
            dissipation (``'rho_inf'``, ``'alpha'``, ``'rho_b'``), or ``None``.
        iterations_per_step: Trials (commands to the specimen) per time step: 1 for all but
            the implicit scheme.
    """

    name: ClassVar[str] = ''
    stability_limit: float = math.inf
    needs_initial_stiffness: ClassVar[bool] = False
    numerical_damping_parameter: ClassVar[str | None] = None
    iterations_per_step: int = 1

    #: Accepted range of each real scheme parameter, ``name: (low, high)`` or
    #: ``name: (low, high, low_open)`` (see :func:`check_parameter`).
    _PARAMETER_RANGES: ClassVar[dict[str, tuple[Any, ...]]] = {}

    def __init__(
        self, mass: Any, damping: Any, dt: float, initial_stiffness: Any = None
    ) -> None:
        """Validate the model and precompute what every step needs.

        Args:
            mass: Mass matrix ``M`` (kg), ``n``×``n`` symmetric positive definite, or a scalar
                for an SDOF.
            damping: Damping matrix ``C`` (N·s/m), ``n``×``n`` or a scalar.
            dt: Time step ``Δt`` in s, positive and finite.
            initial_stiffness: Initial stiffness ``K`` (N/m), required only by schemes with
                ``needs_initial_stiffness``; validated if given.

        Raises:
            ConfigError: On a non-positive or non-finite ``dt``, malformed or mismatched
                matrices, a mass matrix that is not positive definite, or a missing
                initial stiffness for a scheme that needs it.
        """
        try:
            dt_value = float(dt)
        except (TypeError, ValueError):
            raise ConfigError(f'dt: expected a number, got {dt!r}') from None
        if not (math.isfinite(dt_value) and dt_value > 0.0):
            raise ConfigError(f'dt: must be positive and finite, got {dt!r}')
        m = _square_matrix(mass, 'mass')
        n = m.shape[0]
        c = _square_matrix(damping, 'damping')
        if c.shape != (n, n):
            raise ConfigError(f'damping: expected shape ({n}, {n}), got {c.shape}')
        if not np.allclose(m, m.T, rtol=0.0, atol=1e-10 * float(np.max(np.abs(m)))):
            raise ConfigError('mass: matrix must be symmetric')
        try:
            np.linalg.cholesky(m)
        except np.linalg.LinAlgError:
            raise ConfigError('mass: matrix must be positive definite') from None
        k: np.ndarray | None = None
        if initial_stiffness is not None:
            k = _square_matrix(initial_stiffness, 'initial_stiffness')
            if k.shape != (n, n):
                raise ConfigError(f'initial_stiffness: expected shape ({n}, {n}), got {k.shape}')
        elif self.needs_initial_stiffness:
            raise ConfigError(f'initial_stiffness: required by scheme {self.name!r}')
        self._n = n
        self._scalar = n == 1
        self._dt = dt_value
        self._mass = _readonly(m)
        self._damping = _readonly(c)
        self._initial_stiffness = None if k is None else _readonly(k)
        self._status = 'idle'
        self._phase = _COMMITTED
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
        raise NotImplementedError(f'{type(self).__name__} does not iterate')

    def _on_initialize(self) -> None:
        """Hook: reset scheme-specific state after :meth:`initialize` (default: nothing)."""

    def _on_commit(self) -> None:
        """Hook: promote scheme-specific trial state in :meth:`commit` (default: nothing)."""

    def _on_revert(self) -> None:
        """Hook: discard scheme-specific trial state (default: nothing)."""

    # ----------------------------------------------------------------- scheme description

    @classmethod
    def stability_limit_for(cls, **parameters: Any) -> float:
        """Stability limit on ``Ω`` for the given scheme parameters (defaults if omitted).

        Raises:
            ConfigError: On an invalid parameter value.
        """
        if parameters:
            names = ', '.join(sorted(parameters))
            raise ConfigError(f'scheme {cls.name!r}: unknown parameter(s) {names}; it has none')
        return float(cls.stability_limit)

    @classmethod
    def _check(cls, name: str, value: Any) -> float:
        """:func:`check_parameter` with the range of ``name`` in :attr:`_PARAMETER_RANGES`."""
        low, high, *rest = cls._PARAMETER_RANGES[name]
        return check_parameter(value, name, low, high, low_open=bool(rest) and rest[0])

    @classmethod
    def amplification_matrix(cls, omega_dt: float, xi: float = 0.0) -> np.ndarray:
        """Amplification matrix for the linear SDOF free vibration (specimen stiffness K_I).

        Acts on ``(x, Δt·v, Δt²·a)`` (unless the scheme's docstring says otherwise) with
        ``m = 1``, ``ω = Ω/Δt``, ``c = 2ξω``; the eigenvalues give the spectral radius, the
        numerical damping and the period error. Subclasses take their parameters as
        keyword arguments.
        """
        raise NotImplementedError(f'{cls.__name__} has no amplification matrix')

    @property
    def parameters(self) -> dict[str, Any]:
        """The scheme's parameter values by constructor keyword (for summaries)."""
        return {}

    # ----------------------------------------------------------------- array helpers

    def _arr(self, value: Any) -> np.ndarray:
        """A state value as a 1-D array (a new 1-element array for an SDOF float)."""
        if self._scalar:
            return np.array((value,), dtype=float)
        return value

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
                    raise IntegratorError(f'{name}: expected a number, got {value!r}') from None
                if array.size != 1:
                    raise IntegratorError(
                        f'{name}: expected 1 value for 1 DOF, got shape {array.shape}'
                    )
                result = float(array.reshape(-1)[0])
            if not math.isfinite(result):
                raise IntegratorError(f'{name}: must be finite, got {result!r}')
            return result
        try:
            array = np.array(value, dtype=float)
        except (TypeError, ValueError):
            raise IntegratorError(f'{name}: expected {self._n} numbers, got {value!r}') from None
        if array.shape != (self._n,):
            raise IntegratorError(
                f'{name}: expected shape ({self._n},) for {self._n} DOF, got {array.shape}'
            )
        if not np.all(np.isfinite(array)):
            raise IntegratorError(f'{name}: all values must be finite, got {array.tolist()}')
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
        return bool(np.all(np.isfinite(value)))

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
            raise IntegratorError('initialize: the initial acceleration is not finite')
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
        self._phase = _COMMITTED
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
            raise IntegratorError(
                f'predict: integrator is {self._status!r}; call initialize() first'
            )
        if self._phase not in (_COMMITTED, _ITERATING):
            raise IntegratorError(
                f'predict: step {self._step + 1} is already {self._phase}; '
                'commit() or revert_to_last_step() first'
            )
        xt = self._predict()
        if not self._finite(xt):
            self._status = 'failed'
            raise IntegratorError(
                f'predict: step {self._step + 1}: the target displacement is not finite '
                '(the response diverged)'
            )
        self._xt = xt
        self._phase = _PREDICTED
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
        if self._status != 'running' or self._phase != _PREDICTED:
            state = self._status if self._status != 'running' else self._phase
            raise IntegratorError(
                f'correct: step {self._step + 1} has not been predicted (state {state!r}); '
                'call predict() first'
            )
        r = self._vector(restoring_force, 'restoring_force')
        p = self._vector(load, 'load')
        if self._iteration + 1 < self.iterations_per_step:
            self._iterate(r, p)
            self._iteration += 1
            self._phase = _ITERATING
            return
        self._rt = r
        self._pt = p
        at, vt = self._correct(r, p)
        if not (self._finite(at) and self._finite(vt) and self._finite(self._xt)
                and self._finite(self._rt)):
            self._status = 'failed'
            raise IntegratorError(
                f'correct: step {self._step + 1}: the trial acceleration or velocity is not '
                'finite (the response diverged)'
            )
        self._at = at
        self._vt = vt
        self._phase = _CORRECTED

    def commit(self) -> None:
        """Promote the corrected trial state: ``step += 1``, ``t = step·Δt``.

        Raises:
            IntegratorError: If the current step has not been predicted and corrected.
        """
        if self._phase != _CORRECTED or self._status != 'running':
            raise IntegratorError(
                f'commit: step {self._step + 1} is {self._phase} (status {self._status!r}); '
                'predict() and correct() it first'
            )
        self._x = self._xt
        self._v = self._vt
        self._a = self._at
        self._r = self._rt
        self._p = self._pt
        self._step += 1
        self._iteration = 0
        self._phase = _COMMITTED
        self._on_commit()

    def revert_to_last_step(self) -> None:
        """Discard the trial state and any iterations of the step (a no-op if there is none)."""
        self._xt, self._vt, self._at = self._x, self._v, self._a
        self._rt, self._pt = self._r, self._p
        self._iteration = 0
        self._phase = _COMMITTED
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
        """``'idle'`` before :meth:`initialize`, ``'running'``, or ``'failed'`` after a
        non-finite trial state (call :meth:`initialize` to restart)."""
        return self._status

    @property
    def phase(self) -> str:
        """Phase of the current step: ``'committed'``, ``'predicted'``, ``'iterating'`` or
        ``'corrected'``."""
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
        return (
            f'{type(self).__name__}(n_dof={self._n}, dt={self._dt!r}, step={self._step}, '
            f'status={self._status!r}, phase={self._phase!r})'
        )

class ArrayIntegrator(Integrator):
    """Common base of the scheme families outside this module.

    Works on 1-D arrays for SDOF and MDOF alike (an SDOF's float state is converted with
    :meth:`Integrator._arr` / :meth:`Integrator._out`), factorises ``M`` once and takes the
    initial acceleration from the equation of motion, ``a_0 = M⁻¹ (p_0 − C v_0 − r_0)``.
    Subclasses implement :meth:`_setup_scheme` instead of :meth:`_setup`.
    """

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

    def _motion_rhs(self, p: np.ndarray, v: np.ndarray, r: np.ndarray) -> np.ndarray:
        """``p − C v − r``, the right-hand side of ``M a = p − C v − r`` (arrays)."""
        return p - self._damping_product @ v - r

    def _weighted_rhs(
        self, alpha_f: float, load: Any, r_new: np.ndarray, v_new: np.ndarray
    ) -> np.ndarray:
        """``(1 − α_f)(p_{n+1} − r_{n+1} − C v_{n+1}) + α_f (p_n − r_n − C v_n)`` (HHT-α,
        generalized-α), with the committed state at ``t_n``."""
        c = self._damping_product
        return (1.0 - alpha_f) * (self._arr(load) - r_new - c @ v_new) + alpha_f * (
            self._arr(self._p) - self._arr(self._r) - c @ self._arr(self._v)
        )


class _GeneralizedAlphaFamily(ArrayIntegrator):
    """Common base of the schemes with Chung & Hulbert's (1993) parameters of ``rho_inf``
    (:class:`.GeneralizedAlphaOS`, :class:`.KRAlpha`): unconditionally stable for specimens
    not stiffer than ``K_I`` (required)."""

    stability_limit: float = math.inf
    needs_initial_stiffness: ClassVar[bool] = True
    numerical_damping_parameter: ClassVar[str | None] = 'rho_inf'
    _PARAMETER_RANGES = {'rho_inf': (0.0, 1.0)}

    def _set_rho_inf(self, rho_inf: Any) -> None:
        """Validate ``rho_inf`` and set ``α_m``, ``α_f``, ``β``, ``γ`` (for the constructors,
        which keep their own signatures: :mod:`.analysis` reads them)."""
        self._rho_inf = self._check('rho_inf', rho_inf)
        self._alpha_m, self._alpha_f, self._beta, self._gamma = self.coefficients(self._rho_inf)

    @staticmethod
    def coefficients(rho_inf: float) -> tuple[float, float, float, float]:
        """``(α_m, α_f, β, γ)`` of the generalized-α method for ``ρ∞``."""
        alpha_m = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
        alpha_f = rho_inf / (rho_inf + 1.0)
        gamma = 0.5 - alpha_m + alpha_f
        beta = 0.25 * (1.0 - alpha_m + alpha_f) ** 2
        return alpha_m, alpha_f, beta, gamma

    @property
    def parameters(self) -> dict[str, Any]:
        """``{'rho_inf': ρ∞}``."""
        return {'rho_inf': self._rho_inf}


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

    @classmethod
    def amplification_matrix(cls, omega_dt: float, xi: float = 0.0) -> np.ndarray:
        """Thesis eq. 3.7 on ``(x, Δt·v, Δt²·a)``; with damping, eqs. 3.20–3.22 with
        ``c = 2ξω`` (:func:`.stability.amplification_matrix_newmark_explicit` for ``ξ = 0``).
        """
        if xi == 0.0:
            from .stability import amplification_matrix_newmark_explicit  # noqa: PLC0415

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
                raise ConfigError(f'damping: m + dt/2*c = {self._lhs!r} must be positive')
            return
        c = self._damping
        self._half_dt_c_matrix = operator(dt * 0.5 * c)
        self._damping_operator = operator(c)
        lhs = self._mass + dt * 0.5 * c
        self._factor = _cholesky_or_lu(lhs, bool(np.array_equal(c, c.T)))
        if self._factor[0] == 'lu' and np.any(np.diag(self._factor[1][0]) == 0.0):
            raise ConfigError('damping: M + dt/2*C is singular')
        self._mass_factor = scipy.linalg.cho_factor(self._mass)

    def _solve(self, rhs: np.ndarray) -> np.ndarray:
        return _solve_factored(self._factor, rhs)

    def _initial_acceleration(self, x0: Any, v0: Any, p0: Any, r0: Any) -> Any:
        if self._scalar:
            return (p0 - self._c * v0 - r0) / self._m
        return scipy.linalg.cho_solve(self._mass_factor, p0 - self._damping @ v0 - r0)

    def _predict(self) -> Any:
        dt = self._dt
        return self._x + dt * self._v + self._a * dt * dt * 0.5

    def _correct(self, restoring_force: Any, load: Any) -> tuple[Any, Any]:
        v = self._v
        a = self._a
        if self._scalar:
            a_new = (load - restoring_force - self._c * v - self._half_dt_c * a) / self._lhs
        else:
            a_new = self._solve(
                load - restoring_force - self._damping_operator @ v
                - self._half_dt_c_matrix @ a
            )
        v_new = v + self._half_dt * (a + a_new)
        return a_new, v_new

    def predict(self) -> np.ndarray:  # noqa: D102 - documented on the base class
        # SDOF fast path: same checks and arithmetic as the generic path, fewer calls.
        if self._scalar and self._status == 'running' and self._phase == _COMMITTED:
            dt = self._dt
            xt = self._x + dt * self._v + self._a * dt * dt * 0.5
            if xt - xt == 0.0:  # finite
                self._xt = xt
                self._phase = _PREDICTED
                return np.array((xt,))
        return super().predict()

    def correct(self, restoring_force: Any, load: Any) -> None:  # noqa: D102
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
            and self._phase == _PREDICTED
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
                self._phase = _CORRECTED
                return
        super().correct(restoring_force, load)


def _builtin_schemes() -> dict[str, type[Integrator]]:
    """The schemes of the family modules, by registry name.

    Imported here, at the bottom of this module, because those modules subclass
    :class:`Integrator`: when any of them is imported first, Python runs this module to the
    end (the package ``__init__`` imports it) before the class statements they need.
    """
    from .scheme_explicit_alpha import ExplicitGeneralizedAlpha, ModifiedNewmark  # noqa: PLC0415
    from .scheme_implicit import (  # noqa: PLC0415
        AverageAcceleration,
        LinearAcceleration,
        NewmarkImplicit,
    )
    from .scheme_model_based import ChenRicles, KRAlpha  # noqa: PLC0415
    from .scheme_operator_splitting import AlphaOS, GeneralizedAlphaOS  # noqa: PLC0415

    classes: tuple[type[Integrator], ...] = (
        ExplicitGeneralizedAlpha,
        ModifiedNewmark,
        AlphaOS,
        GeneralizedAlphaOS,
        ChenRicles,
        KRAlpha,
        NewmarkImplicit,
        AverageAcceleration,
        LinearAcceleration,
    )
    return {cls.name: cls for cls in classes}


#: Registry of the available schemes by name.
SCHEMES: dict[str, type[Integrator]] = {NewmarkExplicit.name: NewmarkExplicit}
SCHEMES.update(_builtin_schemes())


def make_integrator(name: str, **kwargs: Any) -> Integrator:
    """Create an integrator by registry name.

    Args:
        name: Scheme name, a key of :data:`SCHEMES` (e.g. ``'newmark_explicit'``).
        **kwargs: Passed to the scheme's constructor (``mass``, ``damping``, ``dt``,
            ``initial_stiffness`` and the scheme's keyword-only parameters, e.g.
            ``rho_inf``).

    Returns:
        The new integrator.

    Raises:
        ConfigError: If the name is unknown (the message lists the valid names) or the
            constructor arguments are invalid.
    """
    try:
        cls = SCHEMES[name]
    except (KeyError, TypeError):
        valid = ', '.join(sorted(SCHEMES))
        raise ConfigError(f'scheme: unknown integration scheme {name!r}; valid: {valid}') from None
    return cls(**kwargs)
