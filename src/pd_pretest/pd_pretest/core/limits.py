"""The actuator bridge's safety limits, read from its parameter file, which runs trip them.

And the step at which the bridge would hold each of them.

The limits are those the bridge enforces, checked by the bridge's own functions
(:mod:`pd_common.experimental.limits`): ``|x_target| <= max_displacement``, ``|x_target −
x_current| <= max_increment``, ``|x_target − x_current| / step_duration <= max_velocity`` (only
with both set) on each command, from the position last measured, then ``|f_measured| <=
max_force`` on its measurement; a value exactly at a limit passes. They come from the bridge's
ROS parameter file (``pd_actuator_bridge/config/bridge.yaml``: ``/**: ros__parameters: {...}``,
0 = off for ``max_velocity`` and ``step_duration``), read through its schema as ``./pd run``
reads it, then explicit overrides (command line), checked by the same schema; a parameter
set nowhere is the bridge node's default, and the limits together are checked as the bridge
checks them when it configures (:meth:`~pd_common.experimental.SafetyLimits.from_mapping`).

:func:`trips` says which limits a run exceeds anywhere (its whole demand, for study);
:func:`first_holds` the step at which the bridge would hold it (the first command or
measurement beyond a limit, in the bridge's order), with the bridge's message, as ``./pd
offline`` and ``./pd run`` hold there.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pd_common.config import SchemaError, read_bridge_parameter_file, validate_model
from pd_common.config.schema_bridge import SiteBridgeParameters
from pd_common.errors import BridgeConfigError
from pd_common.experimental.limits import (
    SafetyLimits,
    check_command,
    check_feedback,
    limits_from_parameters,
)
from pd_common.protocol import FeedbackStatus
from pd_common.types import FloatArray

from .errors import PretestError

__all__ = ['LIMIT_NAMES', 'BridgeLimits', 'Hold', 'first_holds', 'read_bridge_limits', 'trips']

#: The limits checked, in the bridge's order (a command's, then the measured force's).
LIMIT_NAMES = ('max_displacement', 'max_increment', 'max_velocity', 'max_force')


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


def read_bridge_limits(path: str | Path, *layers: tuple[Mapping[str, Any] | None, str]
                       ) -> BridgeLimits:
    """The bridge's limits: its parameter file, then each ``(mapping, source)`` override.

    The file is read through its schema (:func:`pd_common.config.read_bridge_parameter_file`)
    and each override through the schema of a site's bridge parameters; a limit set nowhere is
    the node's default; the limits together are checked as the bridge checks them. Parameters
    other than the limits (``driver``, ``on_limit``, ...) are read but not used here.

    Raises:
        PretestError: one line naming the file (or the override) and the parameter.
    """
    path = Path(path)
    sources = [path.name]
    try:
        parameters = read_bridge_parameter_file(path).parameters()
        for mapping, where in layers:
            if mapping is None:
                continue
            layer = validate_model(SiteBridgeParameters, mapping, where)
            parameters.update(layer.model_dump(exclude_unset=True))
            sources.append(where)
        source = ' + '.join(sources)
        safety = limits_from_parameters(parameters, source)
    except (SchemaError, BridgeConfigError) as err:
        raise PretestError(str(err)) from None
    return BridgeLimits(max_displacement=safety.max_displacement,
                        max_increment=safety.max_increment, max_force=safety.max_force,
                        max_velocity=safety.max_velocity, step_duration=safety.step_duration,
                        source=source)


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
