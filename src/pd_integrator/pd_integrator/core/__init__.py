"""The integrator's pure core (numpy/scipy/rosbags; never imports rclpy).

Science: ground motions, structure, integration schemes, stability. Test machinery: the test
definition schema, the step protocol, the session that runs a test, bags and outputs.
"""

from __future__ import annotations

from .config import PARAMETER_PATHS, TestDefinition, from_dict, from_json, load_test_file
from .elements import (
    Condensation,
    ModalProperties,
    assemble,
    beam_column_2d_stiffness,
    modal_damping,
    modal_properties,
    rayleigh_coefficients,
    rayleigh_damping,
    spring_stiffness,
    static_condensation,
)
from .errors import (
    BagError,
    ConfigError,
    GroundMotionError,
    IntegratorError,
    PdIntegratorError,
    ProtocolError,
    StabilityError,
)
from .ground_motion import GroundMotion, read_ground_motion
from .history import ResponseHistory
from pd_common.protocol import Command, Feedback, FeedbackStatus, Status, TestState
from .protocol import StepProtocol, Verdict
from .schemes import SCHEMES, Integrator, NewmarkExplicit, make_integrator
from .session import TestSession
from .stability import StabilityReport, check_stability, period_distortion, require_stable
from .structure import Structure, damping_from_ratio, modal_analysis, omega_max

__all__ = [
    'PARAMETER_PATHS',
    'SCHEMES',
    'BagError',
    'Command',
    'Condensation',
    'ConfigError',
    'Feedback',
    'FeedbackStatus',
    'GroundMotion',
    'GroundMotionError',
    'Integrator',
    'IntegratorError',
    'ModalProperties',
    'NewmarkExplicit',
    'PdIntegratorError',
    'ProtocolError',
    'ResponseHistory',
    'StabilityError',
    'StabilityReport',
    'Status',
    'StepProtocol',
    'Structure',
    'TestDefinition',
    'TestSession',
    'TestState',
    'Verdict',
    'assemble',
    'beam_column_2d_stiffness',
    'check_stability',
    'damping_from_ratio',
    'from_dict',
    'from_json',
    'load_test_file',
    'make_integrator',
    'modal_analysis',
    'modal_damping',
    'modal_properties',
    'omega_max',
    'period_distortion',
    'rayleigh_coefficients',
    'rayleigh_damping',
    'read_ground_motion',
    'require_stable',
    'spring_stiffness',
    'static_condensation',
]
