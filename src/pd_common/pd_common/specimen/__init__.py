"""Specimen models: backbones, hysteresis, specimens, their config schema and the step server.

The simulator node and the ROS-free runner answer step commands with a
:class:`SpecimenServer`; the integrator's numerical springs and the bridge's emulator use the
same hysteresis models.
"""

from __future__ import annotations

from ..errors import BackboneError, HysteresisError, SpecimenConfigError, SpecimenError
from .backbone import (
    BEYOND_MODES,
    Backbone,
    bilinear_backbone,
    load_backbone_csv,
    load_opensees_pushover,
)
from .bouc_wen import BoucWen
from .config import hysteresis_from_config, load_specimen_section, specimen_from_config
from .hysteresis import (
    MEMORY_MODES,
    BilinearKinematic,
    Elastic,
    ElasticPerfectlyPlastic,
    HysteresisModel,
    PushoverHysteresis,
)
from .served import ServedRecord, restore_served, specimen_fingerprint
from .server import SpecimenServer, load_site_server, server_from_config
from .specimen import TOPOLOGIES, Specimen

__all__ = [
    'BEYOND_MODES',
    'MEMORY_MODES',
    'TOPOLOGIES',
    'Backbone',
    'BackboneError',
    'BilinearKinematic',
    'BoucWen',
    'Elastic',
    'ElasticPerfectlyPlastic',
    'HysteresisError',
    'HysteresisModel',
    'PushoverHysteresis',
    'ServedRecord',
    'Specimen',
    'SpecimenConfigError',
    'SpecimenError',
    'SpecimenServer',
    'bilinear_backbone',
    'hysteresis_from_config',
    'load_backbone_csv',
    'load_opensees_pushover',
    'load_site_server',
    'load_specimen_section',
    'restore_served',
    'server_from_config',
    'specimen_fingerprint',
    'specimen_from_config',
]
