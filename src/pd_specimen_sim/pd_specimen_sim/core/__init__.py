"""Pure core of the specimen simulator: backbones, hysteresis, specimens, config, server."""

from __future__ import annotations

from .backbone import (BEYOND_MODES, Backbone, bilinear_backbone, load_backbone_csv,
                       load_opensees_pushover)
from .config import hysteresis_from_config, load_yaml, specimen_from_config
from .errors import BackboneError, HysteresisError, SpecimenConfigError, SpecimenError
from .errors_model import ErroneousStep, ErrorInjector, ErrorModel
from .hysteresis import (BilinearKinematic, Elastic, ElasticPerfectlyPlastic, HysteresisModel,
                         PushoverHysteresis)
from .server import Answer, SpecimenServer
from .specimen import TOPOLOGIES, Specimen

__all__ = [
    'Answer',
    'BEYOND_MODES',
    'Backbone',
    'BackboneError',
    'BilinearKinematic',
    'Elastic',
    'ElasticPerfectlyPlastic',
    'ErroneousStep',
    'ErrorInjector',
    'ErrorModel',
    'HysteresisError',
    'HysteresisModel',
    'PushoverHysteresis',
    'Specimen',
    'SpecimenConfigError',
    'SpecimenError',
    'SpecimenServer',
    'TOPOLOGIES',
    'bilinear_backbone',
    'hysteresis_from_config',
    'load_backbone_csv',
    'load_opensees_pushover',
    'load_yaml',
    'specimen_from_config',
]
