"""The numerical model of a substructured test (OpenFresco's element and setup layers).

* :mod:`.elements` — element matrices (springs, beam-columns), assembly, static condensation;
* :mod:`.damping` — Rayleigh and modal damping;
* :mod:`.modes` — modal properties: participation factors, effective modal masses, report;
* :mod:`.setups` — experimental setups: basic DOFs ↔ actuator strokes;
* :mod:`.substructure` — the :class:`StructuralModel`: linear part, nonlinear springs and
  experimental elements;
* :mod:`.parse` — the ``structure.elements`` section of a test file.
"""

from __future__ import annotations

from .damping import modal_damping, rayleigh_coefficients, rayleigh_damping
from .elements import (
    Condensation,
    assemble,
    beam_column_2d_stiffness,
    spring_stiffness,
    static_condensation,
)
from .modes import ModalProperties, modal_properties
from .parse import parse_elements
from .setups import ExperimentalSetup, OneToOneSetup, RigidLinkTwoActuators, setup_from_config
from .substructure import ExperimentalElement, NonlinearSpring, StructuralModel

__all__ = [
    'Condensation',
    'ExperimentalElement',
    'ExperimentalSetup',
    'ModalProperties',
    'NonlinearSpring',
    'OneToOneSetup',
    'RigidLinkTwoActuators',
    'StructuralModel',
    'assemble',
    'beam_column_2d_stiffness',
    'modal_damping',
    'modal_properties',
    'parse_elements',
    'rayleigh_coefficients',
    'rayleigh_damping',
    'setup_from_config',
    'spring_stiffness',
    'static_condensation',
]
