"""A faulty link between the integrator and its step receiver: ``run_test --faults``.

The fault proxy drops, duplicates, delays and reorders step commands and feedback; with a
short feedback timeout and enough re-sends the test still finishes, and its record is the
ROS-free run's (``./pd offline``) byte for byte: a lost message is re-sent, a duplicated,
reordered or late one is refused or ignored, never committed twice or out of turn.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from graph_support import Processes, executable
from test_graph import run_launcher, wait_exit, write_test_file

from pd_bringup.faults import FaultPlan

pytestmark = pytest.mark.graph

PLAN = 'drop=0.1,duplicate=0.1,delay=0.1,reorder=0.1,seed=3'
STEPS = 100
RUN_TIMEOUT = 45.0


def test_faulty_link_run_finishes_and_matches_the_offline_run(processes: Processes,
                                                               tmp_path: Path) -> None:
    # 1 s of El Centro (100 steps); a lost message is re-sent after 0.1 s (twice delay_s),
    # up to 50 times in a row.
    test_file = write_test_file(tmp_path / 'faults.yaml', test__duration=STEPS * 0.01,
                                test__id='graph-faults', protocol__feedback_timeout=0.1,
                                protocol__max_retries=50)
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [
        str(test_file), '--site', 'direct', '--out', str(out), '--no-figures',
        '--faults', PLAN])
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    log = processes.log('run_test')
    assert code == 0, log[-3000:]

    offline = tmp_path / 'offline'
    subprocess.run([executable('pd_integrator', 'offline'), str(test_file), '--out',
                    str(offline), '--no-figures'], env=processes.env, check=True,
                   capture_output=True, timeout=30)
    assert (out / 'response.csv').read_bytes() == (offline / 'response.csv').read_bytes()

    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished'
    assert summary['steps'] == STEPS
    assert summary['retries'] > 0  # the dropped messages were re-sent
    faults = summary['faults']
    assert faults['plan'] == str(FaultPlan.parse(PLAN))
    proxy = faults['proxies']['fault_proxy']
    assert proxy['report'] == 'faults.json'
    assert (proxy['front'], proxy['back'], proxy['state']) == ('/pd', '/pd/behind', 'stopped')
    report = json.loads((out / 'faults.json').read_text(encoding='utf-8'))
    assert {key: report[key] for key in ('step_command', 'step_feedback')} == {
        key: proxy[key] for key in ('step_command', 'step_feedback')}
    for direction in ('step_command', 'step_feedback'):
        counts = proxy[direction]
        assert counts['received'] >= STEPS + 1  # step 0 and every integration step
        # Every kind of fault happened, in each direction.
        for kind in ('dropped', 'duplicated', 'delayed', 'reordered'):
            assert counts[kind] > 0, (direction, counts)
        assert (counts['forwarded'] + counts['held']
                == counts['received'] - counts['dropped'] + counts['duplicated'])
        assert counts['reordered'] == (counts['reorder_swapped'] + counts['reorder_released']
                                       + counts['reorder_expired'])
    totals = faults['totals']
    assert totals['received'] == (proxy['step_command']['received']
                                  + proxy['step_feedback']['received'])
    assert proxy['session']['starts_forwarded'] >= 1
    assert 'run_test: faults (' in log
