"""``run_test --faults``: where the fault proxies go in the plan (nothing is started)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pd_bringup.launcher import parse_args, plan_resumed_run
from pd_bringup.plan import (
    Child,
    LaunchError,
    LaunchPlan,
    attach_fault_reports,
    insert_fault_proxies,
    site_commands,
)
from pd_core.run.test_file import load_test_file
from support.paths import CONFIG

DEFAULT = CONFIG / 'default_test.yaml'
SITES = CONFIG / 'three_story_two_sites.yaml'
PLAN = 'drop=0.1,duplicate=0.1,delay=0.1,reorder=0.1,seed=3'
CANONICAL = 'drop=0.1,duplicate=0.1,delay=0.1,reorder=0.1,delay_s=0.05,seed=3'
REMAPS = ['-r', 'step_command:={ns}/behind/step_command',
          '-r', 'step_feedback:={ns}/behind/step_feedback',
          '-r', 'session/offer:={ns}/behind/session/offer',
          '-r', 'session/start:={ns}/behind/session/start']


def _children(test_file: Path, mode: str, out: Path) -> list[Child]:
    children, _ = site_commands(load_test_file(test_file), test_file, mode, None, out)
    return insert_fault_proxies(children, PLAN, out)


def _parameter(command: list[str], name: str) -> str:
    return next(item.split(':=', 1)[1] for item in command if item.startswith(f'{name}:='))


def test_direct_site_receiver_moves_behind_a_proxy(tmp_path: Path) -> None:
    children = _children(DEFAULT, 'direct', tmp_path)
    assert [(child.name, child.kind, child.namespace) for child in children] == [
        ('pd_specimen_sim', 'simulator', '/pd'), ('fault_proxy', 'proxy', '/pd')]
    simulator, proxy = children
    # The receiver keeps its namespace; its step-protocol topics go behind the proxy.
    assert '__ns:=/pd' in simulator.command
    assert simulator.command[-8:] == [item.format(ns='/pd') for item in REMAPS]
    assert _parameter(proxy.command, 'front') == '/pd'
    assert _parameter(proxy.command, 'back') == '/pd/behind'
    assert _parameter(proxy.command, 'faults') == CANONICAL
    report = tmp_path.resolve() / 'faults.json'
    assert _parameter(proxy.command, 'report_file') == str(report)
    assert proxy.state_file == str(report)  # a restarted proxy continues its counters
    assert proxy.restorable
    assert not any('key_file' in item or 'authentication' in item for item in proxy.command)


def test_bridge_site_proxy_is_in_front_of_the_bridge_not_the_simulator(tmp_path: Path) -> None:
    children = _children(DEFAULT, 'bridge', tmp_path)
    assert [child.name for child in children] == ['pd_specimen_sim', 'pd_actuator_bridge',
                                                  'fault_proxy']
    simulator, bridge, _ = children
    assert not any('/behind/' in item for item in simulator.command)  # behind the bridge
    assert bridge.command[-8:] == [item.format(ns='/pd') for item in REMAPS]
    assert '__ns:=/pd' in bridge.command  # its controls and status stay where they are


def test_every_site_of_a_substructured_test_gets_its_proxy(tmp_path: Path) -> None:
    children = _children(SITES, 'direct', tmp_path)
    proxies = {child.site: child for child in children if child.kind == 'proxy'}
    assert set(proxies) == {'lab1', 'lab3'}
    for site, proxy in proxies.items():
        assert proxy.name == f'fault_proxy[{site}]'
        assert _parameter(proxy.command, 'front') == f'/pd/{site}'
        assert _parameter(proxy.command, 'back') == f'/pd/{site}/behind'
        assert Path(proxy.state_file).name == f'faults-{site}.json'
    simulator = next(child for child in children if child.name == 'pd_specimen_sim[lab3]')
    assert simulator.command[-8:] == [item.format(ns='/pd/lab3') for item in REMAPS]


def test_bad_plan_or_no_receiver_is_refused_in_one_line(tmp_path: Path) -> None:
    children, _ = site_commands(load_test_file(DEFAULT), DEFAULT, 'direct', None, tmp_path)
    with pytest.raises(LaunchError, match=r"^--faults: fault plan: item 'drop=2': a probability"):
        insert_fault_proxies(children, 'drop=2', tmp_path)
    with pytest.raises(LaunchError, match=r'^--faults: no step receiver is started here'):
        insert_fault_proxies([], PLAN, tmp_path)
    run = tmp_path / 'run'
    run.mkdir()
    with pytest.raises(LaunchError, match=r'^--resume: takes no .*--faults'):
        plan_resumed_run(parse_args(['--resume', str(run), '--faults', PLAN]))


def test_the_counters_end_up_in_the_summary(tmp_path: Path) -> None:
    children = _children(DEFAULT, 'direct', tmp_path)
    plan = LaunchPlan(test_id='t', n_steps=1, out=tmp_path, site_mode='direct', physical=False,
                      key_file=None, environment={}, children=children, integrator=[])
    assert attach_fault_reports(plan) is None  # the proxy wrote nothing
    (tmp_path / 'summary.json').write_text(json.dumps({'state': 'finished'}), encoding='utf-8')
    counts = {'received': 5, 'forwarded': 5, 'dropped': 1, 'duplicated': 1, 'held': 0}
    (tmp_path / 'faults.json').write_text(json.dumps(
        {'faults': CANONICAL, 'step_command': counts, 'step_feedback': counts}),
        encoding='utf-8')
    faults = attach_fault_reports(plan)
    assert faults is not None and faults['totals']['dropped'] == 2
    summary = json.loads((tmp_path / 'summary.json').read_text(encoding='utf-8'))
    assert summary['faults']['proxies']['fault_proxy']['report'] == 'faults.json'
    assert summary['faults']['plan'] == CANONICAL
    # The plan with its proxy survives launch.json (./pd run --resume starts it again).
    plan.save()
    assert LaunchPlan.load(tmp_path).children == children
