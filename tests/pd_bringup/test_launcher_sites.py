"""What run_test starts for a substructured test (the command lines; nothing is started)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml

from pd_bringup.launcher import main, print_summary
from pd_bringup.plan import opensees_command, site_commands
from pd_common.config import read_yaml_file
from pd_common.config.schema_test_file import OpenSeesSite
from pd_core.errors import ConfigError
from pd_core.run.test_file import load_test_file

EXAMPLE = (Path(__file__).resolve().parents[2] / 'src' / 'pd_integrator' / 'config'
           / 'three_story_two_sites.yaml')


def _commands(mode: str, out: Path) -> dict[str, list[str]]:
    children, physical = site_commands(load_test_file(EXAMPLE), EXAMPLE, mode, None, out)
    assert not physical  # every site is simulated
    return {child.name: child.command for child in children}


def test_each_site_gets_its_namespace_its_names_and_its_bridge_limits(tmp_path: Path) -> None:
    definition = load_test_file(EXAMPLE)
    commands = _commands('bridge', tmp_path)
    assert set(commands) == {'pd_specimen_sim[lab1]', 'pd_actuator_bridge[lab1]',
                             'pd_specimen_sim[lab3]', 'pd_actuator_bridge[lab3]'}
    simulator = commands['pd_specimen_sim[lab3]']
    assert '__ns:=/pd/lab3/specimen' in simulator
    assert 'site:=lab3' in simulator
    assert f'dof_names:={json.dumps(["u3-u2"])}' in simulator
    bridge = commands['pd_actuator_bridge[lab1]']
    assert '__ns:=/pd/lab1' in bridge
    assert 'max_force:=1000000.0' in bridge and 'max_displacement:=0.1' in bridge
    direct = _commands('direct', tmp_path)
    assert set(direct) == {'pd_specimen_sim[lab1]', 'pd_specimen_sim[lab3]'}
    assert '__ns:=/pd/lab1' in direct['pd_specimen_sim[lab1]']
    # Each simulated site keeps its own state file in the run folder (restored on restart).
    state_files = {name: [a for a in command if a.startswith('state_file:=')]
                   for name, command in direct.items()}
    assert state_files == {
        'pd_specimen_sim[lab1]': [f'state_file:={tmp_path / "specimen-lab1.state.jsonl"}'],
        'pd_specimen_sim[lab3]': [f'state_file:={tmp_path / "specimen-lab3.state.jsonl"}']}
    assert site_commands(definition, EXAMPLE, 'none', None, tmp_path) == ([], True)


def _two_sites(folder: Path, **lab1: Any) -> Path:
    """The two-site example with ``sites.lab1`` changed (its record found from ``folder``)."""
    raw = read_yaml_file(EXAMPLE)
    raw['ground_motion']['file'] = str(EXAMPLE.parent / raw['ground_motion']['file'])
    raw['sites']['lab1'] = {**raw['sites']['lab1'], **lab1}
    path = folder / 'two_sites.yaml'
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    return path


def test_opensees_site_options_come_from_the_typed_settings(tmp_path: Path) -> None:
    definition = load_test_file(EXAMPLE)
    command = opensees_command(OpenSeesSite(model='epp', stiffness=1.0e5, yield_force=2.0e3),
                               45001, definition)
    assert command[1:] == ['--port', '45001', '--quiet', '--model', 'epp', '--stiffness',
                           '100000.0', '--yield-force', '2000.0']
    script = opensees_command(OpenSeesSite(script='model.py'), 45001, definition)
    assert script[script.index('--model') + 1] == 'script'
    assert Path(script[script.index('--script') + 1]) == EXAMPLE.parent / 'model.py'
    # the test file's opensees mapping reaches the plan typed: an OpenSees process per site
    path = _two_sites(tmp_path, opensees={'model': 'elastic', 'stiffness': 40000000})
    children, _ = site_commands(load_test_file(path), path, 'bridge', None, tmp_path)
    opensees = {child.name: child.command for child in children}['opensees_site[lab1]']
    assert opensees[opensees.index('--stiffness') + 1] == '40000000.0'
    # a bad key is refused when the file is read, one line naming the dotted path
    bad = _two_sites(tmp_path, opensees={'stifness': 1.0})
    with pytest.raises(ConfigError) as info:
        load_test_file(bad)
    assert str(info.value) == 'two_sites.yaml: sites.lab1.opensees.stifness: unknown key'


def test_a_sites_bridge_parameters_reach_its_bridge_typed(tmp_path: Path) -> None:
    # an integer limit is a double, as the bridge declares it (an integer ROS parameter
    # would be refused by the node); only the keys the user set are passed on
    path = _two_sites(tmp_path, bridge={'max_force': 1000000, 'autostart': True})
    children, _ = site_commands(load_test_file(path), path, 'bridge', None, tmp_path)
    bridge = {child.name: child.command for child in children}['pd_actuator_bridge[lab1]']
    given = [item for item in bridge if item.startswith(('max_', 'autostart', 'driver'))]
    assert given == ['max_force:=1000000.0', 'autostart:=true']
    # a site given as null has no settings: its bridge gets the parameter file's
    path = _two_sites(tmp_path)
    raw = read_yaml_file(path)
    raw['sites']['lab3'] = None
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    children, _ = site_commands(load_test_file(path), path, 'bridge', None, tmp_path)
    bridge = {child.name: child.command for child in children}['pd_actuator_bridge[lab3]']
    assert not [item for item in bridge if item.startswith('max_')]


@pytest.mark.parametrize(('bridge', 'message'), [
    ({'max_forse': 1.0}, 'two_sites.yaml: sites.lab1.bridge.max_forse: unknown key'),
    ({'max_force_increment': -5.0},
     'two_sites.yaml: sites.lab1.bridge.max_force_increment: must be >= 0, got -5.0'),
    ({'driver': 'Sim Servo'},
     "two_sites.yaml: sites.lab1.bridge.driver: must match ^[a-z][a-z0-9_]*$, got 'Sim Servo'"),
])
def test_a_bad_site_bridge_mapping_through_run_test_is_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], bridge: dict[str, Any],
        message: str) -> None:
    out = tmp_path / 'run'
    path = _two_sites(tmp_path, bridge=bridge)
    assert main([str(path), '--site', 'bridge', '--out', str(out), '--no-figures']) == 2
    assert capsys.readouterr().err == f'run_test: error: {message}\n'
    assert not out.exists()


def test_summary_lines_of_a_run_that_committed_nothing_and_of_one_that_did(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / 'summary.json').write_text(json.dumps({
        'state': 'aborted', 'steps': 0, 'wall_time': 0.0, 'message': 'no specimen side',
        'dofs': {'top': {'peaks': {}, 'residual_displacement': None}}}), encoding='utf-8')
    print_summary(tmp_path)
    assert capsys.readouterr().out.splitlines() == [
        f'run_test: aborted (no specimen side): 0 steps in 0.00 s; outputs in {tmp_path}']
    (tmp_path / 'summary.json').write_text(json.dumps({
        'state': 'finished', 'steps': 10, 'wall_time': 1.5, 'restarts': 1,
        'dofs': {'top': {'peaks': {'displacement': {'value': 0.0494, 'time': 4.97},
                                   'restoring_force': {'value': 10085.0}},
                         'residual_displacement': 0.00276},
                 'small': {'peaks': {'displacement': {'value': -2.5e-4, 'time': 1.0},
                                     'restoring_force': {'value': 0.987}},
                           'residual_displacement': 0.0}},
        'collapse': {'message': 'COLLAPSE of top at step 9'}}), encoding='utf-8')
    print_summary(tmp_path)
    assert capsys.readouterr().out.splitlines() == [
        ('run_test: top: peak displacement 49.400 mm at 4.97 s, peak force 10.085 kN, '
         'residual 2.7600 mm'),
        ('run_test: small: peak displacement -250.00 µm at 1.00 s, peak force 0.98700 N, '
         'residual 0 m'),
        'run_test: COLLAPSE of top at step 9',
        f'run_test: finished: 10 steps in 1.50 s, 1 restart(s); outputs in {tmp_path}']
    # run_test's restarts and a person's resumes told apart
    (tmp_path / 'summary.json').write_text(json.dumps({
        'state': 'finished', 'steps': 10, 'wall_time': 1.5, 'restarts': 2, 'resumes': 1}),
        encoding='utf-8')
    print_summary(tmp_path)
    assert capsys.readouterr().out.splitlines()[-1] == (
        f'run_test: finished: 10 steps in 1.50 s, 2 restart(s), 1 resume(s); outputs in '
        f'{tmp_path}')
    (tmp_path / 'summary.json').unlink()
    print_summary(tmp_path)
    assert 'no summary.json' in capsys.readouterr().out
