"""The servo-hydraulic emulator as a transfer system of real-time hybrid simulation.

``plant: {model: emulator, ...}`` in a site's ``transfer_system`` section runs the bridge's
own :class:`~.emulator.ServoHydraulicEmulator` (servo-valve, oil column, piston, PID
controller, friction, sensors) at the controller rate under the same
:class:`pd_common.rths.TransferSystem` interface as the vRTHS benchmark's plant: the command
is the emulator controller's displacement reference, held over one sample; the output is the
piston's displacement at the sample's end. Its specimen is a linear spring of ``stiffness``
(N/m) — the continuous actuator's load cell adds the specimen's mass and damping forces from
the displacement, as it does for every plant. The other keys are emulator parameters
(:class:`~.emulator_parameters.EmulatorParameters`; ``rate`` is the controller rate and must
not be given).

Registered when the bridge's drivers are imported (the emulator is the bridge's): a
ROS-free run of the integrator does not know this model and says so in one line.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pd_common.errors import RthsError, SpecimenError
from pd_common.rths import BENCHMARK_SPECIMEN, TransferSystem, register_plant_model
from pd_common.specimen import specimen_from_config

from ..errors import BridgeConfigError, DriverError
from .emulator import ServoHydraulicEmulator
from .emulator_parameters import EmulatorParameters

__all__ = ['EmulatorPlant', 'emulator_plant']


class EmulatorPlant(TransferSystem):
    """The emulator driven one controller sample at a time."""

    def __init__(self, emulator: ServoHydraulicEmulator) -> None:
        """Wrap ``emulator`` (one DOF); its period is the plant's."""
        super().__init__(emulator.dt)
        if emulator.n_dof != 1:
            msg = f'plant model emulator: one DOF, got {emulator.n_dof}'
            raise RthsError(msg)
        self.emulator = emulator

    def reset(self) -> None:
        """Back to rest at 0 (the emulator's equilibrium there)."""
        self.emulator.reset([0.0])

    def output(self) -> float:
        """The piston's displacement at the current sample, m."""
        return float(self.emulator.position[0])

    def actuator_force(self) -> float:
        """The hydraulic force at the current sample, N."""
        return float(self.emulator.hydraulic_force[0])

    def advance(self, command: float) -> None:
        """One controller period with the displacement reference ``command`` (m)."""
        try:
            self.emulator.tick([float(command)])
        except DriverError as err:
            msg = f'plant model emulator: {err}'
            raise RthsError(msg) from None


def emulator_plant(section: Mapping[str, Any], dt: float, where: str) -> TransferSystem:
    """The emulator plant of a ``plant: {model: emulator, ...}`` section.

    The emulator plant of a ``plant: {model: emulator, stiffness: ..., <parameters>}``
    section at controller period ``dt``.

    Raises:
        RthsError: One line naming ``where`` and the key.
    """
    raw = {key: value for key, value in section.items() if key not in ('model', 'stiffness')}
    if 'rate' in raw:
        msg = f'{where}.rate: is the transfer system\'s controller_rate; do not give it here'
        raise RthsError(msg)
    stiffness = section.get('stiffness', BENCHMARK_SPECIMEN.stiffness)
    if (isinstance(stiffness, bool) or not isinstance(stiffness, int | float)
            or not math.isfinite(stiffness) or stiffness <= 0.0):
        msg = f'{where}.stiffness: must be a positive number [N/m], got {stiffness!r}'
        raise RthsError(msg)
    try:
        parameters = EmulatorParameters.from_mapping({**raw, 'rate': 1.0 / dt}, where)
        specimen = specimen_from_config(
            {'elements': [{'model': 'elastic', 'stiffness': float(stiffness)}]},
            base_dir=Path.cwd(), source=where, dof_names=['x'])
        return EmulatorPlant(ServoHydraulicEmulator(specimen, parameters))
    except (BridgeConfigError, SpecimenError, DriverError) as err:
        text = str(err)
        raise RthsError(text if text.startswith(where) else f'{where}: {text}') from None


register_plant_model('emulator', emulator_plant)
