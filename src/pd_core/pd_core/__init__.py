"""The pure core of a pseudo-dynamic test (numpy/scipy/rosbags; never imports rclpy).

A library package: the integrator node (``pd_integrator``) is its ROS shell, and the tools
(``pd_console``, ``pd_pretest``, ``pd_scheme_analysis``, ``pd_studies``, ``pd_rths_benchmark``)
and the bring-up build on it; none of them imports another.

Four groups, each a subpackage, layered from the bottom up:

* :mod:`.schemes` — the integration schemes behind one interface and one registry;
* :mod:`.dynamics` — structure, ground motions, stability and accuracy analysis;
* :mod:`.model` — the numerical model of a substructured test (elements, setups);
* :mod:`.run` — the test machinery: definition, step protocol, session, bag, outputs.

Plus :mod:`.verification` (exact solutions), :mod:`.matrices` (input checks of matrices) and
:mod:`.errors`. The step protocol's data types live in :mod:`pd_common.protocol`.
"""

from __future__ import annotations

from .dynamics import (
    GroundMotion,
    StabilityReport,
    Structure,
    check_stability,
    read_ground_motion,
    require_stable,
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
from .run import StepProtocol, TestDefinition, TestSession, Verdict, load_test_file
from .schemes import SCHEMES, Integrator, NewmarkExplicit, make_integrator

__all__ = [
    'SCHEMES',
    'BagError',
    'ConfigError',
    'GroundMotion',
    'GroundMotionError',
    'Integrator',
    'IntegratorError',
    'NewmarkExplicit',
    'PdIntegratorError',
    'ProtocolError',
    'StabilityError',
    'StabilityReport',
    'StepProtocol',
    'Structure',
    'TestDefinition',
    'TestSession',
    'Verdict',
    'check_stability',
    'load_test_file',
    'make_integrator',
    'read_ground_motion',
    'require_stable',
]
