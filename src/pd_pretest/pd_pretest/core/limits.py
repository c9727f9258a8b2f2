"""The actuator bridge's safety limits, read from its parameter file, which runs trip them.

And the step at which the bridge would hold each of them.

The limits are those the bridge enforces, checked by the bridge's own functions
(:mod:`pd_common.experimental.limits`): ``|x_target| <= max_displacement``, ``|x_target −
x_current| <= max_increment``, ``|x_target − x_current| / step_duration <= max_velocity`` (only
with both set) on each command, from the position last measured, then ``|f_measured| <=
max_force`` on its measurement; a value exactly at a limit passes. They come from the bridge's
ROS parameter file (``pd_actuator_bridge/config/bridge.yaml``: ``/**: ros__parameters: {...}``,
0 = off for ``max_velocity`` and ``step_duration``), then the test file's ``bridge`` mapping,
then explicit overrides (command line).

:func:`trips` says which limits a run exceeds anywhere (its whole demand, for study);
:func:`first_holds` the step at which the bridge would hold it (the first command or
measurement beyond a limit, in the bridge's order), with the bridge's message, as ``./pd
offline`` and ``./pd run`` hold there.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from pd_common.config import read_yaml_file, yaml_problem
from pd_common.errors import BridgeConfigError
from pd_common.experimental.limits import (
    SafetyLimits,
    bridge_parameters,
    check_command,
    check_feedback,
)
from pd_common.protocol import FeedbackStatus
from pd_common.types import FloatArray

from .errors import PretestError

__all__ = ['LIMIT_NAMES', 'BridgeLimits', 'Hold', 'first_holds', 'read_bridge_limits', 'trips']

#: The limits checked, in the bridge's order (a command's, then the measured force's).
LIMIT_NAMES = ('max_displacement', 'max_increment', 'max_velocity', 'max_force')
_REQUIRED = ('max_displacement', 'max_increment', 'max_force')
_OPTIONAL = ('max_velocity', 'step_duration')


@dataclass(frozen=True)
class BridgeLimits:
    """The bridge's limits (``None``: off).

    Attributes:
        max_displacement: largest ``|x|`` [m].
        max_increment: largest ``|Δx|`` per step [m].
        max_force: largest ``|f|`` [N].
        max_velocity: largest ``|Δx| / step_duration`` [m/s], or ``None``.
        step_duration: time the actuator takes for one step [s], or ``None``.
        source: where they came from (for the report).
    """

    max_displacement: float
    max_increment: float
    max_force: float
    max_velocity: float | None = None
    step_duration: float | None = None
    source: str = ''

    def value(self, name: str) -> float | None:
        """The limit ``name`` of :data:`LIMIT_NAMES` (``None``: not checked)."""
        if name == 'max_velocity':
            return self.max_velocity if self.step_duration is not None else None
        number: float = getattr(self, name)
        return number

    @property
    def safety(self) -> SafetyLimits:
        """The same limits as the bridge's :class:`~pd_common.experimental.SafetyLimits`.

        The velocity limit only with a step duration, as :meth:`value`.
        """
        velocity = self.max_velocity if self.step_duration is not None else None
        return SafetyLimits(max_displacement=self.max_displacement,
                            max_increment=self.max_increment, max_force=self.max_force,
                            max_velocity=velocity, step_duration=self.step_duration)


def _parameters(raw: Any, source: str) -> Mapping[str, Any]:
    """The ``ros__parameters`` mapping of a ROS parameter file (or a plain mapping).

    Found as the bridge's rehearsals find it (:func:`~pd_common.experimental.bridge_parameters`).
    """
    try:
        return bridge_parameters(raw, source)
    except BridgeConfigError as err:
        raise PretestError(str(err)) from None


def _number(value: Any, where: str, *, zero_off: bool) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(
            float(value)) or float(value) < 0.0 or (float(value) == 0.0 and not zero_off):
        what = 'a number >= 0 (0 = off)' if zero_off else 'a positive number'
        msg = f'{where}: must be {what}, got {value!r}'
        raise PretestError(msg)
    number = float(value)
    return None if number == 0.0 else number


def read_bridge_limits(path: str | Path, *layers: tuple[Mapping[str, Any] | None, str]
                       ) -> BridgeLimits:
    """The bridge's limits: its parameter file, then each ``(mapping, source)`` override.

    Keys other than the limits (``driver``, ``on_limit``, ...) are ignored.

    Raises:
        PretestError: the file cannot be read, a limit is missing or not a valid number.
    """
    path = Path(path)
    try:
        raw = read_yaml_file(path, what='a parameter file')
    except OSError as err:
        msg = f'{path}: cannot read the bridge parameters ({err.strerror})'
        raise PretestError(msg) from None
    except yaml.YAMLError as err:
        msg = f'{path}: not a YAML file ({yaml_problem(err)})'
        raise PretestError(msg) from None
    values: dict[str, tuple[Any, str]] = {
        key: (value, f'{path.name}: {key}') for key, value in _parameters(raw, path.name).items()}
    sources = [path.name]
    for mapping, where in layers:
        if mapping is None:
            continue
        if not isinstance(mapping, Mapping):
            msg = f'{where}: must be a mapping of bridge parameters'
            raise PretestError(msg)
        sources.append(where)
        values.update({key: (value, f'{where}.{key}') for key, value in mapping.items()})
    limits: dict[str, float | None] = {}
    for key in _REQUIRED + _OPTIONAL:
        if key not in values:
            if key in _REQUIRED:
                msg = f'{path}: {key}: missing (a bridge limit)'
                raise PretestError(msg)
            limits[key] = None
            continue
        value, where = values[key]
        limits[key] = _number(value, where, zero_off=key in _OPTIONAL)
    required = {key: limits[key] for key in _REQUIRED}
    assert all(value is not None for value in required.values())
    return BridgeLimits(max_displacement=float(required['max_displacement'] or 0.0),
                        max_increment=float(required['max_increment'] or 0.0),
                        max_force=float(required['max_force'] or 0.0),
                        max_velocity=limits['max_velocity'],
                        step_duration=limits['step_duration'],
                        source=' + '.join(sources))


def trips(limits: BridgeLimits, *, peak_displacement: FloatArray, max_increment: FloatArray,
          peak_force: FloatArray) -> dict[str, np.ndarray]:
    """Per limit of :data:`LIMIT_NAMES`, which runs exceed it (a value at the limit passes).

    Limits that are off give all ``False``.
    """
    off = np.zeros(peak_displacement.shape, dtype=bool)
    result = {
        'max_displacement': peak_displacement > limits.max_displacement,
        'max_increment': max_increment > limits.max_increment,
        'max_velocity': off.copy(),
        'max_force': peak_force > limits.max_force,
    }
    if limits.max_velocity is not None and limits.step_duration is not None:
        result['max_velocity'] = max_increment / limits.step_duration > limits.max_velocity
    return result


@dataclass(frozen=True)
class Hold:
    """Where the bridge would hold a run.

    Attributes:
        step: the step whose command (or measurement) is beyond a limit.
        limit: the limit of :data:`LIMIT_NAMES`.
        message: the bridge's message, word for word.
    """

    step: int
    limit: str
    message: str


def first_holds(limits: BridgeLimits, displacement: FloatArray, force: FloatArray,
                dof_name: str) -> list[Hold | None]:
    """Per run, the first step at which the bridge would hold it (``None``: none).

    Args:
        limits: the bridge's limits.
        displacement: the commanded (= measured: a simulated specimen) displacement of each
            step, shape ``(n_steps + 1, n_runs)``; step 0 is commanded from the specimen at 0.
        force: the measured force of each step, the same shape.
        dof_name: the actuator's name (the bridge's messages name it).

    The candidates are found for every run at once (the bridge's comparisons on the same
    floats); the step found is then checked with the bridge's own
    :func:`~pd_common.experimental.limits.check_command` and
    :func:`~pd_common.experimental.limits.check_feedback`, which give the limit and the
    message. A non-finite command is no hold: the session fails that step before sending it.
    """
    safety = limits.safety
    x = np.asarray(displacement, dtype=float)
    f = np.asarray(force, dtype=float)
    previous = np.zeros_like(x)
    previous[1:] = x[:-1]
    with np.errstate(invalid='ignore'):
        increment = np.abs(x - previous)
        beyond = ((np.abs(x) > safety.max_displacement) | (increment > safety.max_increment)
                  | (np.abs(f) > safety.max_force))
        if safety.max_velocity is not None and safety.step_duration is not None:
            beyond |= increment / safety.step_duration > safety.max_velocity
    names = [dof_name]
    holds: list[Hold | None] = []
    for run in range(x.shape[1]):
        steps = np.flatnonzero(beyond[:, run])
        hold = None
        if steps.size:
            step = int(steps[0])
            target, current = float(x[step, run]), float(previous[step, run])
            violation = check_command([target], [current], safety, names)
            if violation is None:
                violation = check_feedback([target], [float(f[step, run])], safety, names)
            if violation is not None and violation.kind is FeedbackStatus.LIMIT:
                hold = Hold(step=step, limit=violation.limit, message=violation.message)
        holds.append(hold)
    return holds
