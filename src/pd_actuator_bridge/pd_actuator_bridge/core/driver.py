"""Actuator drivers: one per controller family (like OpenFresco's ExperimentalControl).

A driver moves the actuator and reports what it measured. It is asynchronous-friendly: a real
controller (or the simulated servo) answers later through the measurement callback, while a
synchronous driver calls the callback before :meth:`ActuatorDriver.command` returns.

Drivers perform no safety checks of their own: the :class:`~.bridge.ActuatorBridge` calls
:meth:`ActuatorDriver.command` only with targets that passed its limits.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Callable, Sequence

from .errors import BridgeConfigError, DriverError

MeasurementCallback = Callable[[int, list[float], list[float]], None]
"""``cb(step, displacement, force)``: displacement in m and force in N, one value per DOF."""


class ActuatorDriver(abc.ABC):
    """Interface between the bridge and one actuator controller."""

    def __init__(self) -> None:
        """Create the driver with no measurement callback."""
        self._measurement_callback: MeasurementCallback | None = None

    @property
    @abc.abstractmethod
    def n_dof(self) -> int:
        """Number of actuated DOF."""

    def open(self) -> None:  # noqa: B027 - optional hook
        """Connect to the controller. The default does nothing."""

    def close(self) -> None:  # noqa: B027 - optional hook
        """Disconnect from the controller. The default does nothing."""

    @abc.abstractmethod
    def command(self, step: int, target: Sequence[float]) -> None:
        """Start moving to ``target`` (m, one value per DOF) for ``step``.

        The measurement is reported through the callback, later or (synchronous drivers) before
        this method returns.

        Raises:
            DriverError: If the command cannot be executed.
        """

    @abc.abstractmethod
    def hold(self) -> None:
        """Stop and hold the current position."""

    @abc.abstractmethod
    def position(self) -> list[float]:
        """Return the last known displacement per DOF, m."""

    def set_measurement_callback(self, callback: MeasurementCallback | None) -> None:
        """Set (or clear with ``None``) the function that receives each measurement."""
        self._measurement_callback = callback

    def _emit(self, step: int, displacement: list[float], force: list[float]) -> None:
        """Deliver a measurement to the callback, if one is set."""
        if self._measurement_callback is not None:
            self._measurement_callback(step, displacement, force)


class RemoteDriver(ActuatorDriver):
    """A synchronous driver of a remote controller reached over a connection (TCP).

    Shared by the OpenFresco GenericTCP and the OpenSees adapter drivers: target validation,
    the exchange of one step, the last measurement, holding (send nothing: the controller keeps
    its last command) and the fault bookkeeping. Subclasses implement :meth:`_exchange`,
    :attr:`connected` and :attr:`address` (and ``open``/``close``).

    Attributes:
        hold_count: Number of :meth:`hold` calls.
        fault: The last communication failure message ('' if none).
    """

    #: The subclass's communication error (recorded in :attr:`fault`, then re-raised).
    error_type: type[DriverError] = DriverError

    def __init__(self, n_dof: int, name: str) -> None:
        """Create the driver state for ``n_dof`` DOF (``name`` for messages).

        Raises:
            BridgeConfigError: ``n_dof`` is not a positive integer.
        """
        super().__init__()
        if isinstance(n_dof, bool) or not isinstance(n_dof, int) or n_dof < 1:
            raise BridgeConfigError(f'{name}: n_dof must be a positive integer, got {n_dof!r}')
        self._n_dof = n_dof
        self._name = name
        self._position: list[float] = [math.nan] * n_dof
        self._force: list[float] = [math.nan] * n_dof
        self.hold_count = 0
        self.fault = ''

    @property
    def n_dof(self) -> int:
        """Number of DOF."""
        return self._n_dof

    @property
    @abc.abstractmethod
    def connected(self) -> bool:
        """Whether the connection is open."""

    @property
    @abc.abstractmethod
    def address(self) -> str:
        """``host:port`` of the remote side."""

    @property
    def is_open(self) -> bool:
        """Whether the connection is open."""
        return self.connected

    @property
    def last_force(self) -> list[float]:
        """Force per DOF of the last measurement, N (NaN before the first)."""
        return list(self._force)

    @abc.abstractmethod
    def _exchange(self, step: int, target: list[float]) -> tuple[list[float], list[float]]:
        """Send the trial displacement; return the measured ``(displacement, force)``."""

    def command(self, step: int, target: Sequence[float]) -> None:
        """Send ``target`` as the trial displacement, read the response and report it.

        Raises:
            DriverError: If the driver is not open or the target is malformed.
            error_type: On any communication failure (recorded in :attr:`fault`).
        """
        values = [float(x) for x in target]
        if len(values) != self._n_dof:
            raise DriverError(f'{self._name} {self.address}: target has {len(values)} values, '
                              f'expected {self._n_dof}')
        if not all(math.isfinite(value) for value in values):
            raise DriverError(f'{self._name} {self.address}: refusing a non-finite target '
                              f'{values} at step {step}')
        if not self.connected:
            raise DriverError(
                f'{self._name} {self.address}: command() at step {step} while not connected'
                + (f' (last fault: {self.fault})' if self.fault else ''))
        try:
            displacement, force = self._exchange(step, values)
        except self.error_type as exc:
            self.fault = str(exc)
            raise
        self._store(displacement, force)
        self._emit(step, list(self._position), list(self._force))

    def hold(self) -> None:
        """Hold: send nothing, so the remote side keeps its last command."""
        self.hold_count += 1

    def position(self) -> list[float]:
        """Last measured displacement per DOF, m (NaN before :meth:`open`)."""
        return list(self._position)

    def _store(self, displacement: Sequence[float], force: Sequence[float]) -> None:
        self._position = [float(x) for x in displacement]
        self._force = [float(f) for f in force]


class LoopbackDriver(ActuatorDriver):
    """Synchronous in-process driver for tests and ROS-free use.

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
            raise BridgeConfigError(
                f'LoopbackDriver: n_dof must be a positive integer, got {n_dof!r}'
            )
        if not callable(restoring_force):
            raise BridgeConfigError('LoopbackDriver: restoring_force must be callable')
        if initial_position is None:
            position = [0.0] * n_dof
        else:
            position = [float(x) for x in initial_position]
        if len(position) != n_dof:
            raise BridgeConfigError(
                f'LoopbackDriver: initial_position has {len(position)} values, expected {n_dof}'
            )
        self._restoring_force = restoring_force
        self._n_dof = n_dof
        self._position = position
        self.commands: list[tuple[int, tuple[float, ...]]] = []
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

    def command(self, step: int, target: Sequence[float]) -> None:
        """Move exactly to ``target`` and report the restoring force immediately.

        Raises:
            DriverError: If the driver is not open, the target has the wrong length or the
                restoring force cannot be computed.
        """
        values = tuple(float(x) for x in target)
        self.commands.append((step, values))
        if not self.is_open:
            raise DriverError('LoopbackDriver: command() called before open()')
        if len(values) != self._n_dof:
            raise DriverError(
                f'LoopbackDriver: target has {len(values)} values, expected {self._n_dof}'
            )
        self._position = list(values)
        try:
            force = [float(f) for f in self._restoring_force(list(values))]
        except Exception as exc:  # noqa: BLE001 - any model failure is a driver failure
            raise DriverError(
                f'LoopbackDriver: restoring_force failed at step {step}: '
                f'{type(exc).__name__}: {exc}'
            ) from exc
        self._emit(step, list(self._position), force)

    def hold(self) -> None:
        """Hold position (a loopback actuator is always at rest between commands)."""
        self.hold_count += 1

    def position(self) -> list[float]:
        """Return the current displacement per DOF, m."""
        return list(self._position)
