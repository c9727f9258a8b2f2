"""Parameters of the servo-hydraulic actuator emulator: plant, controller, sensors, friction.

:class:`EmulatorParameters` holds the physical, control and sensor parameters of
:class:`~.emulator.ServoHydraulicEmulator` (the same for every DOF), validates them, builds them
from a mapping (a parsed YAML section or ROS parameters) and derives the figures of the loop
(oil-column stiffness, frequency and damping, velocity constant, static error). The values are
checked by the shared schema (:class:`pd_common.config.schema_driver.EmulatorSection`, the
``emulator`` section of a driver's settings file), the one place of those checks. The model,
the integration and the default tuning are described in :mod:`.emulator`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

from ..error_models import validated

if TYPE_CHECKING:
    from pd_common.config.schema_driver import EmulatorSection


@dataclass(frozen=True)
class EmulatorParameters:
    """Physical, control and sensor parameters of the emulator (the same for every DOF).

    Attributes:
        rate: Controller rate, Hz (>= 1000).
        substeps: Integration sub-steps per controller period (>= 1).
        piston_area: Effective piston area ``A``, m2.
        bulk_modulus: Effective oil bulk modulus ``beta`` (oil, hoses, entrained air), Pa.
        chamber_volume: Total volume ``V`` of both chambers and the lines, m3.
        piston_mass: Moving mass ``m_p`` (piston, rod, load cell, clevis), kg.
        piston_damping: Viscous damping ``c_p`` of the piston seals, N s/m (not seen by the
            load cell).
        valve_time_constant: First-order spool lag ``tau_v``, s.
        valve_flow: Rated flow ``Q`` at full opening, m3/s.
        leakage: Flow-pressure coefficient ``K_ce`` (valve and cross-port leakage), m3/(s Pa).
        supply_pressure: Supply pressure ``P_s`` for the orifice law, Pa; ``None`` keeps the
            flow linear in the spool opening.
        kp: Proportional gain, V/m.
        ki: Integral gain, V/(m s).
        integral_band: The integral acts only while ``|e| <= integral_band``, m (``inf``:
            always); must exceed the largest proportional-only error.
        kd: Derivative gain (on the measurement), V s/m.
        derivative_filter: Time constant ``tau_d`` of the derivative filter, s (0: none).
        velocity_feedforward: Velocity feed-forward as a fraction of the ideal ``u_max A / Q``.
        valve_saturation: Controller output limit ``u_max`` (the servo-valve's rated input), V.
        delay_ticks: Transport delay of the command, controller periods.
        displacement_noise: Standard deviation of the displacement sensor noise, m.
        force_noise: Standard deviation of the load-cell noise, N.
        displacement_lsb: Quantisation step of the displacement sensor, m (0: none).
        force_lsb: Quantisation step of the load cell, N (0: none).
        force_bias: Constant load-cell offset, N.
        friction_coulomb: Coulomb (Dahl) friction force ``F_c`` of the connections, N.
        friction_viscous: Viscous friction ``c_f`` of the connections, N s/m.
        friction_stiffness: Dahl pre-sliding stiffness ``sigma_0``, N/m.
        seed: Seed of the sensor-noise generator (``None``: non-deterministic).

    Raises:
        BridgeConfigError: One line naming the parameter, if a value is invalid.
    """

    rate: float = 1000.0
    substeps: int = 2
    piston_area: float = 0.01
    bulk_modulus: float = 6.9e8
    chamber_volume: float = 6.0e-3
    piston_mass: float = 50.0
    piston_damping: float = 9500.0
    valve_time_constant: float = 0.0015
    valve_flow: float = 1.0e-3
    leakage: float = 5.0e-12
    supply_pressure: float | None = None
    kp: float = 4000.0
    ki: float = 20000.0
    integral_band: float = 5.0e-5
    kd: float = 0.0
    derivative_filter: float = 0.002
    velocity_feedforward: float = 0.0
    valve_saturation: float = 10.0
    delay_ticks: int = 0
    displacement_noise: float = 0.0
    force_noise: float = 0.0
    displacement_lsb: float = 0.0
    force_lsb: float = 0.0
    force_bias: float = 0.0
    friction_coulomb: float = 0.0
    friction_viscous: float = 0.0
    friction_stiffness: float = 1.0e7
    seed: int | None = None

    def __post_init__(self) -> None:
        """Validate every value (the schema's ``EmulatorSection``) and normalise the numbers."""
        from pd_common.config.schema_driver import EmulatorSection  # noqa: PLC0415 (first use)

        values = {field.name: getattr(self, field.name) for field in fields(self)}
        for name, value in validated(EmulatorSection, values, 'EmulatorParameters'):
            object.__setattr__(self, name, value)

    @classmethod
    def from_mapping(
        cls, mapping: Mapping[str, Any], source: str = 'EmulatorParameters', path: str = ''
    ) -> EmulatorParameters:
        """Build the parameters from a mapping (a parsed YAML section or ROS parameters).

        Args:
            mapping: Any subset of the attribute names; missing ones keep their defaults.
            source: Name of the file or parameter namespace, used in error messages.
            path: The mapping's dotted path in its file (``'emulator'``), in error messages.

        Returns:
            The validated parameters.

        Raises:
            BridgeConfigError: On a non-mapping, an unknown key or a bad value.
        """
        from pd_common.config.schema_driver import EmulatorSection  # noqa: PLC0415 (first use)

        return cls.from_section(validated(EmulatorSection, mapping, source, path))

    @classmethod
    def from_section(cls, section: EmulatorSection) -> EmulatorParameters:
        """The parameters of a typed ``emulator`` section (a driver's settings file)."""
        return cls(**dict(section))

    @property
    def dt(self) -> float:
        """Controller period ``1 / rate``, s."""
        return 1.0 / self.rate

    @property
    def substep(self) -> float:
        """Integration sub-step ``h``, s."""
        return 1.0 / (self.rate * self.substeps)

    @property
    def hydraulic_stiffness(self) -> float:
        """Oil-column stiffness ``k_h = 4 beta A^2 / V``, N/m (Merritt ch. 6)."""
        return 4.0 * self.bulk_modulus * self.piston_area**2 / self.chamber_volume

    @property
    def velocity_gain(self) -> float:
        """No-load piston velocity at full valve opening ``Q / A``, m/s."""
        return self.valve_flow / self.piston_area

    @property
    def loop_gain(self) -> float:
        """Velocity constant of the proportional loop ``K_v = k_p Q / (u_max A)``, 1/s."""
        return self.kp * self.velocity_gain / self.valve_saturation

    def hydraulic_frequency(self, specimen_stiffness: float = 0.0) -> float:
        """Oil-column natural frequency ``sqrt((k_h + k_s) / m_p)``, rad/s.

        Args:
            specimen_stiffness: Stiffness ``k_s`` of the specimen, N/m.
        """
        return math.sqrt((self.hydraulic_stiffness + specimen_stiffness) / self.piston_mass)

    def hydraulic_damping_ratio(self) -> float:
        """Damping ratio of the oil-column mode (Merritt ch. 6, with ``c_p + c_f``).

        ``zeta_h = (K_ce / A) sqrt(beta m_p / V) + ((c_p + c_f) / 4 A) sqrt(V / (beta m_p))``.
        """
        beta, m, v, a = self.bulk_modulus, self.piston_mass, self.chamber_volume, self.piston_area
        damping = self.piston_damping + self.friction_viscous
        return (self.leakage / a) * math.sqrt(beta * m / v) + (damping / (4.0 * a)) * math.sqrt(
            v / (beta * m)
        )

    def static_error_ratio(self, specimen_stiffness: float) -> float:
        """Steady-state error over displacement with proportional control only (``k_i = 0``).

        At rest the valve must pass the leakage flow of the load pressure:
        ``Q k_p e / u_max = K_ce k_s x / A``, so ``e / x = u_max K_ce k_s / (A Q k_p)``.

        Args:
            specimen_stiffness: Stiffness ``k_s`` of an elastic specimen, N/m.
        """
        return (
            self.valve_saturation
            * self.leakage
            * specimen_stiffness
            / (self.piston_area * self.valve_flow * self.kp)
        )
