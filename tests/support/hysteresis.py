"""Driving a hysteresis model through a displacement path, one committed step per point."""

from __future__ import annotations

from collections.abc import Sequence

from pd_common.specimen import HysteresisModel


def drive(model: HysteresisModel, path: Sequence[float]) -> list[float]:
    """Apply each displacement as one committed step and return the forces."""
    forces = []
    for x in path:
        forces.append(model.set_trial_displacement(x))
        model.commit()
    return forces
