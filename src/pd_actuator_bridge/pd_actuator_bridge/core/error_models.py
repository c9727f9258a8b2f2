"""Experimental error models (thesis section 3.4.3) with the bridge's exceptions and checks.

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
implemented once, in :mod:`pd_common.experimental.error_model` (the shared library): the
specimen simulator uses them directly
(wrapping a specimen's ``restoring_force``); :class:`ErrorModel` and :class:`ErrorInjector` here
are thin subclasses that add the bridge's exceptions (:class:`~.errors.BridgeConfigError`,
:class:`~.errors.DriverError`) and input checks, for the emulator's ramp-and-hold executor (which
drives the erroneous target and corrupts the averaged measurement).

The tracking monitors are in :mod:`pd_common.experimental.tracking`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from numbers import Integral
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from pd_common.experimental import error_model as _shared
from pd_common.experimental.error_model import (
    ErroneousStep,
    RestoringForce,
    systematic_displacement,
)

from .errors import BridgeConfigError, DriverError

if TYPE_CHECKING:
    from pydantic import BaseModel

__all__ = [
    'ErroneousStep',
    'ErrorInjector',
    'ErrorModel',
    'RestoringForce',
    'apply_error_model',
    'validated',
]

_M = TypeVar('_M', bound='BaseModel')


def validated(model: type[_M], values: Any, source: str, path: str = '') -> _M:
    """``values`` as the typed ``model`` of the shared schema (:mod:`pd_common.config`).

    The one check of a driver's settings (a parsed YAML section, ROS parameters, or the values
    of one of the bridge's parameter dataclasses): shared by :meth:`ErrorModel.from_mapping`,
    ``EmulatorParameters``, ``RampHoldParameters`` and the daqmx configuration.

    Args:
        model: the model (``EmulatorSection``, ``ErrorsSection``, ...).
        values: the values to check.
        source: the file's (or the object's) name in messages.
        path: the dotted path of ``values`` in their file (``'emulator'``; ``''``: none).

    Raises:
        BridgeConfigError: one line, ``<source>: <path>.<key>: <what is wrong>, got <value>``.
    """
    from pd_common.config.schema import (  # noqa: PLC0415 (the models: on first use)
        SchemaError,
        validate_model,
    )

    try:
        return validate_model(model, values, source, path)
    except SchemaError as err:
        raise BridgeConfigError(str(err)) from None


class ErrorModel(_shared.ErrorModel):
    """Experimental errors injected into each step (the same for every DOF).

    :class:`pd_common.experimental.ErrorModel` (the same attributes, validation and
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
    def from_mapping(cls, mapping: Mapping[str, Any], source: str = 'ErrorModel',
                     path: str = '') -> ErrorModel:
        """Build a model from a mapping (a parsed YAML section or ROS parameters).

        Args:
            mapping: Any subset of the attribute names; missing ones keep their defaults.
            source: Name of the file or parameter namespace, used in error messages.
            path: The mapping's dotted path in its file (``'errors'``), in error messages.

        Returns:
            The validated model.

        Raises:
            BridgeConfigError: On a non-mapping, an unknown key or a bad value (the schema's
                :class:`~pd_common.config.schema_specimen.ErrorsSection`).
        """
        from pd_common.config.schema_specimen import (  # noqa: PLC0415 (on first use)
            ErrorsSection,
        )

        return cls(**dict(validated(ErrorsSection, mapping, source, path)))


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
        msg = (
            'apply_error_model: delay_steps must be 0 (a delay needs the step history: use '
            'ErrorInjector)'
        )
        raise BridgeConfigError(msg)
    x_t = _vector(target, 'target', None)
    x_c = _vector(current, 'current', x_t.size)
    imposed = systematic_displacement(x_t, x_c, model.systematic)
    force = _vector(restoring_force(imposed.copy()), 'restoring force', x_t.size)
    generator = np.random.default_rng(model.seed) if rng is None else rng
    displacement, measured = _shared.measure(model, imposed, force, generator)
    return ErroneousStep(x_t, imposed, force, displacement, measured)


class ErrorInjector(_shared.ErrorInjector):
    """Applies an :class:`ErrorModel` step after step (keeps the delay line and the generator).

    :class:`pd_common.experimental.ErrorInjector` with the bridge's input checks:
    the actuator's current position is the displacement imposed at the previous step (or the
    initial position), unless :meth:`impose` is given one explicitly.
    """

    def __init__(
        self,
        model: _shared.ErrorModel,
        n_dof: int = 1,
        initial_position: Sequence[float] | NDArray[np.float64] | None = None,
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
            msg = f'ErrorInjector: model must be an ErrorModel, got {type(model).__name__}'
            raise BridgeConfigError(msg)
        if isinstance(n_dof, bool) or not isinstance(n_dof, Integral) or n_dof < 1:
            msg = f'ErrorInjector: n_dof must be a positive integer, got {n_dof!r}'
            raise BridgeConfigError(msg)
        self._n = int(n_dof)
        try:
            super().__init__(model, self._start(initial_position))
        except DriverError as exc:
            raise BridgeConfigError(str(exc)) from None

    def _start(self, position: Sequence[float] | NDArray[np.float64] | None) -> np.ndarray:
        if position is None:
            return np.zeros(self._n)
        return _vector(position, 'ErrorInjector: position', self._n)

    def reset(self, position: Sequence[float] | NDArray[np.float64] | None = None) -> None:
        """Restart: empty the delay line at ``position`` and re-seed the generator.

        Args:
            position: Position per DOF, m; zeros if omitted.
        """
        super().reset(self._start(position))

    def impose(
        self,
        target: Sequence[float] | np.ndarray,
        current: Sequence[float] | NDArray[np.float64] | None = None,
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


# ---------------------------------------------------------------------- helpers


def _vector(values: Any, what: str, n: int | None) -> np.ndarray:
    try:
        vector = np.array(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        msg = f'{what} must be a sequence of numbers, got {values!r}'
        raise DriverError(msg) from None
    if n is not None and vector.size != n:
        msg = f'{what} has {vector.size} values, expected {n}'
        raise DriverError(msg)
    if not np.all(np.isfinite(vector)):
        msg = f'non-finite {what}: {vector.tolist()}'
        raise DriverError(msg)
    return vector

