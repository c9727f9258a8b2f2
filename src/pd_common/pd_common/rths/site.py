"""A site in continuous motion answering step commands (transport-free).

:class:`ContinuousSiteServer` is to a ``transfer_system`` site what
:class:`~pd_common.specimen.SpecimenServer` is to a ``specimen`` site: it answers the
integrator's step commands (the ROS-free runner's ``serve_queue``) with the measurement of a
:class:`~.continuous.ContinuousActuator` in simulated time, each command one integration step
of ``S`` controller samples. The bridge's ``transfer_system`` driver runs the same actuator,
so a run through the node graph and the ROS-free run compute the same floats.

A site's section of the test file::

    sites:
      lab1:
        transfer_system:
          plant: {model: benchmark}          # or {model: benchmark, perturbed: true, seed: 3},
                                             # or {model: ideal}
          controller_rate: 4096.0            # Hz; test.dt a whole multiple of its period
          compensator: {name: model_based}   # and its parameters
          noise: {displacement_power: 6.25e-14, force_power: 1.16e-3, seed: 1}
          quantum: 3.814697265625e-06        # m (2^-18)
          capacity: 8900.0                   # N
          interpolation: cubic               # or linear
          inertia: subtract                  # or measured

Step 0 (the integrator's initial state, at rest) is answered with the reading at rest and
no time passes; step ``n`` is the actuator's n-th integration step. Commands, as for a
simulated specimen: a new ``(step, iteration)`` moves the actuator; the one
answered last, again, gets the same answer without moving; an older one is ignored
(``None``). Continuous motion takes one command per integration step (explicit schemes):
an iteration > 0, a force-controlled actuator or a site of more than one actuator is answered
with a one-line FAULT, nothing moves. A step whose samples reached the actuator's capacity is
answered with a FAULT too (the run is invalid; the session holds).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..protocol.answers import KeyedAnswers
from ..protocol.messages import Feedback, FeedbackStatus
from .continuous import ContinuousActuator, ContinuousConfig, ContinuousMeasurement

__all__ = ['ContinuousSiteServer', 'SampleLog']


class SampleLog:
    """The controller samples of a run, step after step (what the tracking criteria use).

    Attributes:
        times: Simulated time of each sample, s.
        desired: Desired displacement x_d of each sample, m.
        measured: Measured displacement x_m of each sample, m.
        command: Command u of each sample, m.
        force: Load-cell force of each sample, N.
    """

    def __init__(self) -> None:
        """An empty log."""
        self._parts: dict[str, list[np.ndarray]] = {
            'times': [], 'desired': [], 'measured': [], 'command': [], 'force': []}

    def append(self, measurement: ContinuousMeasurement) -> None:
        """Add the samples of one step."""
        parts = self._parts
        parts['times'].append(measurement.times)
        parts['desired'].append(measurement.desired)
        parts['measured'].append(measurement.measured)
        parts['command'].append(measurement.command)
        parts['force'].append(measurement.measured_force)

    def _joined(self, key: str) -> np.ndarray:
        parts = self._parts[key]
        return np.concatenate(parts) if parts else np.empty(0)

    @property
    def times(self) -> np.ndarray:
        """Simulated time of each sample, s."""
        return self._joined('times')

    @property
    def desired(self) -> np.ndarray:
        """Desired displacement of each sample, m."""
        return self._joined('desired')

    @property
    def measured(self) -> np.ndarray:
        """Measured displacement of each sample, m."""
        return self._joined('measured')

    @property
    def command(self) -> np.ndarray:
        """Command of each sample, m."""
        return self._joined('command')

    @property
    def force(self) -> np.ndarray:
        """Load-cell force of each sample, N."""
        return self._joined('force')


class ContinuousSiteServer(KeyedAnswers):
    """Answers one site's step commands with a continuous actuator in simulated time.

    Args:
        config: The site's ``transfer_system`` configuration.
        integration_dt: The test's Δt, s (a whole multiple of the controller period).
        n_dof: Actuators of the site (must be 1).
        keep_samples: Whether to keep every controller sample in :attr:`samples`.

    Attributes:
        actuator: The :class:`ContinuousActuator`.
        samples: The samples of the run (``None`` unless ``keep_samples``).
        steps_served, repeated, ignored, faults: Counters, as a specimen server's.
        peak_force: Largest |actuator force| of the run, N.
    """

    def __init__(self, config: ContinuousConfig, integration_dt: float, *, n_dof: int = 1,
                 keep_samples: bool = False) -> None:
        """Build the site at rest."""
        super().__init__()
        self.actuator = ContinuousActuator(config, integration_dt)
        self.n_dof = int(n_dof)
        self.samples = SampleLog() if keep_samples else None
        self.steps_served = 0
        self.faults = 0
        self.peak_force = 0.0
        self.position: tuple[float, ...] = (self.actuator.measured_displacement,) * self.n_dof
        self.force: tuple[float, ...] = (0.0,) * self.n_dof

    @property
    def valid(self) -> bool:
        """False once a sample reached the actuator's capacity."""
        return self.actuator.valid

    def _move(self, test_id: str, step: int, iteration: int, target: Sequence[float],
              control_mode: Sequence[int], target_force: Sequence[float]) -> Feedback:
        values = [float(value) for value in target]
        if self.n_dof != 1:
            return self._fault(test_id, step, iteration, f'continuous motion drives one '
                               f'actuator per site, this site has {self.n_dof}')
        if len(values) != 1 or not math.isfinite(values[0]):
            return self._fault(test_id, step, iteration,
                               f'invalid target displacement {values!r}')
        if any(int(mode) != 0 for mode in control_mode):
            return self._fault(test_id, step, iteration, 'continuous motion is displacement '
                               'control only (no force-controlled actuator)')
        if iteration != 0:
            return self._fault(test_id, step, iteration, 'continuous motion takes one command '
                               'per integration step (an explicit scheme), got iteration '
                               f'{iteration}')
        if step == 0:
            # The initial state: the integrator reads the specimen at rest (no time passes).
            if values[0] != 0.0 or self.actuator.completed_steps:
                return self._fault(test_id, step, iteration, 'continuous motion starts from '
                                   f'rest: step 0 must be at 0 before any step, got '
                                   f'{values[0]!r}')
            self.position = (self.actuator.measured_displacement,)
            self.force = (0.0,)
            return Feedback(test_id=test_id, step=step, measured_displacement=self.position,
                            restoring_force=self.force, iteration=iteration)
        measurement = self.actuator.step(values[0])
        self.steps_served += 1
        if self.samples is not None:
            self.samples.append(measurement)
        self.peak_force = max(self.peak_force, measurement.peak_force)
        self.position = (measurement.displacement,)
        self.force = (measurement.force,)
        if measurement.capacity_exceeded:
            return self._fault(test_id, step, iteration, f'actuator force '
                               f'{measurement.peak_force:.1f} N reached the capacity '
                               f'{self.actuator.config.capacity:g} N: the run is invalid')
        return Feedback(test_id=test_id, step=step, measured_displacement=self.position,
                        restoring_force=self.force, iteration=iteration)

    def _fault(self, test_id: str, step: int, iteration: int, message: str) -> Feedback:
        self.faults += 1
        return Feedback(test_id=test_id, step=step, measured_displacement=self.position,
                        restoring_force=self.force, status=FeedbackStatus.FAULT,
                        message=message, iteration=iteration)
