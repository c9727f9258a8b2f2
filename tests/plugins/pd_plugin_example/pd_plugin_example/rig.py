"""The actuator driver ``spring_rig``: an in-process rig whose specimen is a linear spring.

It moves exactly to each target and measures ``f = spring_stiffness · x`` at once. A lab's
driver for its controller has the same shape: a class implementing
:class:`~pd_actuator_bridge.core.ActuatorDriver` and one :class:`DriverSpec` naming its
parameters (each one a ROS parameter of the bridge node).
"""

from __future__ import annotations

from collections.abc import Sequence

from pd_actuator_bridge.core import (
    ActuatorDriver,
    ActuatorMeasurement,
    DriverContext,
    DriverError,
    DriverParameter,
    DriverSpec,
    StepId,
)


class SpringRigDriver(ActuatorDriver):
    """``n_dof`` actuators, each on a spring of stiffness ``stiffness`` (N/m)."""

    def __init__(self, n_dof: int, stiffness: float) -> None:
        """Create the rig at rest."""
        super().__init__()
        self._n_dof = n_dof
        self.stiffness = stiffness
        self._position = [0.0] * n_dof

    @property
    def n_dof(self) -> int:
        """Number of actuators."""
        return self._n_dof

    def command(self, step: StepId, target: Sequence[float]) -> None:
        """Move to ``target`` (m) and report the spring forces (N)."""
        values = tuple(float(x) for x in target)
        if len(values) != self._n_dof:
            msg = f'spring_rig: target has {len(values)} values, expected {self._n_dof}'
            raise DriverError(msg)
        self._position = list(values)
        force = tuple(self.stiffness * x for x in values)
        self._emit(ActuatorMeasurement(step, values, force))

    def hold(self) -> None:
        """A spring rig is at rest between commands."""

    def position(self) -> list[float]:
        """The displacement per actuator, m."""
        return list(self._position)


def make_spring_rig(context: DriverContext) -> SpringRigDriver:
    """The factory: the rig for ``context.n_dof`` actuators."""
    return SpringRigDriver(context.n_dof, float(context.parameters['spring_stiffness']))


SPRING_RIG = DriverSpec(
    name='spring_rig',
    factory=make_spring_rig,
    parameters=(DriverParameter('spring_stiffness', 312559.0,
                                'stiffness of the rig\'s spring, N/m'),),
    description='in-process rig on a linear spring (example plug-in)',
)
