"""A plug-in's driver runs a test through the node graph.

The example plug-in (``tests/plugins/pd_plugin_example``) is installed into a folder on the
nodes' ``PYTHONPATH``; the bridge's parameter file selects its driver ``spring_rig`` (an
in-process rig on a linear spring) with its declared parameter ``spring_stiffness``. The
spring is the test file's elastic specimen, so the run's ``response.csv`` is byte for byte the
ROS-free run's of that file.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
import yaml
from graph_support import REPO, Processes
from test_graph import RUN_TIMEOUT, run_launcher, wait_exit

from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file
from support.plugin_package import install_example_plugin

pytestmark = pytest.mark.graph

RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')
K = 312559.0  # N/m


def test_a_plugin_driver_runs_a_test_through_the_graph(processes: Processes,
                                                       tmp_path: Path) -> None:
    site = install_example_plugin(tmp_path / 'plugin')
    processes.env['PYTHONPATH'] = os.pathsep.join(
        [str(site), *filter(None, [processes.env.get('PYTHONPATH')])])
    test_file = tmp_path / 'spring.yaml'
    test_file.write_text(yaml.safe_dump({
        'test': {'id': 'spring', 'scheme': 'newmark_explicit', 'dt': 0.01, 'duration': 2.0},
        'structure': {'dof_names': ['top'], 'mass': 2543.4, 'damping': {'ratio': 0.05},
                      'initial_stiffness': K, 'influence': [1.0]},
        'ground_motion': {'file': str(RECORD), 'units': 'g', 'g': 9.81},
        'specimen': {'elements': [{'model': 'elastic', 'stiffness': K}]},
    }), encoding='utf-8')
    bridge = tmp_path / 'bridge.yaml'
    bridge.write_text(yaml.safe_dump({'/**': {'ros__parameters': {
        'driver': 'spring_rig', 'spring_stiffness': K, 'autostart': True,
        'max_displacement': 0.25, 'max_increment': 0.02, 'max_force': 100000.0}}}),
        encoding='utf-8')
    offline = run_offline(load_test_file(test_file), tmp_path / 'offline', figures=False)
    assert offline.summary['state'] == 'finished'

    out = tmp_path / 'graph'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--bridge-params',
                                                    str(bridge), '--out', str(out),
                                                    '--no-figures'])
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    log = processes.log('run_test')
    assert code == 0, log[-3000:]
    assert (out / 'response.csv').read_bytes() == (tmp_path / 'offline' /
                                                   'response.csv').read_bytes()
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished'
    assert summary['specimen_side']['default']['driver'] == 'spring_rig'
