"""Per-actuator control of an experimental element: displacement (default) or force.

An experimental element's ``control`` mapping names some of its actuators::

    control:
      vertical: {mode: force, force: 24950.0}              # N, held the whole test
      # vertical: {mode: force, force: [[0.0, 0.0], [2.0, 24950.0]]}  # [t, F]: linear in
      #                                       # test time, held before the first / after the last
      horizontal: {mode: displacement}                     # the default

A force-controlled actuator holds ``F(t)`` of the step's test time (e.g. a column's axial
load) and its stroke is whatever the specimen takes: measured, never imposed. Each basic DOF
of the element whose ``dofs`` entry is ``null`` is then *free*: its displacement comes from
the measurement. An element needs exactly one force-controlled actuator per ``null`` entry.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pd_common.config.schema_test_file import ControlSpec
from pd_common.protocol import ControlMode

from ..errors import ConfigError

__all__ = ['CONTROL_MODES', 'ActuatorControl', 'parse_control']

#: ``control.<actuator>.mode`` values.
CONTROL_MODES = ('displacement', 'force')


@dataclass(frozen=True)
class ActuatorControl:
    """How one actuator is driven.

    Attributes:
        mode: :class:`ControlMode` (displacement or force).
        times: [s] the force table's test times (one point for a constant force).
        forces: [N] the force at each of ``times`` (positive: the actuator pushes the body
            along its stroke's increasing direction).
    """

    mode: ControlMode = ControlMode.DISPLACEMENT
    times: tuple[float, ...] = ()
    forces: tuple[float, ...] = ()

    @property
    def force_controlled(self) -> bool:
        """Whether the actuator holds a force."""
        return self.mode is ControlMode.FORCE

    def force_at(self, time: float) -> float:
        """``F(t)`` [N]: linear between the table's points, held outside them (0: no force)."""
        if not self.forces:
            return 0.0
        if len(self.forces) == 1 or time <= self.times[0]:
            return self.forces[0]
        if time >= self.times[-1]:
            return self.forces[-1]
        return float(np.interp(time, self.times, self.forces))

    def describe(self) -> dict[str, Any]:
        """For ``summary.json``: the mode and the force table."""
        if not self.force_controlled:
            return {'mode': 'displacement'}
        return {'mode': 'force', 'force': [[t, f] for t, f in zip(self.times, self.forces)]}


DISPLACEMENT_CONTROL = ActuatorControl()


def _force_table(value: float | list[list[float]], where: str
                 ) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """A constant force, or a table ``[[t, F], ...]``, as ``(times, forces)``.

    The table's numbers are finite by the schema; its times must increase.
    """
    if isinstance(value, float):
        return (0.0,), (value,)
    if not value:
        msg = (f'{where}: must be a number [N] or a table [[t, F], ...] (s, N) with increasing '
               f'times, got {value!r}')
        raise ConfigError(msg)
    times: list[float] = []
    forces: list[float] = []
    for index, row in enumerate(value):
        if len(row) != 2:
            msg = f'{where}.{index}: must be a pair [t, F] (s, N), got {row!r}'
            raise ConfigError(msg)
        if times and row[0] <= times[-1]:
            msg = f'{where}.{index}: times must increase, got {row[0]:g} s after {times[-1]:g} s'
            raise ConfigError(msg)
        times.append(row[0])
        forces.append(row[1])
    return tuple(times), tuple(forces)


def parse_control(control: Mapping[str, ControlSpec | None] | None, actuators: Sequence[str],
                  where: str) -> tuple[ActuatorControl, ...]:
    """One :class:`ActuatorControl` per actuator of ``actuators`` (missing: displacement).

    Args:
        control: the element's ``control`` (typed by the schema; ``None``: every actuator
            displacement-controlled).
        actuators: the element's actuator names, in order.
        where: the parameter path for messages (``file: structure.elements.0.control``).

    Raises:
        ConfigError: one line naming ``where`` and the key.
    """
    if control is None:
        return (DISPLACEMENT_CONTROL,) * len(actuators)
    unknown = sorted(name for name in control if name not in actuators)
    if unknown:
        msg = (f'{where}.{unknown[0]}: not an actuator of this element (actuators: '
               f'{", ".join(actuators)})')
        raise ConfigError(msg)
    controls = []
    for name in actuators:
        spec = control.get(name)
        here = f'{where}.{name}'
        if spec is None or spec.mode == 'displacement':
            if spec is not None and 'force' in spec.model_fields_set:
                msg = f'{here}.force: unknown parameter for displacement control'
                raise ConfigError(msg)
            controls.append(DISPLACEMENT_CONTROL)
            continue
        if spec.force is None:
            msg = f'{here}.force: is required for force control (N, or a table [[t, F], ...])'
            raise ConfigError(msg)
        times, forces = _force_table(spec.force, f'{here}.force')
        controls.append(ActuatorControl(ControlMode.FORCE, times, forces))
    return tuple(controls)
