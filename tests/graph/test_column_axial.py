"""Force and mixed control through the node graph: the thesis's column under its axial load.

The integrator, the site's bridge and its simulator run as separate processes. The vertical
actuator holds the axial load in force control (ramped by the bridge, never jumped) while the
horizontal one follows the integrator: the lateral history equals the ROS-free run byte for
byte, and the axial force stays at its target for the whole test. A column too soft axially
lets the force-controlled actuator run away in stroke: the bridge's stroke limit holds it. A
process killed mid-test is restarted with its state and the test ends as the uninterrupted
ROS-free run: the restarted bridge holds the load the column carries (it ramps from the measured
force, never from 0 N), the restarted simulator replays its mixed commands, the restarted
integrator resumes from its journal.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import time
from pathlib import Path
from typing import Any

import pytest
import yaml
from graph_support import REPO, Processes, send_control
from test_crash_resume import child_of, wait_for_step
from test_graph import RUN_TIMEOUT, latched_qos, run_launcher, spin_until, wait_exit

from pd_common.protocol import Feedback, FeedbackStatus
from pd_core.run.record.bag import read_bag
from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file

pytestmark = pytest.mark.graph

EXAMPLE = REPO / 'src' / 'pd_integrator' / 'config' / 'column_axial.yaml'
RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')
LOAD = 24950.0  # N, the example's axial load
#: Axial force tolerance [N]: the simulator solves the force to 1e-10 relative.
FORCE_TOLERANCE = 1e-6 * LOAD


def _column_test(path: Path, duration: float, **site: Any) -> Path:
    raw = yaml.safe_load(EXAMPLE.read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(RECORD)
    raw['test'].update(duration=duration, id=path.stem)
    for key, value in site.items():
        section, name = key.split('__')
        if section == 'bridge':
            raw['sites']['lab']['bridge'][name] = value
        else:
            raw['sites']['lab']['specimen']['column'][name] = value
    path.write_text(yaml.safe_dump(raw), encoding='utf-8')
    return path


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(encoding='utf-8', newline='') as handle:
        return list(csv.DictReader(handle))


def _served_forces(out: Path) -> list[float]:
    """The vertical actuator's force of every command the simulator served, in order (its
    state file: what the bridge really sent it, each sub-step once)."""
    lines = (out / 'specimen-lab.state.jsonl').read_text(encoding='utf-8').splitlines()[1:]
    served = [json.loads(line) for line in lines if line.strip()]
    assert all(len(item) == 6 and item[4] == [0, 1] for item in served)  # mixed, every one
    return [float(item[5][1]) for item in served]


def test_column_under_axial_load_through_the_bridge_equals_the_ros_free_run(
        processes: Processes, tmp_path: Path) -> None:
    test_file = _column_test(tmp_path / 'column-graph.yaml', 3.0)
    reference = run_offline(load_test_file(test_file), tmp_path / 'offline', figures=False)
    increment = 2500.0  # the example's max_force_increment
    out = tmp_path / 'graph'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--site', 'bridge',
                                                    '--out', str(out), '--no-figures'])
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    assert code == 0, processes.log('run_test')[-3000:]

    # The lateral history (and every actuator's) equals the ROS-free run byte for byte.
    assert (out / 'response.csv').read_bytes() == (
        reference.directory / 'response.csv').read_bytes()
    assert (out / 'actuators.csv').read_bytes() == (
        reference.directory / 'actuators.csv').read_bytes()
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished' and summary['steps'] == 300

    # The axial force held its target at every committed step (the ramp ends within step 0).
    rows = _rows(out / 'actuators.csv')
    assert len(rows) == 301
    assert all(row['mode_vertical'] == '1' and float(row['command_vertical']) == LOAD
               for row in rows)
    errors = [abs(float(row['force_vertical']) - LOAD) for row in rows]
    assert max(errors) <= FORCE_TOLERANCE, max(errors)
    assert max(abs(float(row['column.u'])) for row in rows) > 0.02  # the column did move

    # The load was ramped by the bridge, never jumped: 0 -> 24,950 N in ten sub-steps, then
    # held (one served command per step).
    forces = _served_forces(out)
    ramp = [force for force in forces if force < LOAD]
    assert len(ramp) == 9 and forces[9:] == [LOAD] * 301
    steps = [b - a for a, b in zip([0.0, *forces[:-1]], forces)]
    assert max(abs(step) for step in steps) <= increment * (1 + 1e-9)


def test_a_runaway_force_controlled_actuator_is_held_by_its_stroke_limit(
        rig_key: Any, processes: Processes, observer: Any, tmp_path: Path) -> None:
    from pd_msgs.msg import TestStatus

    # Axially far too soft: under 24,950 N the top would sink 0.5 m; the stroke limit is
    # 0.3 m, reached at the seventh 2,495 N sub-step of the ramp (0.35 m).
    limit = 0.3
    test_file = _column_test(tmp_path / 'column-runaway.yaml', 1.0,
                             column__axial_stiffness=5.0e4, bridge__max_increment=1.0,
                             bridge__max_displacement=limit)
    statuses: list[Any] = []
    observer.create_subscription(TestStatus, '/pd/test_status', statuses.append, latched_qos())
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--site', 'bridge',
                                                    '--out', str(out), '--no-figures'])
    spin_until(observer, lambda: any(s.state == TestStatus.STATE_HOLDING for s in statuses),
               RUN_TIMEOUT, 'the integrator to hold')
    holding = next(s for s in statuses if s.state == TestStatus.STATE_HOLDING)
    assert 'vertical' in holding.message and 'max_displacement' in holding.message, (
        holding.message)
    time.sleep(0.5)  # nothing moves while holding
    for _ in range(10):
        observer.executor_for_test.spin_once(timeout_sec=0.05)
    send_control(observer, rig_key, 'abort')
    assert wait_exit(launcher, 30.0, lambda: processes.log('run_test')) == 1

    # The ramp stopped at the sub-step that showed the runaway: never the full load.
    forces = _served_forces(out)
    assert forces and max(forces) < LOAD
    assert len(forces) == 7, forces
    run = read_bag(out / 'bag')
    refused = [item for _, item in run.site_events['lab']
               if isinstance(item, Feedback) and item.status is FeedbackStatus.LIMIT]
    assert refused and refused[0].step == 0
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'aborted'


@pytest.mark.parametrize('kind', ['integrator', 'simulator', 'bridge'])
def test_a_process_killed_under_the_axial_load_is_restarted_and_the_test_is_unchanged(
        kind: str, processes: Processes, tmp_path: Path) -> None:
    test_file = _column_test(tmp_path / f'column-kill-{kind}.yaml', 3.0)
    reference = run_offline(load_test_file(test_file), tmp_path / 'offline', figures=False)
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--site', 'bridge',
                                                    '--out', str(out), '--no-figures'])
    wait_for_step(out, 120, launcher, processes)
    os.kill(child_of(launcher, kind), signal.SIGKILL)
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    log = processes.log('run_test')
    assert code == 0, log[-3000:]
    assert 'SIGKILL' in log and 'restart' in log
    for name in ('response.csv', 'actuators.csv'):
        assert (out / name).read_bytes() == (reference.directory / name).read_bytes(), name
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished' and summary['restarts'] == 1
    forces = _served_forces(out)  # the simulator's record, across its restart if any
    assert forces[:10] == pytest.approx([2495.0 * k for k in range(1, 11)], rel=1e-15)
    assert forces[10:] == [LOAD] * (len(forces) - 10)  # after the ramp, never another force
    if kind == 'bridge':
        assert 'holding the measured forces' in log
