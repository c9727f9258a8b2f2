"""The actuator driver interface: one driver per controller family (OpenFresco's expControl).

A driver moves the actuator and reports what it measured, one :class:`ActuatorMeasurement`
per step (OpenFresco's ``getDaqResponse``). It is asynchronous-friendly: a real controller (or
the simulated servo) answers later through the measurement callback, while a synchronous
driver calls the callback before :meth:`ActuatorDriver.command` returns.

The node shell drives every driver through the same neutral hooks (:meth:`~ActuatorDriver.ready`,
:meth:`~ActuatorDriver.poll`, :meth:`~ActuatorDriver.waiting_since`, ...), whose defaults
suit a synchronous driver; it never names a driver class.

Drivers perform no safety checks of their own: the :class:`~..bridge.ActuatorBridge` calls
:meth:`ActuatorDriver.command` only with targets that passed its limits. A new driver is one
module with its class and one :class:`~.registry.DriverSpec` registered with
:func:`~.registry.register_driver` (see :mod:`.registry`).
"""

from __future__ import annotations

import abc
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypeAlias

from pd_common.protocol import StateOrigin

from ..errors import BridgeConfigError, DriverError

StepId: TypeAlias = int | tuple[int, ...]
"""A step as the bridge and the drivers see it: an ``int`` or a key such as
:class:`pd_common.protocol.StepKey` ``(step, iteration)``, compared by equality and order only."""



@dataclass(frozen=True)
class ActuatorMeasurement:
    """What a driver measured for one step: OpenFresco's ``getDaqResponse`` (the DAQ side).

    The values are the driver's as read (the bridge checks them: a malformed or non-finite
    value is a FAULT there, not here).

    Attributes:
        step: The step (or force sub-step) the measurement answers.
        displacement: Measured displacement per DOF, m.
        force: Measured force per DOF, N.
        time: The controller's time of the reading, s, if it reports one (``None``: not known).
    """

    step: StepId
    displacement: tuple[float, ...]
    force: tuple[float, ...]
    time: float | None = None


MeasurementCallback = Callable[[ActuatorMeasurement], None]
"""``cb(measurement)``: receives every :class:`ActuatorMeasurement` a driver reports."""


class ActuatorDriver(abc.ABC):
    """Interface between the bridge and one actuator controller.

    The operations, with the names OpenFresco's ``ExperimentalControl`` gives them:

    * :meth:`open` — ``setup()``: connect and learn the current state; never moves anything.
    * :meth:`command` — ``setTrialResponse()`` followed by ``getDaqResponse()``: move to the
      trial displacement and report the measured displacement and force through the
      measurement callback (before returning, or later for an asynchronous driver).
    * :meth:`position` — the displacement part of the last ``getDaqResponse()``.
    * :meth:`hold` — no OpenFresco counterpart: stop and keep the current position.
    * :meth:`close` — the destructor (GenericTCP's ``DIE``, 99).
    * ``commitState()`` has no counterpart: the bridge keeps no committed state in the driver
      (OpenFresco's GenericTCP client sends nothing on commit either).
    * :meth:`command_force` — one sub-step of a mixed (force/displacement) command. Only a
      driver whose :meth:`force_control_problem` is ``None`` takes it; the others refuse
      force control (the bridge answers such a command with a one-line FAULT, nothing moves).
      See ``docs/force_control.md``.

    The hooks of the node shell, with defaults that suit a synchronous driver (one answering
    inside :meth:`command`): :meth:`ready` (``True``), :meth:`waiting_for`, :meth:`poll`
    (nothing), :meth:`set_test_id` (ignored), :meth:`repeat` (nothing),
    :meth:`waiting_since` (``None``), :attr:`last_force` (``None``), :attr:`carried_force`
    (:attr:`last_force`) and :meth:`refusals` (none). An asynchronous driver overrides the
    ones it needs.
    """

    #: The registered name of the driver (``driver`` parameter), for messages ('': the
    #: class name).
    driver_name = ''

    def __init__(self) -> None:
        """Create the driver with no measurement callback."""
        self._measurement_callback: MeasurementCallback | None = None

    @property
    def state_origin(self) -> StateOrigin:
        """Where the specimen state the driver drives comes from.

        The controller's hardware (the default), or a simulated specimen (``FRESH`` when it cannot
        be restored).
        """
        return StateOrigin.HARDWARE

    @property
    def state_epoch(self) -> str | None:
        """The epoch of the specimen state behind the driver, if it has its own (a simulator node).

        ``None``: the bridge's own epoch.
        """
        return None

    @property
    @abc.abstractmethod
    def n_dof(self) -> int:
        """Number of actuated DOF."""

    def open(self) -> None:
        """Connect to the controller (OpenFresco ``setup``). The default does nothing."""

    # -- hooks of the node shell (defaults: a synchronous driver) ------------------------------

    def ready(self) -> bool:
        """Whether the driver can take commands now (the node offers a session only then).

        Called by the node's loop until it is ``True``; it may do the work of getting ready
        (open a session with a remote side). The default: ``True``.
        """
        return True

    def waiting_for(self) -> str:
        """What :meth:`ready` waits for, for the log (e.g. ``'the specimen node on ...'``)."""
        return 'the driver'

    def poll(self) -> None:
        """Keep the driver's connection alive.

        Called by the node's loop while the bridge is configured (every 10 to 60 ms). The
        default does nothing.
        """

    def set_test_id(self, test_id: str) -> None:
        """Take the (run-tagged) test id of the commands that follow, before the bridge sees them.

        A driver that forwards moves to a keyed receiver keys them by it. The default ignores it.
        """

    def repeat(self) -> None:
        """The step in flight was commanded again (a re-sent command).

        Ask the controller again, without a new motion. The default does nothing (nothing is in
        flight between calls of a synchronous driver).
        """

    def waiting_since(self) -> float | None:
        """``time.monotonic()`` when the move in flight was last sent.

        Or ``None`` if no move waits for its measurement (the default). The node holds when it is
        older than the ``driver_timeout`` parameter.
        """
        return None

    @property
    def last_force(self) -> list[float] | None:
        """Force per DOF of the last measurement, N.

        ``None`` (the default) if the driver does not know it: the node then offers 0 N.
        """
        return None

    @property
    def carried_force(self) -> list[float] | None:
        """The force per DOF the actuators carry when the driver becomes ready, N.

        ``None``: not known. A restarted bridge ramps force from it, never from 0 N. The
        default: :attr:`last_force`.
        """
        return self.last_force

    def refusals(self) -> dict[str, dict[str, int]]:
        """Messages the driver refused by authentication.

        By source and reason (none by default).
        """
        return {}

    def close(self) -> None:
        """Disconnect from the controller. The default does nothing."""

    @abc.abstractmethod
    def command(self, step: StepId, target: Sequence[float]) -> None:
        """Start moving to ``target`` (m, one value per DOF) for ``step``.

        OpenFresco's ``setTrialResponse`` and ``getDaqResponse`` in one call: the measurement is
        reported through the callback, later or (synchronous drivers) before this method
        returns.

        Raises:
            DriverError: If the command cannot be executed.
        """

    def force_control_problem(self) -> str | None:
        """Why this driver cannot drive force-controlled actuators (``None``: it can).

        The default: it cannot. A driver that can overrides this and :meth:`command_force`.
        """
        return ('force control not supported; it would drive every actuator in displacement '
                '(use a driver with force control, see docs/force_control.md)')

    def command_force(self, step: StepId, target: Sequence[float],
                      control_mode: Sequence[int], target_force: Sequence[float]) -> None:
        """Start one sub-step of a mixed command.

        The bridge calls it once per force ramp sub-step, each with its own ``step``: the
        integrator's key followed by the sub-step number, ``(*key, s)`` (``s`` = 0, 1, ...; a
        ramp-down at deactivation continues the numbering of the last mixed command), and
        waits for that sub-step's measurement (reported with the same ``step``) before the
        next.

        Args:
            step: The sub-step's id, ``(*key, s)``.
            target: Per DOF the displacement, m: imposed on a displacement-controlled DOF;
                for a force-controlled DOF the stroke last measured (not imposed).
            control_mode: Per DOF :class:`pd_common.protocol.ControlMode` (0 displacement,
                1 force).
            target_force: Per DOF the force a force-controlled DOF is to hold, N (0 for the
                displacement-controlled ones).

        Raises:
            DriverError: The driver does not support force control (the default) or cannot
                execute the sub-step.
        """
        problem = self.force_control_problem() or 'force control not supported'
        msg = f'driver {self.driver_name or type(self).__name__}: {problem}'
        raise DriverError(msg)

    @abc.abstractmethod
    def hold(self) -> None:
        """Stop and hold the current position."""

    @abc.abstractmethod
    def position(self) -> list[float]:
        """Return the last known displacement per DOF, m."""

    def set_measurement_callback(self, callback: MeasurementCallback | None) -> None:
        """Set (or clear with ``None``) the function that receives each measurement."""
        self._measurement_callback = callback

    def _emit(self, measurement: ActuatorMeasurement) -> None:
        """Deliver a measurement to the callback, if one is set."""
        if self._measurement_callback is not None:
            self._measurement_callback(measurement)


#: Specimen-side iterations per integrator iteration in :func:`force_substep_key`.
SUBSTEP_STRIDE = 65536
#: The largest integrator iteration :func:`force_substep_key` can carry (uint32 iterations).
MAX_MIXED_ITERATION = (2**32 - 1) // SUBSTEP_STRIDE - 1


def force_substep_key(step: StepId) -> tuple[int, int]:
    """The ``(step, iteration)`` key of force sub-step ``step = (*key, s)`` for a specimen.

    Sub-step ``s`` of the integrator's ``(step, iteration)`` (or of ``step``: iteration 0) is
    ``(step, iteration * SUBSTEP_STRIDE + s)``: a new key per sub-step, in order, after every
    sub-step of the earlier iterations and steps and before the later ones (a ramp-down
    continues the numbering). A specimen that answers a repeat of its last key and ignores
    older ones (:class:`pd_common.specimen.SpecimenServer`) so sees every sub-step as a new
    command.

    Raises:
        DriverError: ``s`` or the iteration is beyond what the scheme carries.
    """
    values = [int(value) for value in step] if isinstance(step, tuple) else [int(step)]
    *key, sub = values
    number = key[0] if key else 0
    iteration = key[1] if len(key) > 1 else 0
    if not 0 <= sub < SUBSTEP_STRIDE or not 0 <= iteration <= MAX_MIXED_ITERATION:
        msg = (f'cannot key force sub-step {sub} of step {number} iteration {iteration} for '
               f'the specimen (at most {SUBSTEP_STRIDE} sub-steps and iteration '
               f'{MAX_MIXED_ITERATION})')
        raise DriverError(msg)
    return number, iteration * SUBSTEP_STRIDE + sub


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
            msg = f'{name}: n_dof must be a positive integer, got {n_dof!r}'
            raise BridgeConfigError(msg)
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
    def _exchange(self, step: StepId, target: list[float]) -> tuple[list[float], list[float]]:
        """Send the trial displacement; return the measured ``(displacement, force)``."""

    def command(self, step: StepId, target: Sequence[float]) -> None:
        """Send ``target`` as the trial displacement, read the response and report it.

        Raises:
            DriverError: If the driver is not open or the target is malformed.
            error_type: On any communication failure (recorded in :attr:`fault`).
        """
        values = [float(x) for x in target]
        if len(values) != self._n_dof:
            msg = (
                f'{self._name} {self.address}: target has {len(values)} values, '
                              f'expected {self._n_dof}'
            )
            raise DriverError(msg)
        if not all(math.isfinite(value) for value in values):
            msg = (
                f'{self._name} {self.address}: refusing a non-finite target '
                              f'{values} at step {step}'
            )
            raise DriverError(msg)
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
        self._emit(ActuatorMeasurement(step, tuple(self._position), tuple(self._force)))

    def hold(self) -> None:
        """Hold: send nothing, so the remote side keeps its last command."""
        self.hold_count += 1

    def position(self) -> list[float]:
        """Last measured displacement per DOF, m (NaN before :meth:`open`)."""
        return list(self._position)

    def _store(self, displacement: Sequence[float], force: Sequence[float]) -> None:
        """Keep a measurement as the last position and force."""
        self._position = [float(x) for x in displacement]
        self._force = [float(f) for f in force]
