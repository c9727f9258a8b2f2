"""Experimental error models (thesis section 3.4.3) and tracking monitors.

Injection. Shing and Mahin ("Cumulative experimental errors in pseudodynamic tests", Earthquake
Eng. Struct. Dyn. 15, 1987) split the errors of a pseudo-dynamic test into *systematic* errors,
e.g. an actuator that consistently undershoots or overshoots the commanded displacement
increment, and *random* errors (sensor noise); they showed that the systematic ones accumulate
and are the harmful ones. The thesis (section 3.4.3) names the same sources: displacements that
cannot be applied exactly, and force feedback affected by the measurement and by friction. An
:class:`ErrorModel` describes, per step and for every DOF:

* a systematic displacement error as a fraction ``s`` of the increment: the actuator, at
  ``x_current``, reaches ``x_current + (1 + s) (x_target - x_current)`` (``s < 0`` undershoot,
  ``s > 0`` overshoot), so that ``x = x_target + s * increment``;
* a constant delay of ``delay_steps`` steps: the actuator executes the target of that many steps
  earlier (the initial position before the first ones);
* random noise on the measured displacement and force (Gaussian, standard deviations in m, N);
* a constant force-measurement bias (N).

:func:`apply_error_model` applies a model (without delay) to one step; :class:`ErrorInjector`
keeps the state needed for the delay and a seeded generator. The model and its application are
implemented once, in :mod:`pd_specimen_sim.core.errors_model` (the bridge depends on
``pd_specimen_sim``, not the other way round): the specimen simulator uses them directly
(wrapping a specimen's ``restoring_force``); :class:`ErrorModel` and :class:`ErrorInjector` here
are thin subclasses that add the bridge's exceptions (:class:`~.errors.BridgeConfigError`,
:class:`~.errors.DriverError`) and input checks, for the emulator's ramp-and-hold executor (which
drives the erroneous target and corrupts the averaged measurement).

Monitors. :func:`tracking_error` is the history of ``measured - command``.
:func:`tracking_indicator` is the tracking indicator proposed by Mercan and Ricles ("Stability and
accuracy analysis of outer loop dynamics in real-time pseudodynamic testing of SDOF systems",
Earthquake Eng. Struct. Dyn. 36, 2007): the area enclosed by the loop of the measured versus the
commanded displacement. Here it is accumulated with the trapezoidal rule in the symmetric form
``TI = (int x_m dx_c - int x_c dx_m) / 2``, i.e.
``TI_{i+1} = TI_i + (x_m,i x_c,i+1 - x_m,i+1 x_c,i) / 2``, which is zero for perfect tracking
even on an open path and equals ``oint x_m dx_c`` on a closed cycle.

Sign: positive = energy removed, negative = energy added. For a linear specimen of stiffness
``k`` the integrator pairs the force ``k x_m`` measured at the achieved displacement with its own
command ``x_c``, so over a cycle it sees the work ``k * TI`` done on the specimen. A measured
displacement *lagging* the command (the actuator delay analysed by Mercan and Ricles, equivalent
to negative damping) traverses the (command, measured) loop counter-clockwise and gives
``TI < 0``: energy added to the test. A *leading* one gives ``TI > 0``: energy removed (extra
damping). For ``x_c = a sin(w t)`` and ``x_m = a sin(w t - phi)`` one cycle gives
``TI = -pi a^2 sin(phi)``. Units: m2 (times a stiffness in N/m, J).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from numbers import Integral
from typing import Any, TypeVar

import numpy as np
from pd_specimen_sim.core import errors_model as _shared
from pd_specimen_sim.core.errors_model import (
    ErroneousStep,
    RestoringForce,
    systematic_displacement,
)

from .errors import BridgeConfigError, DriverError

_P = TypeVar('_P')


def parameters_from_mapping(
    cls: type[_P], mapping: Mapping[str, Any], source: str, what: str, item: str
) -> _P:
    """Build a parameter dataclass from a mapping (a parsed YAML section or ROS parameters).

    Shared by :meth:`ErrorModel.from_mapping` and ``EmulatorParameters.from_mapping``.

    Args:
        cls: The dataclass; it raises :class:`~.errors.BridgeConfigError` on a bad value.
        mapping: Any subset of the field names; missing ones keep their defaults.
        source: Name of the file or parameter namespace, used in error messages.
        what: Name of the whole mapping in error messages (``'error model'``).
        item: Name of one key in error messages (``'error model parameter'``).

    Returns:
        The validated instance.

    Raises:
        BridgeConfigError: On a non-mapping, an unknown key or a bad value.
    """
    if not isinstance(mapping, Mapping):
        raise BridgeConfigError(
            f'{source}: {what} must be a mapping, got {type(mapping).__name__}'
        )
    known = [f.name for f in fields(cls)]  # type: ignore[arg-type]
    for key in mapping:
        if key not in known:
            raise BridgeConfigError(
                f'{source}: unknown {item} {key!r} '
                f'(expected one of: {", ".join(sorted(known))})'
            )
    try:
        return cls(**dict(mapping))
    except BridgeConfigError as exc:
        raise BridgeConfigError(f'{source}: {exc}') from None


class ErrorModel(_shared.ErrorModel):
    """Experimental errors injected into each step (the same for every DOF).

    :class:`pd_specimen_sim.core.errors_model.ErrorModel` (the same attributes, validation and
    meaning), raising :class:`~.errors.BridgeConfigError`.

    Attributes:
        systematic: Displacement error as a fraction of the increment: ``-0.05`` is a 5 %
            undershoot, ``0.05`` a 5 % overshoot. Must be in ``(-1, 1]``.
        delay_steps: Constant delay of the executed target, steps.
        displacement_noise: Standard deviation of the displacement measurement noise, m.
        force_noise: Standard deviation of the force measurement noise, N.
        force_bias: Constant force-measurement offset, N.
        seed: Seed of the noise generator (``None``: non-deterministic).

    Raises:
        BridgeConfigError: One line naming the parameter, if a value is invalid.
    """

    @classmethod
    def _invalid(cls, name: str, problem: str) -> Exception:
        return BridgeConfigError(f'ErrorModel: {name} {problem}')

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any], source: str = 'errors') -> ErrorModel:
        """Build a model from a mapping (a parsed YAML section or ROS parameters).

        Args:
            mapping: Any subset of the attribute names; missing ones keep their defaults.
            source: Name of the file or parameter namespace, used in error messages.

        Returns:
            The validated model.

        Raises:
            BridgeConfigError: On a non-mapping, an unknown key or a bad value.
        """
        return parameters_from_mapping(cls, mapping, source, 'error model',
                                       'error model parameter')


def apply_error_model(
    model: ErrorModel,
    target: Sequence[float] | np.ndarray,
    current: Sequence[float] | np.ndarray,
    restoring_force: RestoringForce,
    rng: np.random.Generator | None = None,
) -> ErroneousStep:
    """Apply a model without delay to one step: impose, evaluate the force, measure.

    Args:
        model: The error model; its ``delay_steps`` must be 0 (use :class:`ErrorInjector`).
        target: Ideal target displacement per DOF, m.
        current: Displacement before the step per DOF, m.
        restoring_force: Force per DOF (N) at a displacement per DOF (m), e.g. a specimen's
            ``restoring_force`` (the caller commits or reverts the specimen afterwards).
        rng: Noise generator; default ``numpy.random.default_rng(model.seed)``.

    Returns:
        The step with its errors.

    Raises:
        BridgeConfigError: If the model has a delay.
        DriverError: On malformed or non-finite displacements or forces.
    """
    if model.delay_steps:
        raise BridgeConfigError(
            'apply_error_model: delay_steps must be 0 (a delay needs the step history: use '
            'ErrorInjector)'
        )
    x_t = _vector(target, 'target', None)
    x_c = _vector(current, 'current', x_t.size)
    imposed = systematic_displacement(x_t, x_c, model.systematic)
    force = _vector(restoring_force(imposed.copy()), 'restoring force', x_t.size)
    generator = np.random.default_rng(model.seed) if rng is None else rng
    displacement, measured = _shared.measure(model, imposed, force, generator)
    return ErroneousStep(x_t, imposed, force, displacement, measured)


class ErrorInjector(_shared.ErrorInjector):
    """Applies an :class:`ErrorModel` step after step (keeps the delay line and the generator).

    :class:`pd_specimen_sim.core.errors_model.ErrorInjector` with the bridge's input checks:
    the actuator's current position is the displacement imposed at the previous step (or the
    initial position), unless :meth:`impose` is given one explicitly.
    """

    def __init__(
        self,
        model: _shared.ErrorModel,
        n_dof: int = 1,
        initial_position: Sequence[float] | None = None,
    ) -> None:
        """Create the injector.

        Args:
            model: The error model.
            n_dof: Number of DOF.
            initial_position: Position before the first step per DOF, m; zeros if omitted.

        Raises:
            BridgeConfigError: On a bad model, ``n_dof`` or ``initial_position``.
        """
        if not isinstance(model, _shared.ErrorModel):
            raise BridgeConfigError(
                f'ErrorInjector: model must be an ErrorModel, got {type(model).__name__}'
            )
        if isinstance(n_dof, bool) or not isinstance(n_dof, Integral) or n_dof < 1:
            raise BridgeConfigError(
                f'ErrorInjector: n_dof must be a positive integer, got {n_dof!r}'
            )
        self._n = int(n_dof)
        try:
            super().__init__(model, self._start(initial_position))
        except DriverError as exc:
            raise BridgeConfigError(str(exc)) from None

    def _start(self, position: Sequence[float] | None) -> np.ndarray:
        if position is None:
            return np.zeros(self._n)
        return _vector(position, 'ErrorInjector: position', self._n)

    def reset(self, position: Sequence[float] | None = None) -> None:
        """Restart: empty the delay line at ``position`` and re-seed the generator.

        Args:
            position: Position per DOF, m; zeros if omitted.
        """
        super().reset(self._start(position))

    def impose(
        self, target: Sequence[float] | np.ndarray, current: Sequence[float] | None = None
    ) -> np.ndarray:
        """Return the displacement the actuator reaches when commanded ``target``.

        The target goes through the delay line; the delayed target then gets the systematic
        error relative to ``current``.

        Args:
            target: Commanded displacement per DOF, m.
            current: Position before the step per DOF, m; default: the last imposed one.

        Returns:
            The imposed displacement per DOF, m (also the new current position).

        Raises:
            DriverError: On a malformed or non-finite value.
        """
        x_t = _vector(target, 'target', self._n)
        x_c = None if current is None else _vector(current, 'current', self._n)
        return super().impose(x_t, x_c)

    def measure(
        self, displacement: Sequence[float] | np.ndarray, force: Sequence[float] | np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Corrupt a measurement with the model's noise and force bias.

        Args:
            displacement: True displacement per DOF, m.
            force: True force per DOF, N.

        Returns:
            ``(displacement, force)`` as measured.

        Raises:
            DriverError: On a malformed or non-finite value.
        """
        x = _vector(displacement, 'displacement', self._n)
        f = _vector(force, 'force', self._n)
        return super().measure(x, f)

    def apply(
        self, target: Sequence[float] | np.ndarray, restoring_force: RestoringForce
    ) -> ErroneousStep:
        """Impose ``target`` with the errors, evaluate the force there and measure.

        Args:
            target: Commanded displacement per DOF, m.
            restoring_force: Force per DOF (N) at a displacement per DOF (m).

        Returns:
            The step with its errors.
        """
        x_t = _vector(target, 'target', self._n)
        imposed = self.impose(x_t)
        force = _vector(restoring_force(imposed.copy()), 'restoring force', self._n)
        displacement, measured = super().measure(imposed, force)
        return ErroneousStep(x_t, imposed, force, displacement, measured)


# ---------------------------------------------------------------------- monitors


def tracking_error(
    command: Sequence[float] | np.ndarray, measured: Sequence[float] | np.ndarray
) -> np.ndarray:
    """History of the tracking error ``measured - command``.

    Args:
        command: Commanded displacements, shape ``(n,)`` or ``(n, n_dof)``, m.
        measured: Measured displacements, the same shape, m.

    Returns:
        ``measured - command``, the same shape (positive: beyond the command), m.

    Raises:
        ValueError: On different shapes or non-finite values.
    """
    c, m = _series(command, measured)
    return m - c


def tracking_indicator(
    command: Sequence[float] | np.ndarray, measured: Sequence[float] | np.ndarray
) -> np.ndarray:
    """Running tracking indicator (Mercan and Ricles 2007) of a measured-vs-command history.

    ``TI_0 = 0`` and ``TI_{i+1} = TI_i + (x_m,i x_c,i+1 - x_m,i+1 x_c,i) / 2``, the trapezoidal
    form of ``(int x_m dx_c - int x_c dx_m) / 2``: zero for perfect tracking, ``oint x_m dx_c``
    over a closed cycle. Positive means energy removed from the test (measured leading the
    command), negative energy added (measured lagging); see the module docstring. Usable on a
    whole test's series, at the controller rate or one value per step.

    Args:
        command: Commanded displacements, shape ``(n,)`` or ``(n, n_dof)``, m.
        measured: Measured displacements, the same shape, m.

    Returns:
        The indicator after each sample, the same shape, m2.

    Raises:
        ValueError: On different shapes or non-finite values.
    """
    c, m = _series(command, measured)
    result = np.zeros_like(c)
    if c.shape[0] > 1:
        increments = 0.5 * (m[:-1] * c[1:] - m[1:] * c[:-1])
        result[1:] = np.cumsum(increments, axis=0)
    return result


@dataclass(frozen=True)
class TrackingSample:
    """The monitors after one sample (one value per DOF).

    Attributes:
        error: ``measured - command``, m.
        indicator: Tracking indicator so far, m2.
    """

    error: np.ndarray
    indicator: np.ndarray


class TrackingMonitor:
    """Incremental tracking error and indicator, for publishing during a test.

    Gives the same values as :func:`tracking_error` and :func:`tracking_indicator` on the whole
    series.
    """

    def __init__(self, n_dof: int = 1) -> None:
        """Create an empty monitor.

        Args:
            n_dof: Number of DOF.

        Raises:
            BridgeConfigError: On a bad ``n_dof``.
        """
        if isinstance(n_dof, bool) or not isinstance(n_dof, Integral) or n_dof < 1:
            raise BridgeConfigError(
                f'TrackingMonitor: n_dof must be a positive integer, got {n_dof!r}'
            )
        self._n = int(n_dof)
        self.reset()

    def reset(self) -> None:
        """Forget every sample."""
        self._commands: list[np.ndarray] = []
        self._measured: list[np.ndarray] = []
        self._errors: list[np.ndarray] = []
        self._indicators: list[np.ndarray] = []
        self._indicator = np.zeros(self._n)

    def update(
        self, command: Sequence[float] | np.ndarray, measured: Sequence[float] | np.ndarray
    ) -> TrackingSample:
        """Add one (command, measured) pair.

        Args:
            command: Commanded displacement per DOF, m.
            measured: Measured displacement per DOF, m.

        Returns:
            The error of this sample and the indicator so far.

        Raises:
            ValueError: On a malformed or non-finite value.
        """
        try:
            c = _vector(command, 'command', self._n)
            m = _vector(measured, 'measured', self._n)
        except DriverError as exc:
            raise ValueError(str(exc)) from None
        if self._commands:
            c0, m0 = self._commands[-1], self._measured[-1]
            self._indicator = self._indicator + 0.5 * (m0 * c - m * c0)
        error = m - c
        self._commands.append(c)
        self._measured.append(m)
        self._errors.append(error)
        self._indicators.append(self._indicator.copy())
        return TrackingSample(error.copy(), self._indicator.copy())

    @property
    def count(self) -> int:
        """Number of samples."""
        return len(self._commands)

    @property
    def indicator(self) -> np.ndarray:
        """Tracking indicator so far per DOF, m2."""
        return self._indicator.copy()

    @property
    def commands(self) -> np.ndarray:
        """Command history, shape ``(count, n_dof)``, m."""
        return _stack(self._commands, self._n)

    @property
    def measured(self) -> np.ndarray:
        """Measured history, shape ``(count, n_dof)``, m."""
        return _stack(self._measured, self._n)

    @property
    def errors(self) -> np.ndarray:
        """Tracking error history, shape ``(count, n_dof)``, m."""
        return _stack(self._errors, self._n)

    @property
    def indicators(self) -> np.ndarray:
        """Tracking indicator history, shape ``(count, n_dof)``, m2."""
        return _stack(self._indicators, self._n)


# ---------------------------------------------------------------------- helpers


def _stack(rows: list[np.ndarray], n: int) -> np.ndarray:
    return np.array(rows) if rows else np.zeros((0, n))


def _series(command: Any, measured: Any) -> tuple[np.ndarray, np.ndarray]:
    c = np.asarray(command, dtype=float)
    m = np.asarray(measured, dtype=float)
    if c.shape != m.shape or c.ndim not in (1, 2):
        raise ValueError(
            f'command and measured must have the same shape (n,) or (n, n_dof), got {c.shape} '
            f'and {m.shape}'
        )
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(m))):
        raise ValueError('command and measured must be finite')
    return c, m


def _vector(values: Any, what: str, n: int | None) -> np.ndarray:
    try:
        vector = np.array(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise DriverError(f'{what} must be a sequence of numbers, got {values!r}') from None
    if n is not None and vector.size != n:
        raise DriverError(f'{what} has {vector.size} values, expected {n}')
    if not np.all(np.isfinite(vector)):
        raise DriverError(f'non-finite {what}: {vector.tolist()}')
    return vector

