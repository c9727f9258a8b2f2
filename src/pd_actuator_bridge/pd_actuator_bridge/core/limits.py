"""Safety limits of the actuator bridge and the checks applied to commands and measurements.

The limits are the bridge's own: they are enforced whatever the integrator sends. A value exactly
at a limit is allowed; anything beyond it is rejected. There is deliberately no tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, fields
from numbers import Real
from typing import Any

from .errors import BridgeConfigError

KIND_LIMIT = 'limit'
KIND_FAULT = 'fault'

_REQUIRED = ('max_displacement', 'max_increment', 'max_force')
_OPTIONAL = ('max_velocity', 'step_duration')


@dataclass(frozen=True)
class SafetyLimits:
    """Limits the bridge enforces on every command and measurement (the same for each DOF).

    Attributes:
        max_displacement: Largest allowed absolute target displacement |x| of a DOF, m.
        max_increment: Largest allowed |x_target - x_current| of a DOF in one step, m.
        max_force: Largest allowed absolute measured force |f| of a DOF, N.
        max_velocity: Largest allowed mean velocity over a step, m/s; enforced as
            |x_target - x_current| / step_duration <= max_velocity. Requires ``step_duration``.
        step_duration: Time the actuator takes to execute one step, s.

    Raises:
        BridgeConfigError: If a value is not a positive finite number, or ``max_velocity`` is
            given without ``step_duration``.
    """

    max_displacement: float
    max_increment: float
    max_force: float
    max_velocity: float | None = None
    step_duration: float | None = None

    def __post_init__(self) -> None:
        """Validate and normalise the values to ``float``."""
        _validate(self, 'SafetyLimits')
        for name in _REQUIRED + _OPTIONAL:
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, float(value))

    @property
    def velocity_checked(self) -> bool:
        """Whether the velocity limit is active (both ``max_velocity`` and ``step_duration``)."""
        return self.max_velocity is not None and self.step_duration is not None

    @classmethod
    def from_mapping(
        cls, mapping: Mapping[str, Any], source: str = 'safety limits'
    ) -> SafetyLimits:
        """Build the limits from a mapping such as a parsed YAML section or ROS parameters.

        Args:
            mapping: Keys exactly ``max_displacement``, ``max_increment``, ``max_force`` and
                optionally ``max_velocity`` and ``step_duration`` (``None`` means not set).
            source: Name of the file or parameter namespace, used in error messages.

        Returns:
            The validated limits.

        Raises:
            BridgeConfigError: On a non-mapping, an unknown or missing key, or a bad value.
        """
        if not isinstance(mapping, Mapping):
            raise BridgeConfigError(
                f'{source}: safety limits must be a mapping, got {type(mapping).__name__}'
            )
        known = _REQUIRED + _OPTIONAL
        for key in mapping:
            if key not in known:
                raise BridgeConfigError(
                    f'{source}: unknown safety limit {key!r} '
                    f'(expected one of: {", ".join(sorted(known))})'
                )
        for key in _REQUIRED:
            if key not in mapping:
                raise BridgeConfigError(f'{source}: missing required safety limit {key!r}')
        values = {key: mapping.get(key) for key in known}
        _validate_values(values, source)
        return cls(**values)


def _validate(limits: SafetyLimits, source: str) -> None:
    _validate_values({f.name: getattr(limits, f.name) for f in fields(limits)}, source)


def _validate_values(values: Mapping[str, Any], source: str) -> None:
    for name in _REQUIRED + _OPTIONAL:
        value = values[name]
        if value is None and name in _OPTIONAL:
            continue
        if isinstance(value, bool) or not isinstance(value, Real):
            raise BridgeConfigError(
                f'{source}: {name} must be a positive finite number, '
                f'got {type(value).__name__} {value!r}'
            )
        if not math.isfinite(float(value)) or float(value) <= 0.0:
            raise BridgeConfigError(
                f'{source}: {name} must be a positive finite number, got {value!r}'
            )
    if values['max_velocity'] is not None and values['step_duration'] is None:
        raise BridgeConfigError(
            f'{source}: max_velocity requires step_duration (the velocity limit would not be '
            'enforced)'
        )


@dataclass(frozen=True)
class LimitViolation:
    """Why a command or a measurement was rejected.

    Attributes:
        kind: ``'limit'`` (a finite value beyond a safety limit) or ``'fault'`` (malformed,
            non-finite or inconsistent data).
        dof: Index of the offending DOF. For a length mismatch, the first index present in only
            one of the two sequences.
        message: One-line human-readable reason naming the DOF, the value and the limit.
    """

    kind: str
    dof: int
    message: str


def check_command(
    target: Sequence[float],
    current: Sequence[float],
    limits: SafetyLimits,
    dof_names: Sequence[str] | None = None,
) -> LimitViolation | None:
    """Check a target displacement against the safety limits.

    Checks, in order, over all DOFs: malformed or non-finite values and length mismatch
    (``'fault'``), then |target| <= max_displacement, then |target - current| <= max_increment,
    then the mean velocity over ``step_duration`` (all ``'limit'``).

    Args:
        target: Commanded displacement per DOF, m.
        current: Current (last known) displacement per DOF, m.
        limits: The limits to enforce.
        dof_names: Optional DOF names used in messages, e.g. ``'DOF 0 (top)'``.

    Returns:
        The first violation found, or ``None`` if the command is safe.
    """
    target_values, problem = _as_floats(target, 'target displacement')
    if problem is not None:
        return LimitViolation(KIND_FAULT, 0, problem)
    current_values, problem = _as_floats(current, 'current displacement')
    if problem is not None:
        return LimitViolation(KIND_FAULT, 0, problem)
    if len(target_values) != len(current_values):
        return LimitViolation(
            KIND_FAULT,
            min(len(target_values), len(current_values)),
            f'target displacement has {len(target_values)} values but the actuator has '
            f'{len(current_values)} DOF',
        )
    violation = _non_finite(target_values, 'target displacement', dof_names)
    if violation is None:
        violation = _non_finite(current_values, 'current displacement', dof_names)
    if violation is not None:
        return violation

    for dof, value in enumerate(target_values):
        if abs(value) > limits.max_displacement:
            return LimitViolation(
                KIND_LIMIT,
                dof,
                f'{_dof_label(dof, dof_names)}: target displacement '
                f'{_fmt(value, limits.max_displacement)} m exceeds max_displacement '
                f'{_fmt(limits.max_displacement)} m',
            )
    increments = [abs(t - c) for t, c in zip(target_values, current_values)]
    for dof, increment in enumerate(increments):
        if increment > limits.max_increment:
            return LimitViolation(
                KIND_LIMIT,
                dof,
                f'{_dof_label(dof, dof_names)}: displacement increment '
                f'{_fmt(increment, limits.max_increment)} m (from {_fmt(current_values[dof])} m '
                f'to {_fmt(target_values[dof])} m) exceeds max_increment '
                f'{_fmt(limits.max_increment)} m',
            )
    if limits.max_velocity is not None and limits.step_duration is not None:
        for dof, increment in enumerate(increments):
            velocity = increment / limits.step_duration
            if velocity > limits.max_velocity:
                return LimitViolation(
                    KIND_LIMIT,
                    dof,
                    f'{_dof_label(dof, dof_names)}: velocity '
                    f'{_fmt(velocity, limits.max_velocity)} m/s (increment {_fmt(increment)} m '
                    f'over step_duration {_fmt(limits.step_duration)} s) exceeds max_velocity '
                    f'{_fmt(limits.max_velocity)} m/s',
                )
    return None


def check_feedback(
    displacement: Sequence[float],
    force: Sequence[float],
    limits: SafetyLimits,
    dof_names: Sequence[str] | None = None,
    n_dof: int | None = None,
) -> LimitViolation | None:
    """Check a measurement (displacement and force per DOF) from the actuator.

    Args:
        displacement: Measured displacement per DOF, m.
        force: Measured force per DOF, N.
        limits: The limits to enforce.
        dof_names: Optional DOF names used in messages.
        n_dof: Expected number of DOF; if given, both sequences must have this length.

    Returns:
        ``'fault'`` for malformed, mismatched or non-finite measurements, ``'limit'`` for
        |force| > max_force, else ``None``.
    """
    displacement_values, problem = _as_floats(displacement, 'measured displacement')
    if problem is not None:
        return LimitViolation(KIND_FAULT, 0, problem)
    force_values, problem = _as_floats(force, 'measured force')
    if problem is not None:
        return LimitViolation(KIND_FAULT, 0, problem)
    expected = len(displacement_values) if n_dof is None else n_dof
    for what, values in (('measured displacement', displacement_values),
                         ('measured force', force_values)):
        if len(values) != expected:
            return LimitViolation(
                KIND_FAULT,
                min(len(values), expected),
                f'{what} has {len(values)} values but the actuator has {expected} DOF',
            )
    violation = _non_finite(displacement_values, 'measured displacement', dof_names)
    if violation is None:
        violation = _non_finite(force_values, 'measured force', dof_names)
    if violation is not None:
        return violation
    for dof, value in enumerate(force_values):
        if abs(value) > limits.max_force:
            return LimitViolation(
                KIND_LIMIT,
                dof,
                f'{_dof_label(dof, dof_names)}: measured force {_fmt(value, limits.max_force)} N '
                f'exceeds max_force {_fmt(limits.max_force)} N',
            )
    return None


def _as_floats(values: Any, what: str) -> tuple[list[float], str | None]:
    """Convert a sequence of numbers to floats, or describe why it cannot be."""
    if isinstance(values, (str, bytes, Mapping)) or not isinstance(values, Iterable):
        return [], f'{what} must be a sequence of numbers, got {type(values).__name__}'
    result = []
    for dof, value in enumerate(values):
        try:
            result.append(float(value))
        except (TypeError, ValueError, OverflowError):
            return [], f'{what} for DOF {dof} is not a number: {value!r}'
    return result, None


def _non_finite(
    values: Sequence[float], what: str, dof_names: Sequence[str] | None
) -> LimitViolation | None:
    for dof, value in enumerate(values):
        if not math.isfinite(value):
            return LimitViolation(
                KIND_FAULT, dof, f'non-finite {what} for {_dof_label(dof, dof_names)}: {value}'
            )
    return None


def _dof_label(dof: int, dof_names: Sequence[str] | None) -> str:
    if dof_names is not None and 0 <= dof < len(dof_names):
        return f'DOF {dof} ({dof_names[dof]})'
    return f'DOF {dof}'


def _fmt(value: float, limit: float | None = None) -> str:
    """Format compactly, but never so that a value beyond ``limit`` prints equal to it."""
    text = f'{value:.6g}'
    if limit is not None and text == f'{limit:.6g}':
        return repr(value)
    return text
