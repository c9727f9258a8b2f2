"""A delay compensator ``scaled`` (``u = gain · x_d``) and a plant model ``scaled_ideal``
(an ideal actuator with a gain: ``x = gain · u`` one sample later), for the real-time kinds."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pd_common.errors import RthsError
from pd_common.registry import Parameter
from pd_common.rths import IdealPlant, TransferSystem
from pd_common.rths.compensation import Compensator, CompensatorSpec


class ScaledCompensation(Compensator):
    """``u = gain · x_d``."""

    def __init__(self, dt: float, gain: float) -> None:
        """Create it for sample period ``dt``."""
        super().__init__(dt)
        self.gain = gain

    def reset(self) -> None:
        """Nothing to forget."""

    def command(self, target: float, measured: float) -> float:
        """The scaled target."""
        return self.gain * target


SCALED = CompensatorSpec(
    name='scaled',
    factory=lambda dt, parameters: ScaledCompensation(dt, parameters['gain']),
    parameters=(Parameter('gain', 1.0, 'factor on the desired displacement'),),
    description='u = gain * x_d (example plug-in)',
)


class ScaledIdealPlant(IdealPlant):
    """An ideal actuator whose displacement is ``gain`` times the command."""

    def __init__(self, dt: float, gain: float) -> None:
        """Create it at rest."""
        super().__init__(dt)
        self.gain = gain

    def advance(self, command: float) -> None:
        """Go to ``gain · command``."""
        super().advance(self.gain * command)


def scaled_ideal(section: Mapping[str, Any], dt: float, where: str) -> TransferSystem:
    """``plant: {model: scaled_ideal, gain: 1.0}``."""
    unknown = sorted(set(section) - {'model', 'gain'})
    if unknown:
        msg = f'{where}: unknown key {unknown[0]!r} (expected model, gain)'
        raise RthsError(msg)
    gain = section.get('gain', 1.0)
    if isinstance(gain, bool) or not isinstance(gain, int | float):
        msg = f'{where}.gain: must be a number, got {gain!r}'
        raise RthsError(msg)
    return ScaledIdealPlant(dt, float(gain))
