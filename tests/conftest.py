"""Test configuration: make the pure cores importable straight from the source tree."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

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

GRAPH_TESTS = REPO / 'tests' / 'graph'


@pytest.hookimpl(tryfirst=True)  # before ``-m`` selects: the mark must be there to be seen
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Every test under ``tests/graph`` is a graph test, marked or not: ``./pd test`` runs the
    others on every CPU and these alone, one at a time (they start node processes)."""
    for item in items:
        if GRAPH_TESTS in item.path.parents:
            item.add_marker(pytest.mark.graph)
