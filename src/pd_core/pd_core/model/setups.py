"""Experimental setups of the integrator: the shared :mod:`pd_common.experimental.setups`.

The setups (an experimental element's basic DOFs ↔ its site's actuator strokes and forces:
``one_to_one``, ``rigid_link_2``, ``planar``, ``column``, ``planar_3``) live in the shared
library, so that the simulated specimen can emulate the same lab geometry; see that module
for their definitions. This adapter re-exports them and turns the library's
:class:`~pd_common.errors.SetupError` into the integrator's :class:`~..errors.ConfigError`
(same one-line message) when a test file's ``setup`` is read.
"""

from __future__ import annotations

from typing import Any

from pd_common.errors import SetupError
from pd_common.experimental import setups as _shared
from pd_common.experimental.setups import (
    SETUP_TYPES,
    ColumnSetup,
    ExperimentalSetup,
    OneToOneSetup,
    PlanarActuators,
    PlanarThreeActuators,
    RigidLinkTwoActuators,
)

from ..errors import ConfigError

__all__ = [
    'SETUP_TYPES',
    'ColumnSetup',
    'ExperimentalSetup',
    'OneToOneSetup',
    'PlanarActuators',
    'PlanarThreeActuators',
    'RigidLinkTwoActuators',
    'SetupError',
    'setup_from_config',
]


def setup_from_config(raw: Any, n_basic: int, where: str) -> ExperimentalSetup:
    """Build a setup from a test file's ``setup`` mapping (``None``: one-to-one).

    Raises:
        ConfigError: one line naming ``where`` (e.g. ``test.yaml: structure.elements.0.setup``).
    """
    try:
        return _shared.setup_from_config(raw, n_basic, where)
    except SetupError as err:
        raise ConfigError(str(err)) from None
