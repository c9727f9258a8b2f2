"""Specimen models, their config schema and the step server.

The models: backbones, hysteresis, specimens (a column with P-Δ among them).

The simulator node and the ROS-free runner answer step commands with a
:class:`SpecimenServer`; the integrator's numerical springs and the bridge's emulator use the
same hysteresis models.
"""

from __future__ import annotations

from ..errors import (
    BackboneError,
    HysteresisError,
    SpecimenConfigError,
    SpecimenError,
    StateFileError,
)
from .backbone import (
    BEYOND_MODES,
    Backbone,
    bilinear_backbone,
    load_backbone_csv,
    load_opensees_pushover,
)
from .bouc_wen import BoucWen
from .column import ColumnSpecimen, hysteresis_tangent
from .config import (
    hysteresis_from_config,
    load_specimen_section,
    model_from_config,
    specimen_from_config,
)
from .hysteresis import (
    MEMORY_MODES,
    BilinearKinematic,
    Elastic,
    ElasticPerfectlyPlastic,
    HysteresisModel,
    PushoverHysteresis,
)
from .models import (
    HYSTERESIS_MODELS,
    ElementReader,
    HysteresisModelSpec,
    register_hysteresis_model,
)
from .served import ServedRecord, restore_served, specimen_fingerprint
from .server import (
    SiteGeometry,
    SpecimenServer,
    load_site_server,
    server_from_config,
    site_geometry,
)
from .specimen import TOPOLOGIES, Specimen

__all__ = [
    'BEYOND_MODES',
    'HYSTERESIS_MODELS',
    'MEMORY_MODES',
    'TOPOLOGIES',
    'Backbone',
    'BackboneError',
    'BilinearKinematic',
    'BoucWen',
    'ColumnSpecimen',
    'Elastic',
    'ElasticPerfectlyPlastic',
    'ElementReader',
    'HysteresisError',
    'HysteresisModel',
    'HysteresisModelSpec',
    'PushoverHysteresis',
    'ServedRecord',
    'SiteGeometry',
    'Specimen',
    'SpecimenConfigError',
    'SpecimenError',
    'SpecimenServer',
    'StateFileError',
    'bilinear_backbone',
    'hysteresis_from_config',
    'hysteresis_tangent',
    'load_backbone_csv',
    'load_opensees_pushover',
    'load_site_server',
    'load_specimen_section',
    'model_from_config',
    'register_hysteresis_model',
    'restore_served',
    'server_from_config',
    'site_geometry',
    'specimen_fingerprint',
    'specimen_from_config',
]
