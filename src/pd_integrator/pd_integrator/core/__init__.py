"""The integrator's pure core (numpy/scipy/rosbags; never imports rclpy).

Science: ground motions, structure, integration schemes, stability. Test machinery: the test
definition schema, the step protocol, the session that runs a test, bags and outputs.
"""

from __future__ import annotations

from .config import PARAMETER_PATHS, TestDefinition, from_dict, from_json, load_test_file
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
from .messages import Command, Feedback, FeedbackStatus, Status, TestState
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
    'ConfigError',
    'Feedback',
    'FeedbackStatus',
    'GroundMotion',
    'GroundMotionError',
    'Integrator',
    'IntegratorError',
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
    'check_stability',
    'damping_from_ratio',
    'from_dict',
    'from_json',
    'load_test_file',
    'make_integrator',
    'modal_analysis',
    'omega_max',
    'period_distortion',
    'read_ground_motion',
    'require_stable',
]
