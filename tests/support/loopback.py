"""A synchronous in-process actuator driver for the bridge tests (not part of any package)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from pd_actuator_bridge.core import (
    ActuatorDriver,
    ActuatorMeasurement,
    BridgeConfigError,
    DriverError,
    StepId,
)


class LoopbackDriver(ActuatorDriver):
    """Synchronous in-process driver for tests.

    It moves exactly to the target and answers inside :meth:`command` with the force returned by
    ``restoring_force`` (e.g. a specimen model).

    Attributes:
        commands: Every ``(step, target)`` received by :meth:`command`, in order.
        hold_count: Number of :meth:`hold` calls.
        is_open: Whether :meth:`open` was called (and :meth:`close` not since).
    """

    def __init__(
        self,
        restoring_force: Callable[[list[float]], Sequence[float]],
        n_dof: int = 1,
        initial_position: Sequence[float] | None = None,
    ) -> None:
        """Create the driver.

        Args:
            restoring_force: Maps a displacement per DOF (m) to a force per DOF (N).
            n_dof: Number of DOF.
            initial_position: Starting displacement per DOF, m; zeros if omitted.

        Raises:
            BridgeConfigError: On a bad ``n_dof`` or ``initial_position``.
        """
        super().__init__()
        if isinstance(n_dof, bool) or not isinstance(n_dof, int) or n_dof < 1:
            msg = f'LoopbackDriver: n_dof must be a positive integer, got {n_dof!r}'
            raise BridgeConfigError(msg)
        if not callable(restoring_force):
            msg = 'LoopbackDriver: restoring_force must be callable'
            raise BridgeConfigError(msg)
        if initial_position is None:
            position = [0.0] * n_dof
        else:
            position = [float(x) for x in initial_position]
        if len(position) != n_dof:
            msg = (f'LoopbackDriver: initial_position has {len(position)} values, '
                   f'expected {n_dof}')
            raise BridgeConfigError(msg)
        self._restoring_force = restoring_force
        self._n_dof = n_dof
        self._position = position
        self.commands: list[tuple[StepId, tuple[float, ...]]] = []
        self.hold_count = 0
        self.is_open = False

    @property
    def n_dof(self) -> int:
        """Number of DOF."""
        return self._n_dof

    def open(self) -> None:
        """Mark the driver open."""
        self.is_open = True

    def close(self) -> None:
        """Mark the driver closed."""
        self.is_open = False

    def command(self, step: StepId, target: Sequence[float]) -> None:
        """Move exactly to ``target`` and report the restoring force immediately.

        Raises:
            DriverError: If the driver is not open, the target has the wrong length or the
                restoring force cannot be computed.
        """
        values = tuple(float(x) for x in target)
        self.commands.append((step, values))
        if not self.is_open:
            msg = 'LoopbackDriver: command() called before open()'
            raise DriverError(msg)
        if len(values) != self._n_dof:
            msg = f'LoopbackDriver: target has {len(values)} values, expected {self._n_dof}'
            raise DriverError(msg)
        self._position = list(values)
        try:
            force = [float(f) for f in self._restoring_force(list(values))]
        except Exception as exc:
            msg = (f'LoopbackDriver: restoring_force failed at step {step}: '
                   f'{type(exc).__name__}: {exc}')
            raise DriverError(msg) from exc
        self._emit(ActuatorMeasurement(step, tuple(self._position), tuple(force)))

    def hold(self) -> None:
        """Hold position (a loopback actuator is always at rest between commands)."""
        self.hold_count += 1

    def position(self) -> list[float]:
        """Return the current displacement per DOF, m."""
        return list(self._position)
