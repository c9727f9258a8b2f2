"""The experimental error model (thesis section 3.4.3), shared by the simulator and the bridge.

Shing and Mahin ("Cumulative experimental errors in pseudodynamic tests", Earthquake Eng.
Struct. Dyn. 15, 1987) split the errors of a pseudo-dynamic test into *systematic* errors, e.g.
an actuator that consistently undershoots or overshoots the commanded displacement increment,
and *random* errors (sensor noise); they showed that the systematic ones accumulate and are the
harmful ones. An :class:`ErrorModel` describes, per step and for every DOF:

* a systematic displacement error as a fraction ``s`` of the increment: the actuator, at
  ``x_current``, reaches ``x_imposed = x_delayed + s * (x_delayed - x_current)`` (``s < 0``
  undershoot, ``s > 0`` overshoot);
* a constant delay of ``delay_steps`` steps: ``x_delayed`` is the target of that many steps
  earlier (the initial position before the first ones);
* random noise on the measured displacement and force (Gaussian, standard deviations in m, N):
  one draw of ``2 n_dof`` standard normal numbers per step (first the displacements', then the
  forces'), ``x_measured = x_imposed + displacement_noise * z_x`` and
  ``f_measured = f(x_imposed) + force_bias + force_noise * z_f``;
* a constant force-measurement bias (N).

This is the one implementation: :class:`pd_common.specimen.server.SpecimenServer` injects it
into the simulated specimen, and ``pd_actuator_bridge.core.error_models`` re-exports it (with
the bridge's exception types and input checks) for the emulator's ramp-and-hold executor. It
lives in the shared library because both peers use it.

:class:`ErrorInjector` keeps the state a model needs from step to step (the actuator's position,
the delay line and the seeded noise generator). It does not check its inputs (float arrays of
``n_dof`` values): its callers do, each with its own exceptions.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from numbers import Integral, Real
from typing import Any

import numpy as np

from ..errors import SpecimenConfigError
from ..types import FloatArray

ERRORS_KEY = 'errors'
"""Key of the experimental-error mapping in the ``specimen`` section."""

RestoringForce = Callable[[FloatArray], FloatArray | Sequence[float]]
"""``r(x)``: displacement per DOF (m) to restoring force per DOF (N)."""


@dataclass(frozen=True)
class ErrorModel:
    """Experimental errors injected into each step (the same for every DOF).

    Attributes:
        systematic: Displacement error as a fraction of the increment, in ``(-1, 1]``:
            ``-0.05`` is a 5 % undershoot, ``0.05`` a 5 % overshoot.
        delay_steps: Constant delay of the executed target, steps.
        displacement_noise: Standard deviation of the displacement measurement noise, m.
        force_noise: Standard deviation of the force measurement noise, N.
        force_bias: Constant force-measurement offset, N.
        seed: Seed of the noise generator (``None``: a different draw every run).

    Raises:
        SpecimenConfigError: One line naming the parameter, if a value is invalid (a subclass
            may raise another type through :meth:`_invalid`).
    """

    systematic: float = 0.0
    delay_steps: int = 0
    displacement_noise: float = 0.0
    force_noise: float = 0.0
    force_bias: float = 0.0
    seed: int | None = None

    def __post_init__(self) -> None:
        """Validate and normalise the values."""
        name = 'systematic'
        systematic = self._real(self.systematic, name)
        if not -1.0 < systematic <= 1.0:
            raise self._invalid(name, 'must be in (-1, 1] (a fraction of the '
                                f'increment), got {self.systematic!r}')
        object.__setattr__(self, 'systematic', systematic)
        for name in ('displacement_noise', 'force_noise'):
            value = self._real(getattr(self, name), name)
            if value < 0.0:
                raise self._invalid(name, f'must be a non-negative finite number, got {value!r}')
            object.__setattr__(self, name, value)
        object.__setattr__(self, 'force_bias', self._real(self.force_bias, 'force_bias'))
        object.__setattr__(self, 'delay_steps', self._count(self.delay_steps, 'delay_steps'))
        if self.seed is not None:
            object.__setattr__(self, 'seed', self._count(self.seed, 'seed'))

    @classmethod
    def _invalid(cls, name: str, problem: str) -> Exception:
        """The exception for an invalid parameter: ``<name>: <problem>``."""
        return SpecimenConfigError(f'{name}: {problem}')

    @classmethod
    def _real(cls, value: Any, name: str) -> float:
        if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
            raise cls._invalid(name, f'must be a finite number, got {value!r}')
        return float(value)

    @classmethod
    def _count(cls, value: Any, name: str) -> int:
        if isinstance(value, bool) or not isinstance(value, Integral) or int(value) < 0:
            raise cls._invalid(name, f'must be an integer >= 0, got {value!r}')
        return int(value)

    @classmethod
    def from_mapping(cls, mapping: Any, source: str = 'test file') -> ErrorModel:
        """Build the model from the ``specimen.errors`` mapping of a test file.

        Args:
            mapping: Any subset of the attribute names; missing ones keep their defaults.
            source: Name of the YAML file, used in error messages.

        Returns:
            The validated model.

        Raises:
            SpecimenConfigError: ``<source>: specimen.errors...: <what is wrong>`` on a
                non-mapping, an unknown key or a bad value.
        """
        where = f'{source}: specimen.{ERRORS_KEY}'
        if not isinstance(mapping, Mapping):
            msg = f'{where}: must be a mapping, got {type(mapping).__name__}'
            raise SpecimenConfigError(msg)
        known = [f.name for f in fields(cls)]
        for key in mapping:
            if key not in known:
                msg = (f"{where}: unknown key '{key}' (allowed: "
                       f"{', '.join(sorted(known))})")
                raise SpecimenConfigError(msg)
        try:
            return cls(**dict(mapping))
        except SpecimenConfigError as exc:
            msg_0 = f'{where}.{exc}'
            raise SpecimenConfigError(msg_0) from None

    @property
    def is_ideal(self) -> bool:
        """Whether the model injects no error at all."""
        return (self.systematic == 0.0 and self.delay_steps == 0
                and self.displacement_noise == 0.0 and self.force_noise == 0.0
                and self.force_bias == 0.0)


@dataclass(frozen=True)
class ErroneousStep:
    """One step with its injected errors (one value per DOF in every array).

    Attributes:
        target: Ideal (commanded) displacement, m.
        imposed: Displacement actually imposed on the specimen (delay, systematic error), m.
        true_force: Restoring force at the imposed displacement, N.
        displacement: Measured displacement (imposed plus noise), m.
        force: Measured force (true force plus bias and noise), N.
    """

    target: FloatArray
    imposed: FloatArray
    true_force: FloatArray
    displacement: FloatArray
    force: FloatArray


def systematic_displacement(
    target: FloatArray, current: FloatArray, systematic: float
) -> FloatArray:
    """Displacement reached with a systematic error: ``target + systematic * (target - current)``.

    Args:
        target: Commanded displacement per DOF, m.
        current: Displacement before the step per DOF, m.
        systematic: Fraction of the increment (negative: undershoot).
    """
    return target + systematic * (target - current)


def measure(
    model: ErrorModel, x: FloatArray, f: FloatArray, rng: np.random.Generator
) -> tuple[FloatArray, FloatArray]:
    """Add noise (always drawn, so that the sequence does not depend on the stds) and bias.

    Args:
        model: The error model.
        x: True displacement per DOF, m.
        f: True force per DOF, N.
        rng: The noise generator (one draw of ``2 x.size`` numbers).

    Returns:
        ``(displacement, force)`` as measured.
    """
    noise = rng.standard_normal(2 * x.size)
    displacement = x + model.displacement_noise * noise[: x.size]
    force = f + model.force_bias + model.force_noise * noise[x.size:]
    return displacement, force


class ErrorInjector:
    """Applies an :class:`ErrorModel` step after step (keeps the delay line and the generator).

    The actuator's current position is the displacement imposed at the previous step (or the
    initial position), unless :meth:`impose` is given one explicitly. Inputs are float arrays of
    ``n_dof`` finite values; they are not checked here.
    """

    def __init__(self, model: ErrorModel, initial_position: FloatArray) -> None:
        """Create the injector.

        Args:
            model: The error model.
            initial_position: Position before the first step per DOF, m (sets ``n_dof``).
        """
        self._model = model
        self._n = int(np.asarray(initial_position).size)
        self.reset(initial_position)

    @property
    def model(self) -> ErrorModel:
        """The error model."""
        return self._model

    @property
    def n_dof(self) -> int:
        """Number of DOF."""
        return self._n

    @property
    def current(self) -> FloatArray:
        """The actuator's current position (the last imposed displacement), m."""
        return self._current.copy()

    def reset(self, position: FloatArray) -> None:
        """Restart: empty the delay line at ``position`` and re-seed the generator.

        Args:
            position: Position per DOF, m.
        """
        start = np.array(position, dtype=float).reshape(-1)
        self._current = start
        self._pending = [start.copy() for _ in range(self._model.delay_steps)]
        self._rng = np.random.default_rng(self._model.seed)

    def peek(self, target: FloatArray, current: FloatArray | None = None) -> FloatArray:
        """The displacement the actuator would reach when commanded ``target``; no state change.

        The target goes through the delay line; the delayed target then gets the systematic
        error relative to ``current`` (default: the last imposed displacement).
        """
        delayed = self._pending[0] if self._pending else target
        x_c = self._current if current is None else current
        return systematic_displacement(delayed, x_c, self._model.systematic)

    def impose(self, target: FloatArray, current: FloatArray | None = None) -> FloatArray:
        """Command ``target``: :meth:`peek`, then advance the delay line and the position.

        Returns:
            The imposed displacement per DOF, m (also the new current position).
        """
        imposed = self.peek(target, current)
        self._advance(target, imposed)
        return imposed

    def measure(self, displacement: FloatArray, force: FloatArray
                ) -> tuple[FloatArray, FloatArray]:
        """Corrupt a measurement with the model's noise and force bias (one draw)."""
        return measure(self._model, displacement, force, self._rng)

    def step(self, target: FloatArray, restoring_force: RestoringForce) -> ErroneousStep:
        """Impose ``target`` with the errors, evaluate the force there and measure.

        If ``restoring_force`` raises, the exception propagates and nothing changes (the delay
        line, the position and the generator stay as they were).

        Args:
            target: Commanded displacement per DOF, m.
            restoring_force: Force per DOF (N) at a displacement per DOF (m).

        Returns:
            The step with its errors.
        """
        imposed = self.peek(target)
        force = np.array(restoring_force(imposed.copy()), dtype=float).reshape(-1)
        self._advance(target, imposed)
        displacement, measured = self.measure(imposed, force)
        return ErroneousStep(target, imposed, force, displacement, measured)

    def _advance(self, target: FloatArray, imposed: FloatArray) -> None:
        if self._pending:
            self._pending.pop(0)
            self._pending.append(target)
        self._current = imposed.copy()
