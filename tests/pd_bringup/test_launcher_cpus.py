"""``run_test --cpus KIND=CPUS``: each kind of process on the CPUs given, recorded for resume.

Two processes that answer each other step by step (the integrator and a simulator, or the
integrator and a real-time bridge) lose most of a step to waking each other across CPUs on a
small machine; placing them is a launch option, checked here from its parsing to the CPUs a
started process actually runs on.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from pd_bringup.launcher import parse_args, plan_resumed_run
from pd_bringup.plan import LaunchError, parse_cpus
from pd_bringup.supervisor import _child_setup
from support.paths import CONFIG
from support.run_folders import stopped_run

DEFAULT = CONFIG / 'default_test.yaml'
AVAILABLE = {0, 1, 2, 3}


def test_cpus_are_parsed_per_kind() -> None:
    assert parse_cpus(['integrator=0', 'bridge=1-3', 'simulator=0,2'], AVAILABLE) == {
        'integrator': [0], 'bridge': [1, 2, 3], 'simulator': [0, 2]}
    assert parse_cpus([], AVAILABLE) == {}


@pytest.mark.parametrize(('items', 'message'), [
    (['robot=0'], "--cpus robot=0: 'robot' is not a kind of process (integrator, bridge, "),
    (['bridge=a'], "--cpus bridge=a: 'a' is not a list of CPUs"),
    (['bridge='], "--cpus bridge=: '' is not a list of CPUs"),
    (['bridge=3-1'], "--cpus bridge=3-1: '3-1' is not a list of CPUs"),
    (['bridge=1', 'bridge=2'], '--cpus bridge=2: bridge is placed twice'),
    (['bridge=4'], '--cpus bridge=4: CPU 4 not available (this test may use 0, 1, 2, 3)'),
])
def test_bad_cpus_are_one_line_naming_the_option(items: list[str], message: str) -> None:
    with pytest.raises(LaunchError) as error:
        parse_cpus(items, AVAILABLE)
    assert str(error.value).startswith(message)
    assert '\n' not in str(error.value)


def test_a_started_process_runs_on_its_cpus() -> None:
    """The child is placed before it runs (every thread it makes inherits the CPUs)."""
    cpu = min(os.sched_getaffinity(0))
    script = ('import os, threading\n'
              'seen = []\n'
              't = threading.Thread(target=lambda: seen.append(sorted(os.sched_getaffinity(0))))\n'
              't.start(); t.join()\n'
              'print(sorted(os.sched_getaffinity(0)), seen[0])')
    done = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True,
                          preexec_fn=_child_setup(None, [cpu]), check=True, timeout=30)
    assert done.stdout.split() == [f'[{cpu}]', f'[{cpu}]']
    assert _child_setup(None, None) is None  # nothing to do: no preexec_fn at all


def test_the_placement_is_recorded_and_resumed(tmp_path: Path) -> None:
    cpu = min(os.sched_getaffinity(0))
    plan = stopped_run(tmp_path / 'run', DEFAULT, '--cpus', f'integrator={cpu}',
                       '--cpus', f'bridge={cpu}')
    assert plan.cpus == {'integrator': [cpu], 'bridge': [cpu]}
    recorded = json.loads((tmp_path / 'run' / 'launch.json').read_text(encoding='utf-8'))
    assert recorded['cpus'] == {'integrator': [cpu], 'bridge': [cpu]}
    resumed = plan_resumed_run(parse_args(['--resume', str(tmp_path / 'run')]))
    assert resumed.cpus == plan.cpus
    anew = plan_resumed_run(parse_args(['--resume', str(tmp_path / 'run'),
                                        '--cpus', f'simulator={cpu}']))
    assert anew.cpus == {'simulator': [cpu]}


def test_a_recorded_cpu_this_machine_lacks_is_one_line_on_resume(tmp_path: Path) -> None:
    stopped_run(tmp_path / 'run', DEFAULT)
    path = tmp_path / 'run' / 'launch.json'
    data = json.loads(path.read_text(encoding='utf-8'))
    absent = max(os.sched_getaffinity(0)) + 1
    data['cpus'] = {'bridge': [absent]}
    path.write_text(json.dumps(data), encoding='utf-8')
    with pytest.raises(LaunchError) as error:
        plan_resumed_run(parse_args(['--resume', str(tmp_path / 'run')]))
    assert str(error.value).startswith(
        f'{path}: bridge={absent}: CPU {absent} not available')
    assert str(error.value).endswith('(place them anew with --cpus)')
    data['cpus'] = {'bridge': ['one']}
    path.write_text(json.dumps(data), encoding='utf-8')
    with pytest.raises(LaunchError, match='cpus: not CPU numbers per kind of process'):
        plan_resumed_run(parse_args(['--resume', str(tmp_path / 'run')]))
