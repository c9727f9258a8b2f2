"""Test configuration: make the pure cores importable straight from the source tree."""

from __future__ import annotations

import os
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
TESTS = str(REPO / 'tests')  # the shared helpers: ``support``
if TESTS not in sys.path:
    sys.path.insert(0, TESTS)
for package in ('pd_common', 'pd_integrator', 'pd_specimen_sim', 'pd_actuator_bridge',
                'pd_bringup'):
    path = str(REPO / 'src' / package)
    if path not in sys.path:
        sys.path.insert(0, path)

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
