"""The interfaces of real-time hybrid simulation: transfer system, specimen force, sensors.

A *transfer system* (servo-valve, actuator, specimen with control–structure interaction) takes
the controller's command ``u`` held over one controller sample and gives the actuator's
displacement; it runs at the controller rate ``dt`` (e.g. 1/4096 s). Sample ordering, the same
for every implementation::

    y = plant.output()      # displacement at sample k (strictly proper: does not depend on u[k])
    plant.advance(u)        # u[k] held over [t_k, t_k + dt]; now at sample k + 1

Pure (numpy/scipy): shared by the bridge's driver layer and the integrator's ROS-free loops.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass

import numpy as np

from ..errors import RthsError


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value) or value <= 0.0:
        msg = f'{name} must be a positive finite number, got {value!r}'
        raise RthsError(msg)
    return value


class TransferSystem(abc.ABC):
    """A discrete-time model of the transfer system, from command to actuator displacement."""

    def __init__(self, dt: float) -> None:
        """Create the model for the controller sample period ``dt`` (s)."""
        self.dt = _positive('transfer system dt', dt)

    @abc.abstractmethod
    def reset(self) -> None:
        """Return to rest (zero state)."""

    @abc.abstractmethod
    def output(self) -> float:
        """The actuator displacement at the current sample, m."""

    @abc.abstractmethod
    def advance(self, command: float) -> None:
        """Hold ``command`` (m) over one sample and move to the next sample."""


class IdealPlant(TransferSystem):
    """A perfect actuator: one sample after a command, the displacement is that command.

    A perfect actuator: the displacement one sample after a command is that command
    (``output()`` returns the last command; 0 at rest).
    """

    def __init__(self, dt: float) -> None:
        """Create the ideal plant."""
        super().__init__(dt)
        self._y = 0.0

    def reset(self) -> None:
        """Return to rest."""
        self._y = 0.0

    def output(self) -> float:
        """The last command, m."""
        return self._y

    def advance(self, command: float) -> None:
        """Go to ``command``."""
        self._y = float(command)


@dataclass(frozen=True)
class PhysicalSpecimen:
    """A linear spring–mass–damper specimen (the vRTHS benchmark's physical substructure).

    Attributes:
        mass: m_e, kg.
        stiffness: k_e, N/m.
        damping_ratio: ζ_e; the damping coefficient is c_e = 2 ζ_e √(k_e m_e).
    """

    mass: float
    stiffness: float
    damping_ratio: float

    def __post_init__(self) -> None:
        """Check the fields."""
        if not (math.isfinite(self.mass) and self.mass >= 0.0):
            msg = f'specimen mass must be >= 0, got {self.mass!r}'
            raise RthsError(msg)
        _positive('specimen stiffness', self.stiffness)
        if not (math.isfinite(self.damping_ratio) and self.damping_ratio >= 0.0):
            msg = f'specimen damping_ratio must be >= 0, got {self.damping_ratio!r}'
            raise RthsError(msg)

    @property
    def damping(self) -> float:
        """c_e = 2 ζ_e √(k_e m_e), N·s/m."""
        return 2.0 * self.damping_ratio * math.sqrt(self.stiffness * self.mass)

    def force(self, x0: float, x1: float, x2: float, dt: float) -> float:
        """The force the load cell reads, N: ``k_e x + c_e ẋ + m_e ẍ``.

        From the displacement at samples k (``x0``), k − 1 and k − 2 by backward differences.
        """
        velocity = (x0 - x1) / dt
        acceleration = (x0 - 2.0 * x1 + x2) / (dt * dt)
        return self.stiffness * x0 + self.damping * velocity + self.mass * acceleration


#: The vRTHS benchmark's physical substructure (Silva et al. 2020).
BENCHMARK_SPECIMEN = PhysicalSpecimen(mass=29.13, stiffness=1.19e6, damping_ratio=0.0097)


def quantise(value: float, quantum: float) -> float:
    """``value`` rounded to the nearest multiple of ``quantum`` (``quantum`` 0: unchanged)."""
    if quantum <= 0.0:
        return value
    return round(value / quantum) * quantum


@dataclass(frozen=True)
class SensorNoise:
    """Band-limited white sensor noise (Simulink's block).

    A Gaussian sample each controller sample ``dt`` with standard deviation √(power / dt).

    Attributes:
        displacement_power: Noise power of the displacement sensor, m²·s (benchmark 6.25e-14:
            RMS 1.6e-5 m at 4096 Hz).
        force_power: Noise power of the load cell, N²·s (benchmark 1.16e-3: RMS 2.18 N).
        seed: Seed of the generator (a run is reproducible).
    """

    displacement_power: float = 0.0
    force_power: float = 0.0
    seed: int = 0

    def displacement_std(self, dt: float) -> float:
        """RMS of the displacement noise at sample period ``dt``, m."""
        return math.sqrt(self.displacement_power / dt)

    def force_std(self, dt: float) -> float:
        """RMS of the force noise at sample period ``dt``, N."""
        return math.sqrt(self.force_power / dt)

    def generator(self) -> np.random.Generator:
        """A fresh generator for one run."""
        return np.random.default_rng(self.seed)


#: The vRTHS benchmark's sensor noise powers.
BENCHMARK_NOISE = SensorNoise(displacement_power=6.25e-14, force_power=1.16e-3)
#: The benchmark's quantisation of command and measurement, m (2⁻¹⁸).
BENCHMARK_QUANTUM = 2.0 ** -18
#: The benchmark actuator's force capacity, N (a run that reaches it is invalid).
BENCHMARK_CAPACITY = 8900.0
