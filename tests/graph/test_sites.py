"""Substructured tests through the node graph: two sites, each its own processes and namespace.

The integrator commands ``/pd/lab1`` and ``/pd/lab3`` (a simulator each, or a bridge in front of
a simulator each) and advances when both answered; the history equals the ROS-free run of the
same file float for float, the bag holds each site's stream, and the replay rebuilds the run.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any

import pytest
import yaml
from rosbags.highlevel import AnyReader

from pd_integrator.core.bag import read_bag
from pd_integrator.core.config import load_test_file
from pd_integrator.core.runner import rebuild_outputs, run_offline

from graph_support import REPO, Processes, executable
from test_graph import RUN_TIMEOUT, run_launcher, wait_exit

pytestmark = pytest.mark.graph

RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')


def two_site_test(path: Path, *, duration: float = 1.5) -> Path:
    """A 3-story building whose first and third stories are at sites lab1 and lab3."""
    raw = {
        'test': {'id': 'two-sites', 'dt': 0.005, 'duration': duration},
        'structure': {
            'dof_names': ['u1', 'u2', 'u3'], 'mass': [2.0e4, 2.0e4, 1.5e4],
            'damping': {'rayleigh': {'modes': [1, 3], 'ratios': [0.05, 0.05]}},
            'elements': [
                {'type': 'experimental', 'name': 'story1', 'site': 'lab1', 'dofs': ['u1'],
                 'initial_stiffness': 4.0e7},
                {'type': 'story', 'name': 'story2', 'dofs': ['u1', 'u2'], 'stiffness': 3.5e7},
                {'type': 'experimental', 'name': 'story3', 'site': 'lab3', 'dofs': ['u3'],
                 'relative_to': ['u2'], 'initial_stiffness': 3.0e7},
            ]},
        'ground_motion': {'file': str(RECORD), 'scale': 2.0},
        'sites': {
            'lab1': {'specimen': {'elements': [{'model': 'epp', 'stiffness': 4.0e7,
                                                'yield_force': 1.5e5}]},
                     'bridge': {'max_force': 1.0e6, 'max_increment': 0.01}},
            'lab3': {'specimen': {'elements': [{'model': 'elastic', 'stiffness': 3.0e7}]},
                     'bridge': {'max_force': 1.0e6, 'max_increment': 0.01}},
        },
        'protocol': {'start_timeout': 60.0},
    }
    path.write_text(yaml.safe_dump(raw), encoding='utf-8')
    return path


@pytest.fixture(scope='module')
def site_test(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The two-site test file and its ROS-free run."""
    directory = tmp_path_factory.mktemp('sites')
    test_file = two_site_test(directory / 'two_sites.yaml')
    out = directory / 'offline'
    result = run_offline(load_test_file(test_file), out, figures=False)
    assert result.summary['state'] == 'finished'
    return test_file, out


@pytest.mark.parametrize('site', ['direct', 'bridge'])
def test_two_sites_through_the_graph_match_the_ros_free_run(
        site: str, site_test: tuple[Path, Path], processes: Processes, tmp_path: Path) -> None:
    test_file, offline = site_test
    out = tmp_path / 'graph'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--site', site,
                                                    '--out', str(out), '--no-figures'])
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    log = processes.log('run_test')
    assert code == 0, log[-3000:]
    assert (out / 'response.csv').read_bytes() == (offline / 'response.csv').read_bytes()
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished'
    assert summary['sites'] == ['lab1', 'lab3']
    assert 'modal analysis' in log and 'sites: lab1, lab3' in log

    run = read_bag(out / 'bag')
    assert set(run.site_events) == {'lab1', 'lab3'}
    for events in run.site_events.values():
        commands = [item for _, item in events if type(item).__name__ == 'Command']
        assert len(commands) >= 301
    with AnyReader([out / 'bag']) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    for lab in ('lab1', 'lab3'):
        assert counts[f'/pd/{lab}/step_feedback'] >= 301
        if site == 'bridge':  # each site's bridge status, recorded on its own topic
            assert counts[f'/pd/{lab}/bridge/status'] >= 1
    assert counts['/pd/structure/step_command'] >= 301
    if site == 'bridge':
        assert any(status.message.startswith('active') for _, status in run.bridge_statuses)
    replay = rebuild_outputs(out / 'bag', tmp_path / 'replay', figures=False)
    assert (replay.directory / 'response.csv').read_bytes() == (
        out / 'response.csv').read_bytes()


def test_two_sites_on_three_hosts_match_the_one_host_run(
        site_test: tuple[Path, Path], netns_hub: Any, ros_env: dict[str, str],
        tmp_path: Path) -> None:
    """Integrator and two sites in three network namespaces (veth links, UDP only)."""
    test_file, offline = site_test
    ns = netns_hub('integrator', 'lab1', 'lab3')
    before = {name: ns.link_bytes(name) for name in ns.names}
    logs = {}
    started = []
    for lab, names in (('lab1', ['u1']), ('lab3', ['u3-u2'])):
        logs[lab] = (tmp_path / f'{lab}.log').open('wb')
        started.append(ns.popen(lab, [
            executable('pd_specimen_sim'), '--ros-args', '-r', f'__ns:=/pd/{lab}',
            '-p', f'test_file:={test_file}', '-p', f'site:={lab}',
            '-p', f'dof_names:={json.dumps(names)}'], ns.env(lab, ros_env),
            stdout=logs[lab], stderr=subprocess.STDOUT))
    out = tmp_path / 'multi-host'
    log_path = tmp_path / 'integrator.log'
    with log_path.open('wb') as log:
        integrator = ns.popen('integrator', [
            executable('pd_integrator'), '--ros-args', '-p', f'test_file:={test_file}',
            '-p', f'output_dir:={out}', '-p', 'figures:=false'],
            ns.env('integrator', ros_env), stdout=log, stderr=subprocess.STDOUT)
        code = wait_exit(integrator, RUN_TIMEOUT,
                         lambda: log_path.read_text(encoding='utf-8', errors='replace'))
    text = log_path.read_text(encoding='utf-8', errors='replace')
    assert code == 0, text[-3000:]
    assert (out / 'response.csv').read_bytes() == (offline / 'response.csv').read_bytes()
    # Every step crossed the links: each site's veth carried its commands and answers.
    for lab in ('lab1', 'lab3'):
        grown = {way: ns.link_bytes(lab)[way] - before[lab][way] for way in ('rx', 'tx')}
        assert grown['rx'] > 301 * 100 and grown['tx'] > 301 * 100, (lab, grown)
    assert all(process.poll() is None for process in started)  # the sites are still serving
    for handle in logs.values():
        handle.close()
