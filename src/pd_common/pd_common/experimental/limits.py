"""Safety limits of the actuator bridge and the checks applied to commands and measurements.

The limits are the bridge's own: they are enforced whatever the integrator sends. A value exactly
at a limit is allowed; anything beyond it is rejected. There is deliberately no tolerance.

One implementation, two users: the actuator bridge enforces them
(``pd_actuator_bridge.core.bridge``), and the ROS-free rehearsals apply the same checks to the
same floats (``./pd offline`` holds where the bridge would; ``./pd pretest`` predicts the step).
:func:`bridge_parameters` and :func:`limits_from_parameters` read the limits from the bridge's
ROS parameters (a parameter file's ``ros__parameters``, 0 = off for the optional ones) exactly
as the bridge node does.

Two kinds of violation are distinguished: ``LIMIT`` (a finite value beyond a safety limit) and
``FAULT`` (malformed, non-finite or inconsistent data, or an actuator that does not follow its
command: see :func:`check_tracking`). :func:`saturate_command` clips a target to the nearest
allowed value for the bridge's ``on_limit='saturate'`` mode; a fault is never saturated.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from fractions import Fraction
from numbers import Real
from typing import Any

from ..errors import BridgeConfigError
from ..protocol import ControlMode, FeedbackStatus, control_problem, dof_label

__all__ = [
    'KIND_FAULT',
    'KIND_LIMIT',
    'LIMIT_PARAMETERS',
    'ON_LIMIT_OPTIONS',
    'LimitViolation',
    'SafetyLimits',
    'Saturation',
    'bridge_parameters',
    'check_command',
    'check_control',
    'check_feedback',
    'check_strokes',
    'check_target_force',
    'check_tracking',
    'dof_label',
    'format_value',
    'limits_from_parameters',
    'on_limit_from_parameters',
    'saturate_command',
]

KIND_LIMIT = FeedbackStatus.LIMIT
KIND_FAULT = FeedbackStatus.FAULT

_REQUIRED = ('max_displacement', 'max_increment', 'max_force')
_OPTIONAL = ('max_velocity', 'step_duration', 'tracking_tolerance', 'watchdog_timeout')
#: Limits that may be 0 (off) but never negative.
_ZERO_OFF = ('max_force_increment',)


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
        tracking_tolerance: Largest allowed |measured - commanded displacement| of a DOF when a
            step is answered, m (feedback plausibility); ``None`` disables the check.
        watchdog_timeout: Longest allowed time without a command while the bridge is active, s
            (see :meth:`~.bridge.ActuatorBridge.check_watchdog`); ``None`` disables the watchdog.
        max_force_increment: Largest change of a force-controlled actuator's commanded force in
            one sub-step, N: a force change is executed through
            :func:`pd_common.experimental.force_ramp.force_ramp` sub-steps of at most this
            (``docs/force_control.md``); 0 (the default) = no ramp, one sub-step.

    Raises:
        BridgeConfigError: If a value is not a positive finite number (``max_force_increment``:
            a finite number >= 0), or ``max_velocity`` is given without ``step_duration``.
    """

    max_displacement: float
    max_increment: float
    max_force: float
    max_velocity: float | None = None
    step_duration: float | None = None
    tracking_tolerance: float | None = None
    watchdog_timeout: float | None = None
    max_force_increment: float = 0.0

    def __post_init__(self) -> None:
        """Validate and normalise the values to ``float``."""
        _validate(self, 'SafetyLimits')
        for name in _REQUIRED + _OPTIONAL + _ZERO_OFF:
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, float(value))

    @property
    def velocity_checked(self) -> bool:
        """Whether the velocity limit is active (both ``max_velocity`` and ``step_duration``)."""
        return self.max_velocity is not None and self.step_duration is not None

    @property
    def max_step(self) -> float:
        """Largest allowed |x_target - x_current| of a DOF in one step, m.

        ``max_increment``, or ``max_velocity * step_duration`` if that is smaller. Rounding may
        put this value an ulp away from what :func:`check_command` accepts; use it as a guide
        (e.g. to plan moves), never as the check itself.
        """
        if self.max_velocity is not None and self.step_duration is not None:
            return min(self.max_increment, self.max_velocity * self.step_duration)
        return self.max_increment

    @classmethod
    def from_mapping(
        cls, mapping: Mapping[str, Any], source: str = 'safety limits'
    ) -> SafetyLimits:
        """Build the limits from a mapping such as a parsed YAML section or ROS parameters.

        Args:
            mapping: Keys exactly ``max_displacement``, ``max_increment``, ``max_force`` and
                optionally ``max_velocity``, ``step_duration``, ``tracking_tolerance`` and
                ``watchdog_timeout`` (``None`` means not set) and ``max_force_increment``
                (0 or missing: no force ramp).
            source: Name of the file or parameter namespace, used in error messages.

        Returns:
            The validated limits.

        Raises:
            BridgeConfigError: On a non-mapping, an unknown or missing key, or a bad value.
        """
        if not isinstance(mapping, Mapping):
            msg = f'{source}: safety limits must be a mapping, got {type(mapping).__name__}'
            raise BridgeConfigError(msg)
        known = _REQUIRED + _OPTIONAL + _ZERO_OFF
        for key in mapping:
            if key not in known:
                msg = (
                    f'{source}: unknown safety limit {key!r} '
                    f'(expected one of: {", ".join(sorted(known))})'
                )
                raise BridgeConfigError(msg)
        for key in _REQUIRED:
            if key not in mapping:
                msg = f'{source}: missing required safety limit {key!r}'
                raise BridgeConfigError(msg)
        values: dict[str, Any] = {key: mapping.get(key) for key in _REQUIRED + _OPTIONAL}
        for key in _ZERO_OFF:
            values[key] = mapping.get(key, 0.0)
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
            msg = (
                f'{source}: {name} must be a positive finite number, '
                f'got {type(value).__name__} {value!r}'
            )
            raise BridgeConfigError(msg)
        if not math.isfinite(float(value)) or float(value) <= 0.0:
            msg = f'{source}: {name} must be a positive finite number, got {value!r}'
            raise BridgeConfigError(msg)
    for name in _ZERO_OFF:
        value = values.get(name, 0.0)
        if (isinstance(value, bool) or not isinstance(value, Real)
                or not math.isfinite(float(value)) or float(value) < 0.0):
            msg = (f'{source}: {name} must be a finite number >= 0 (0 = off), got '
                   f'{type(value).__name__} {value!r}')
            raise BridgeConfigError(msg)
    if values['max_velocity'] is not None and values['step_duration'] is None:
        msg = (
            f'{source}: max_velocity requires step_duration (the velocity limit would not be '
            'enforced)'
        )
        raise BridgeConfigError(msg)


#: The bridge node's parameters that are safety limits, with the node's defaults (0 = off for
#: the optional ones: ``max_velocity``, ``step_duration``, ``tracking_tolerance``,
#: ``watchdog_timeout``; 0 = no force ramp for ``max_force_increment``).
LIMIT_PARAMETERS: dict[str, float] = {
    'max_displacement': 0.25,
    'max_increment': 0.02,
    'max_force': 1.0e5,
    'max_velocity': 0.0,
    'step_duration': 0.0,
    'tracking_tolerance': 0.0,
    'watchdog_timeout': 0.0,
    'max_force_increment': 0.0,
}
#: The bridge's reactions to a command beyond a limit (``on_limit``); the first is the default.
ON_LIMIT_OPTIONS = ('hold', 'saturate')


def bridge_parameters(raw: Any, source: str) -> dict[str, Any]:
    """The bridge's parameters in a ROS parameter file's content.

    The ``ros__parameters`` of its first node section that has them (e.g. ``/**``), or ``raw``
    itself if none has.

    Raises:
        BridgeConfigError: ``raw`` is not a mapping.
    """
    if not isinstance(raw, Mapping):
        msg = f'{source}: must be a mapping of ROS parameters, got {type(raw).__name__}'
        raise BridgeConfigError(msg)
    for value in raw.values():
        if isinstance(value, Mapping) and isinstance(value.get('ros__parameters'), Mapping):
            return dict(value['ros__parameters'])
    return dict(raw)


def limits_from_parameters(parameters: Mapping[str, Any],
                           source: str = 'pd_actuator_bridge parameters') -> SafetyLimits:
    """The safety limits the bridge node configures from its parameters.

    As the node does: a parameter not given takes the node's default
    (:data:`LIMIT_PARAMETERS`); ``max_displacement``, ``max_increment``, ``max_force`` and
    ``max_force_increment`` are taken as they are, the optional limits only when above 0 (0 =
    off). Other parameters (``driver``, ``on_limit``, ...) are ignored.

    Raises:
        BridgeConfigError: a limit is not a number, or :class:`SafetyLimits` refuses a value.
    """
    mapping: dict[str, float] = {}
    for key, default in LIMIT_PARAMETERS.items():
        value = parameters.get(key, default)
        if isinstance(value, bool) or not isinstance(value, Real):
            msg = f'{source}: {key} must be a number, got {type(value).__name__} {value!r}'
            raise BridgeConfigError(msg)
        if key in _OPTIONAL and not float(value) > 0.0:
            continue
        mapping[key] = float(value)
    return SafetyLimits.from_mapping(mapping, source=source)


def on_limit_from_parameters(parameters: Mapping[str, Any],
                             source: str = 'pd_actuator_bridge parameters') -> str:
    """The bridge's ``on_limit`` parameter (``'hold'`` if not given).

    Raises:
        BridgeConfigError: a value other than those of :data:`ON_LIMIT_OPTIONS`.
    """
    value = parameters.get('on_limit', ON_LIMIT_OPTIONS[0])
    if value not in ON_LIMIT_OPTIONS:
        msg = (f'{source}: on_limit must be one of {", ".join(ON_LIMIT_OPTIONS)}, '
               f'got {value!r}')
        raise BridgeConfigError(msg)
    return str(value)


@dataclass(frozen=True)
class LimitViolation:
    """Why a command or a measurement was rejected.

    Attributes:
        kind: ``'limit'`` (a finite value beyond a safety limit) or ``'fault'`` (malformed,
            non-finite or inconsistent data).
        dof: Index of the offending DOF. For a length mismatch, the first index present in only
            one of the two sequences.
        message: One-line human-readable reason naming the DOF, the value and the limit.
        limit: The limit that was exceeded (``'max_displacement'``, ``'max_increment'``,
            ``'max_velocity'``, ``'max_force'``, ``'tracking_tolerance'``); empty for malformed
            or non-finite data. Not compared (the message names it too).
    """

    kind: FeedbackStatus
    dof: int
    message: str
    limit: str = field(default='', compare=False)


def check_command(
    target: Sequence[float],
    current: Sequence[float],
    limits: SafetyLimits,
    dof_names: Sequence[str] | None = None,
    *,
    displacement_controlled: Sequence[bool] | None = None,
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
        displacement_controlled: Under mixed control, per DOF whether it is
            displacement-controlled; the limits then apply to those DOFs only (a
            force-controlled DOF's target is not imposed, so only its finiteness is checked;
            its stroke is checked after each force sub-step, :func:`check_strokes`). ``None``:
            every DOF.

    Returns:
        The first violation found, or ``None`` if the command is safe.
    """
    target_values, current_values, violation = _parse_pair(
        target, 'target displacement', current, 'current displacement')
    if violation is not None:
        return violation
    if len(target_values) != len(current_values):
        return LimitViolation(
            KIND_FAULT,
            min(len(target_values), len(current_values)),
            f'target displacement has {len(target_values)} values but the actuator has '
            f'{len(current_values)} DOF',
        )
    violation = _non_finite_pair(target_values, 'target displacement', current_values,
                                 'current displacement', dof_names)
    if violation is not None:
        return violation

    imposed = _mask(displacement_controlled, len(target_values))
    for dof, value in enumerate(target_values):
        if imposed[dof] and abs(value) > limits.max_displacement:
            return LimitViolation(
                KIND_LIMIT,
                dof,
                f'{_dof_label(dof, dof_names)}: target displacement '
                f'{_fmt(value, limits.max_displacement)} m exceeds max_displacement '
                f'{_fmt(limits.max_displacement)} m',
                'max_displacement',
            )
    increments = [abs(t - c) if on else 0.0
                  for t, c, on in zip(target_values, current_values, imposed)]
    for dof, increment in enumerate(increments):
        if increment > limits.max_increment:
            return LimitViolation(
                KIND_LIMIT,
                dof,
                f'{_dof_label(dof, dof_names)}: displacement increment '
                f'{_fmt(increment, limits.max_increment)} m (from {_fmt(current_values[dof])} m '
                f'to {_fmt(target_values[dof])} m) exceeds max_increment '
                f'{_fmt(limits.max_increment)} m',
                'max_increment',
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
                    'max_velocity',
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
    displacement_values, force_values, violation = _parse_pair(
        displacement, 'measured displacement', force, 'measured force')
    if violation is not None:
        return violation
    expected = len(displacement_values) if n_dof is None else n_dof
    for what, values in (('measured displacement', displacement_values),
                         ('measured force', force_values)):
        if len(values) != expected:
            return LimitViolation(
                KIND_FAULT,
                min(len(values), expected),
                f'{what} has {len(values)} values but the actuator has {expected} DOF',
            )
    violation = _non_finite_pair(displacement_values, 'measured displacement', force_values,
                                 'measured force', dof_names)
    if violation is not None:
        return violation
    for dof, value in enumerate(force_values):
        if abs(value) > limits.max_force:
            return LimitViolation(
                KIND_LIMIT,
                dof,
                f'{_dof_label(dof, dof_names)}: measured force {_fmt(value, limits.max_force)} N '
                f'exceeds max_force {_fmt(limits.max_force)} N',
                'max_force',
            )
    return None


def check_tracking(
    measured: Sequence[float],
    commanded: Sequence[float],
    limits: SafetyLimits,
    dof_names: Sequence[str] | None = None,
    *,
    displacement_controlled: Sequence[bool] | None = None,
) -> LimitViolation | None:
    """Check that the actuator followed its command (feedback plausibility).

    Args:
        measured: Measured displacement per DOF when the step is answered, m.
        commanded: Displacement sent to the driver for that step, m.
        limits: The limits; nothing is checked when ``tracking_tolerance`` is ``None``.
        dof_names: Optional DOF names used in messages.
        displacement_controlled: Under mixed control, per DOF whether it is
            displacement-controlled (a force-controlled DOF goes wherever its force takes it:
            not checked); ``None``: every DOF.

    Returns:
        ``'fault'`` if |measured - commanded| > tracking_tolerance for a DOF (the first one), or
        if the values are malformed, mismatched or non-finite; else ``None``. An actuator that
        does not go where it is told is a fault of the hardware, not a value beyond a limit.
    """
    tolerance = limits.tracking_tolerance
    if tolerance is None:
        return None
    measured_values, commanded_values, violation = _parse_pair(
        measured, 'measured displacement', commanded, 'commanded displacement')
    if violation is not None:
        return violation
    if len(measured_values) != len(commanded_values):
        return LimitViolation(
            KIND_FAULT,
            min(len(measured_values), len(commanded_values)),
            f'measured displacement has {len(measured_values)} values but '
            f'{len(commanded_values)} were commanded',
        )
    violation = _non_finite_pair(measured_values, 'measured displacement', commanded_values,
                                 'commanded displacement', dof_names)
    if violation is not None:
        return violation
    imposed = _mask(displacement_controlled, len(measured_values))
    for dof, (x_measured, x_commanded) in enumerate(zip(measured_values, commanded_values)):
        error = abs(x_measured - x_commanded)
        if imposed[dof] and error > tolerance:
            return LimitViolation(
                KIND_FAULT,
                dof,
                f'{_dof_label(dof, dof_names)}: tracking error {_fmt(error, tolerance)} m '
                f'(measured {_fmt(x_measured)} m, commanded {_fmt(x_commanded)} m) exceeds '
                f'tracking_tolerance {_fmt(tolerance)} m',
                'tracking_tolerance',
            )
    return None


def check_control(
    control_mode: Sequence[Any],
    target_force: Sequence[Any],
    n_dof: int,
    dof_names: Sequence[str] | None = None,
) -> tuple[tuple[bool, ...], tuple[float, ...], LimitViolation | None]:
    """Check a command's control modes and target forces for consistency.

    The protocol's :func:`pd_common.protocol.control_problem` on values taken as they come from the
    wire.

    Modes must be empty (every DOF displacement-controlled; then no forces either) or one
    :class:`~pd_common.protocol.ControlMode` per DOF, with one finite target force per DOF.

    Args:
        control_mode: Per DOF 0 (displacement) or 1 (force), or empty.
        target_force: Per DOF the force a force-controlled DOF holds, N (ignored for the
            others), or empty.
        n_dof: Number of DOF.
        dof_names: Optional DOF names used in messages.

    Returns:
        ``(force_controlled, forces, violation)``: per DOF whether it is force-controlled, the
        target forces as floats (zeros without modes) and ``None``, or a ``'fault'``
        violation (then the first two are empty).
    """
    for what, values in (('control_mode', control_mode), ('target_force', target_force)):
        if _not_a_sequence(values):
            return (), (), LimitViolation(
                KIND_FAULT, 0, f'{what} must be a sequence, got {type(values).__name__}')
    modes = list(control_mode)
    raw_forces = list(target_force)
    forces, problem = _as_floats(raw_forces, 'target force')
    # The protocol's rule (one home); forces that are not numbers are reported after it.
    rule = control_problem(modes, forces if problem is None else [0.0] * len(raw_forces),
                           n_dof, dof_names)
    if rule is not None:
        return (), (), LimitViolation(KIND_FAULT, rule[0], rule[1])
    if problem is not None:
        return (), (), LimitViolation(KIND_FAULT, 0, problem)
    if not modes:
        return (False,) * n_dof, (0.0,) * n_dof, None
    return tuple(int(mode) == ControlMode.FORCE for mode in modes), tuple(forces), None


def check_target_force(
    target_force: Sequence[float],
    force_controlled: Sequence[bool],
    limits: SafetyLimits,
    dof_names: Sequence[str] | None = None,
) -> LimitViolation | None:
    """``'limit'`` for the first force-controlled DOF with |target_force| > max_force."""
    for dof, (force, controlled) in enumerate(zip(target_force, force_controlled)):
        if controlled and abs(force) > limits.max_force:
            return LimitViolation(
                KIND_LIMIT, dof,
                f'{_dof_label(dof, dof_names)}: target force {_fmt(force, limits.max_force)} N '
                f'exceeds max_force {_fmt(limits.max_force)} N (force-controlled; nothing moved)',
                'max_force')
    return None


def check_strokes(
    measured: Sequence[float],
    start: Sequence[float],
    force_controlled: Sequence[bool],
    limits: SafetyLimits,
    dof_names: Sequence[str] | None = None,
    where: str = '',
) -> LimitViolation | None:
    """Check every actuator's measured stroke after a sub-step of a mixed command.

    ``'limit'`` for the first DOF with |measured| > max_displacement, then for the first one
    whose stroke changed within the step by more than max_increment (|measured - start|, with
    ``start`` the stroke when the step began): a force-controlled actuator running away.

    Args:
        measured: Measured stroke per DOF, m (finite, checked by :func:`check_feedback`).
        start: Stroke per DOF when the step (or the ramp-down) began, m.
        force_controlled: Per DOF whether it is force-controlled (named in the message).
        limits: The limits to enforce.
        dof_names: Optional DOF names used in messages.
        where: Appended to the message, e.g. ``' at force ramp sub-step 3 of 10'``.
    """
    def label(dof: int) -> str:
        text = _dof_label(dof, dof_names)
        return f'{text}, force-controlled' if force_controlled[dof] else text

    for dof, value in enumerate(measured):
        if abs(value) > limits.max_displacement:
            return LimitViolation(
                KIND_LIMIT, dof,
                f'{label(dof)}: measured stroke {_fmt(value, limits.max_displacement)} m '
                f'exceeds max_displacement {_fmt(limits.max_displacement)} m{where}; holding',
                'max_displacement')
    for dof, (value, begin) in enumerate(zip(measured, start)):
        change = abs(value - begin)
        if change > limits.max_increment:
            return LimitViolation(
                KIND_LIMIT, dof,
                f'{label(dof)}: stroke change {_fmt(change, limits.max_increment)} m within the '
                f'step (from {_fmt(begin)} m to {_fmt(value)} m) exceeds max_increment '
                f'{_fmt(limits.max_increment)} m{where}; holding', 'max_increment')
    return None


def _mask(flags: Sequence[bool] | None, n: int) -> list[bool]:
    """Per DOF whether the displacement limits apply (every DOF without flags)."""
    if flags is None:
        return [True] * n
    values = [bool(flag) for flag in flags]
    return values + [True] * (n - len(values))


@dataclass(frozen=True)
class Saturation:
    """The result of :func:`saturate_command`.

    Attributes:
        target: The target to send (each DOF clipped to the nearest allowed value; it passes
            :func:`check_command`), or ``None`` if the command cannot be made safe.
        message: Empty if nothing was clipped, else one line naming each clipped DOF, the
            requested and the sent value and the binding limit.
        violation: Why the command cannot be made safe (a fault, or no allowed value exists),
            else ``None``.
    """

    target: tuple[float, ...] | None
    message: str
    violation: LimitViolation | None

    @property
    def clipped(self) -> bool:
        """Whether at least one DOF was clipped."""
        return bool(self.message)


# Clipped values are nudged by at most this many ulps so that the rounding of
# ``current +- max_step`` neither produces a value beyond a limit nor stops short of the nearest
# allowed one.
_MAX_NUDGES = 64


def saturate_command(
    target: Sequence[float],
    current: Sequence[float],
    limits: SafetyLimits,
    dof_names: Sequence[str] | None = None,
) -> Saturation:
    """Clip a target displacement to the nearest value the limits allow.

    Each DOF is clipped to the interval allowed by |x| <= max_displacement and
    |x - current| <= ``max_step`` (max_increment or, if tighter, the velocity limit), then
    adjusted by a few ulps to the nearest value that is within the limits both as
    :func:`check_command` computes it and in exact arithmetic (so a clipped value never relies
    on rounding to pass). The result is verified with :func:`check_command`, so it never exceeds
    a limit. DOFs already within the limits are sent unchanged.

    A fault (malformed, mismatched or non-finite target or current position) is never
    saturated. Neither is a DOF whose current position is so far beyond ``max_displacement``
    that no value within one step is allowed.

    Args:
        target: Requested displacement per DOF, m.
        current: Current (last known) displacement per DOF, m.
        limits: The limits to enforce.
        dof_names: Optional DOF names used in messages.

    Returns:
        The clipped target and a description of what was clipped, or the violation that
        prevents saturation.
    """
    violation = check_command(target, current, limits, dof_names)
    if violation is None:
        return Saturation(tuple(float(x) for x in target), '', None)
    if violation.kind != KIND_LIMIT:
        return Saturation(None, '', violation)
    # check_command found no fault: both are equally long sequences of finite numbers.
    target_values = [float(x) for x in target]
    current_values = [float(x) for x in current]
    max_step = limits.max_step
    if max_step < limits.max_increment:
        step_bound = (
            f'max_velocity {_fmt(limits.max_velocity or 0.0)} m/s over step_duration '
            f'{_fmt(limits.step_duration or 0.0)} s'
        )
    else:
        step_bound = f'max_increment {_fmt(limits.max_increment)} m'
    clipped: list[float] = []
    notes: list[str] = []
    for dof, (x_target, x_current) in enumerate(zip(target_values, current_values)):
        label = _dof_label(dof, dof_names)
        if _dof_allowed(x_target, x_current, limits):
            clipped.append(x_target)
            continue
        low = max(-limits.max_displacement, x_current - max_step)
        high = min(limits.max_displacement, x_current + max_step)
        value = min(max(x_target, low), high) if low <= high else math.nan
        for _ in range(_MAX_NUDGES):
            if math.isnan(value) or _dof_allowed_exactly(value, x_current, limits):
                break
            value = math.nextafter(value, x_current)
        if math.isnan(value) or not _dof_allowed_exactly(value, x_current, limits):
            value = math.nan
        else:
            # The allowed set is an interval of floats: move outwards while still allowed, so the
            # result is the allowed value nearest the target, not one an ulp short of it.
            for _ in range(_MAX_NUDGES):
                further = math.nextafter(value, x_target)
                if further == value or not _dof_allowed_exactly(further, x_current, limits):
                    break
                value = further
        if math.isnan(value):
            return Saturation(
                None,
                '',
                LimitViolation(
                    KIND_LIMIT,
                    dof,
                    f'{label}: cannot saturate target {_fmt(x_target)} m: no displacement '
                    f'within max_displacement {_fmt(limits.max_displacement)} m is reachable '
                    f'in one step ({step_bound}) from {_fmt(x_current)} m',
                    violation.limit,
                ),
            )
        if abs(value) == limits.max_displacement and abs(x_target) > limits.max_displacement:
            bound = f'max_displacement {_fmt(limits.max_displacement)} m'
        else:
            bound = f'{step_bound} from {_fmt(x_current)} m'
        clipped.append(value)
        notes.append(f'{label}: target {_fmt(x_target)} m clipped to {_fmt(value)} m ({bound})')
    final = check_command(clipped, current_values, limits, dof_names)
    if final is not None:  # pragma: no cover - defensive: the DOFs were checked one by one
        return Saturation(None, '', final)
    return Saturation(tuple(clipped), '; '.join(notes), None)


def _dof_allowed(target: float, current: float, limits: SafetyLimits) -> bool:
    """Whether one DOF's move passes :func:`check_command` (the same arithmetic, by reuse)."""
    return check_command([target], [current], limits) is None


def _dof_allowed_exactly(target: float, current: float, limits: SafetyLimits) -> bool:
    """Whether one DOF's move passes :func:`check_command` and the limits in exact arithmetic."""
    if not _dof_allowed(target, current, limits):
        return False
    increment = abs(Fraction(target) - Fraction(current))
    if increment > Fraction(limits.max_increment):
        return False
    if limits.max_velocity is not None and limits.step_duration is not None:
        return increment <= Fraction(limits.max_velocity) * Fraction(limits.step_duration)
    return True


def _not_a_sequence(values: Any) -> bool:
    """Whether ``values`` cannot be a sequence of values (text, bytes, a mapping, a scalar).

    A tuple or list (what the bridge receives) is decided without the abstract base classes'
    ``isinstance``, which costs a microsecond each.
    """
    kind = type(values)
    if kind is tuple or kind is list:
        return False
    return isinstance(values, (str, bytes, Mapping)) or not isinstance(values, Iterable)


def _as_floats(values: Any, what: str) -> tuple[list[float], str | None]:
    """Convert a sequence of numbers to floats, or describe why it cannot be."""
    if _not_a_sequence(values):
        return [], f'{what} must be a sequence of numbers, got {type(values).__name__}'
    result = []
    for dof, value in enumerate(values):
        try:
            result.append(float(value))
        except (TypeError, ValueError, OverflowError):
            return [], f'{what} for DOF {dof} is not a number: {value!r}'
    return result, None


def _parse_pair(
    first: Any, first_what: str, second: Any, second_what: str
) -> tuple[list[float], list[float], LimitViolation | None]:
    """Both sequences as floats, or the fault describing the first one that is malformed."""
    first_values, problem = _as_floats(first, first_what)
    if problem is None:
        second_values, problem = _as_floats(second, second_what)
    if problem is not None:
        return [], [], LimitViolation(KIND_FAULT, 0, problem)
    return first_values, second_values, None


def _non_finite_pair(
    first: Sequence[float], first_what: str, second: Sequence[float], second_what: str,
    dof_names: Sequence[str] | None,
) -> LimitViolation | None:
    """The fault for the first non-finite value of ``first``, then of ``second``."""
    violation = _non_finite(first, first_what, dof_names)
    return violation if violation is not None else _non_finite(second, second_what, dof_names)


def _non_finite(
    values: Sequence[float], what: str, dof_names: Sequence[str] | None
) -> LimitViolation | None:
    for dof, value in enumerate(values):
        if not math.isfinite(value):
            return LimitViolation(
                KIND_FAULT, dof, f'non-finite {what} for {_dof_label(dof, dof_names)}: {value}'
            )
    return None


def format_value(value: float, limit: float | None = None) -> str:
    """Format compactly, but never so that a value beyond ``limit`` prints equal to it."""
    text = f'{value:.6g}'
    if limit is not None and text == f'{limit:.6g}':
        return repr(value)
    return text


# Short names used throughout this module's messages.
_dof_label = dof_label
_fmt = format_value
