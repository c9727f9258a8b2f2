"""The controllers behind the GenericTCP controller-side server (:mod:`.controller_server`).

The server fronts a pluggable actuator controller (:class:`Controller`):

* :class:`ElasticController`: an ideal actuator that reaches every trial displacement exactly,
  on an elastic specimen ``f = k x``.
* :class:`EmulatorController`: an adapter to an actuator emulator backend;
  :func:`load_emulator_controller` builds one on the servo-hydraulic emulator of
  :mod:`pd_actuator_bridge.core.drivers.emulator`, each step executed by the core's
  ramp-and-hold executor (:class:`~pd_actuator_bridge.core.RampHoldExecutor`).

:func:`make_controller` returns the one the command-line options select (falling back to the
elastic controller when the emulator cannot be built). No ``rclpy``.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence
from typing import Any, Protocol

from pd_actuator_bridge.core.drivers.emulator import ServoHydraulicEmulator
from pd_actuator_bridge.core.drivers.generic_tcp_protocol import (
    RESPONSE_KINDS,
    DaqResponse,
    SizeID,
    TrialResponse,
)
from pd_actuator_bridge.core.drivers.ramp_hold import RampHoldExecutor, RampHoldParameters
from pd_actuator_bridge.core.errors import BridgeConfigError, BridgeError
from pd_common.specimen import Elastic, Specimen

# The server's logger: the controllers' messages are the executable's.
LOGGER = logging.getLogger('pd_actuator_bridge.controller_server')


class ControllerError(BridgeError):
    """The controller behind the server cannot serve the request (sizes, values, failure)."""


class EmulatorUnavailableError(BridgeError):
    """The servo-hydraulic emulator cannot be built."""


class Controller(Protocol):
    """What the server needs from the actuator controller it fronts."""

    def setup(self, size_id: SizeID) -> None:
        """Accept (or reject with :class:`ControllerError`) the client's size ID."""

    def set_trial_response(self, trial: TrialResponse) -> None:
        """Execute a trial (move the actuator)."""

    def get_daq_response(self) -> DaqResponse:
        """Return the measured response, one tuple per kind sized as the size ID says."""

    def commit_state(self) -> None:
        """Commit the current step (no-op for most controllers)."""


class _MeasuredController:
    """Common size checks and daq assembly for controllers measuring displacement and force."""

    name = 'controller'

    def __init__(self, n_dof: int) -> None:
        if isinstance(n_dof, bool) or not isinstance(n_dof, int) or n_dof < 1:
            msg = f'{type(self).__name__}: n_dof must be a positive integer, got {n_dof!r}'
            raise BridgeConfigError(msg)
        self.n_dof = n_dof
        self.size_id: SizeID | None = None
        self.trials = 0
        self.commits = 0
        self._trial = TrialResponse()
        self._t0 = time.monotonic()

    def setup(self, size_id: SizeID) -> None:
        """Check that the size ID fits this controller.

        Displacement must be controlled on every DOF; displacement, velocity, acceleration and
        force may each be acquired on 0 or ``n_dof`` channels, time on any number.

        Raises:
            ControllerError: If the sizes do not fit.
        """
        ctrl = dict(zip(RESPONSE_KINDS, size_id.ctrl, strict=True))
        daq = dict(zip(RESPONSE_KINDS, size_id.daq, strict=True))
        if ctrl['disp'] != self.n_dof:
            msg = (
                f'{self.name}: {self.n_dof} DOF need {self.n_dof} controlled displacement(s), '
                f'the size ID has {ctrl["disp"]}'
            )
            raise ControllerError(msg)
        for kind in ('vel', 'accel', 'force'):
            if ctrl[kind] not in (0, self.n_dof):
                msg = (
                    f'{self.name}: controlled {kind} size must be 0 or {self.n_dof}, '
                    f'got {ctrl[kind]}'
                )
                raise ControllerError(msg)
        for kind in ('disp', 'vel', 'accel', 'force'):
            if daq[kind] not in (0, self.n_dof):
                msg = f'{self.name}: daq {kind} size must be 0 or {self.n_dof}, got {daq[kind]}'
                raise ControllerError(msg)
        self.size_id = size_id
        self._t0 = time.monotonic()

    def set_trial_response(self, trial: TrialResponse) -> None:
        """Execute the trial displacement (see :meth:`_move`)."""
        self._trial = trial
        self.trials += 1
        self._move(list(trial.disp))

    def get_daq_response(self) -> DaqResponse:
        """Return the measured displacement and force, and the trial velocity/acceleration."""
        assert self.size_id is not None, 'setup() first'
        sizes = dict(zip(RESPONSE_KINDS, self.size_id.daq, strict=True))
        disp, force = self._measure()
        zeros = (0.0,) * self.n_dof
        if self._trial.time:
            now = self._trial.time[0]
        else:
            now = time.monotonic() - self._t0
        return DaqResponse(
            disp=tuple(disp) if sizes['disp'] else (),
            vel=(self._trial.vel or zeros) if sizes['vel'] else (),
            accel=(self._trial.accel or zeros) if sizes['accel'] else (),
            force=tuple(force) if sizes['force'] else (),
            time=(float(now),) * sizes['time'],
        )

    def commit_state(self) -> None:
        """Count the commit (nothing else to do)."""
        self.commits += 1

    def _move(self, target: list[float]) -> None:
        raise NotImplementedError

    def _measure(self) -> tuple[list[float], list[float]]:
        raise NotImplementedError


class ElasticController(_MeasuredController):
    """An ideal actuator on a linear elastic specimen: it reaches every target exactly.

    The measured force per DOF is ``k_i * x_i``.

    Attributes:
        position: Current displacement per DOF, m.
    """

    name = 'elastic controller'

    def __init__(
        self,
        stiffness: float | Sequence[float] = 1.0e6,
        n_dof: int = 1,
        initial_position: Sequence[float] | None = None,
    ) -> None:
        """Create the controller.

        Args:
            stiffness: Specimen stiffness, N/m: one value for every DOF or one per DOF.
            n_dof: Number of DOF.
            initial_position: Starting displacement per DOF, m (zeros if omitted).

        Raises:
            BridgeConfigError: On a bad argument.
        """
        super().__init__(n_dof)
        values = [stiffness] * n_dof if isinstance(stiffness, int | float) else list(stiffness)
        if len(values) != n_dof or not all(
            isinstance(k, int | float) and not isinstance(k, bool) and math.isfinite(k)
            for k in values
        ):
            msg = (
                f'ElasticController: stiffness must be a finite number or {n_dof} of them, '
                f'got {stiffness!r}'
            )
            raise BridgeConfigError(msg)
        self.stiffness = [float(k) for k in values]
        position = [0.0] * n_dof if initial_position is None else list(initial_position)
        if len(position) != n_dof:
            msg = (
                f'ElasticController: initial_position has {len(position)} values, '
                f'expected {n_dof}'
            )
            raise BridgeConfigError(msg)
        self.position = [float(x) for x in position]

    def describe(self) -> str:
        """One-line description."""
        k = ', '.join(f'{v:g}' for v in self.stiffness)
        return f'ideal actuator on an elastic specimen, {self.n_dof} DOF, k = [{k}] N/m'

    def _move(self, target: list[float]) -> None:
        self.position = list(target)

    def _measure(self) -> tuple[list[float], list[float]]:
        force = [k * x for k, x in zip(self.stiffness, self.position, strict=True)]
        return list(self.position), force


class EmulatorController(_MeasuredController):
    """Adapter from the GenericTCP server to an actuator emulator backend.

    The backend must have ``execute(target)`` taking the target displacement per DOF (m) and
    returning the measured displacement and force per DOF, either as a pair ``(disp, force)``
    or as an object with ``displacement`` (or ``disp``) and ``force`` attributes.
    """

    name = 'emulator controller'

    def __init__(self, backend: Any, n_dof: int = 1, description: str = '') -> None:
        """Wrap ``backend``.

        Raises:
            BridgeConfigError: If the backend has no callable ``execute``.
        """
        super().__init__(n_dof)
        if not callable(getattr(backend, 'execute', None)):
            msg = f'EmulatorController: backend {type(backend).__name__} has no execute(target)'
            raise BridgeConfigError(msg)
        self.backend = backend
        self._description = description or f'emulator backend {type(backend).__name__}'
        self._disp = [0.0] * n_dof
        self._force = [0.0] * n_dof

    def describe(self) -> str:
        """One-line description."""
        return f'{self._description}, {self.n_dof} DOF'

    def _move(self, target: list[float]) -> None:
        result = self.backend.execute(list(target))
        if isinstance(result, tuple | list) and len(result) == 2:
            disp, force = result
        else:
            disp = getattr(result, 'displacement', getattr(result, 'disp', None))
            force = getattr(result, 'force', None)
        self._disp = self._vector(disp, 'displacement')
        self._force = self._vector(force, 'force')

    def _measure(self) -> tuple[list[float], list[float]]:
        return list(self._disp), list(self._force)

    def _vector(self, value: Any, what: str) -> list[float]:
        if isinstance(value, int | float) and self.n_dof == 1:
            return [float(value)]
        try:
            values = [float(v) for v in value]
        except TypeError:
            values = []
        if len(values) != self.n_dof:
            msg = f'{self.name}: backend returned {what} {value!r}, expected {self.n_dof} values'
            raise ControllerError(msg)
        return values


def load_emulator_controller(
    n_dof: int, stiffness: float, ramp_time: float = 0.2, hold_time: float = 0.3
) -> EmulatorController:
    """An :class:`EmulatorController` on the servo-hydraulic emulator.

    The emulator drives a linear elastic specimen (one :class:`pd_common.specimen.Elastic` of
    ``stiffness`` per DOF); each trial is executed by the core's
    :class:`~pd_actuator_bridge.core.RampHoldExecutor`: a ramp of ``ramp_time``, a hold of at
    least ``hold_time`` until the measurement has settled (default tolerance), then the
    average of the last samples. The settling may take up to ``hold_time`` plus the
    executor's default timeout; beyond it the trial fails and the session ends.

    Raises:
        EmulatorUnavailableError: If the emulator cannot be built (e.g. a stiffness that is not
            positive).
    """
    try:
        specimen = Specimen([Elastic(stiffness) for _ in range(n_dof)])
        emulator = ServoHydraulicEmulator(specimen)
        backend = RampHoldExecutor(emulator, ramp_time=ramp_time, hold_time=hold_time,
                                   timeout=hold_time + RampHoldParameters.timeout)
    except Exception as exc:  # noqa: BLE001 - any failure means the emulator is unusable
        msg = f'the servo-hydraulic emulator is not available: {type(exc).__name__}: {exc}'
        raise EmulatorUnavailableError(msg) from None
    how = (f'ServoHydraulicEmulator, ramp {ramp_time:g} s + hold {hold_time:g} s, '
           f'k = {stiffness:g} N/m')
    return EmulatorController(backend, n_dof, f'servo-hydraulic emulator ({how})')


def make_controller(
    n_dof: int = 1,
    stiffness: float = 1.0e6,
    emulator: bool = False,
    warn: Callable[[str], None] | None = None,
    ramp_time: float = 0.2,
    hold_time: float = 0.3,
) -> Any:
    """Return the controller selected by the command-line options.

    Args:
        n_dof: Number of DOF.
        stiffness: Specimen stiffness, N/m.
        emulator: Use the servo-hydraulic emulator; falls back to the elastic controller
            (with a message through ``warn``) if it is not available.
        warn: Receives the fall-back message; logged as a warning if omitted.
        ramp_time: Emulator ramp duration per step, s (see :func:`load_emulator_controller`).
        hold_time: Emulator minimum hold per step, s.
    """
    if emulator:
        try:
            return load_emulator_controller(n_dof, stiffness, ramp_time, hold_time)
        except EmulatorUnavailableError as exc:
            message = f'{exc}; falling back to the ideal elastic controller'
            (warn or LOGGER.warning)(message)
    return ElasticController(stiffness, n_dof)
