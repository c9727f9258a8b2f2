"""run_test's rig settings and keys: domain and discovery of the rig, which key every node gets."""

from __future__ import annotations

import argparse
import os
import stat
from pathlib import Path

import pytest
import yaml

from pd_bringup.launcher import parse_args, plan_new_run, resolve_key
from pd_bringup.plan import LaunchError, with_key
from pd_bringup.rig import (
    RigError,
    RigSettings,
    load_rig,
    prune_test_keys,
    state_key_dir,
)
from pd_bringup.rig import test_key_path as new_test_key
from pd_common.auth import generate_key, load_key
from pd_common.config import SchemaError, read_test_file, read_yaml_file
from pd_common.config.schema_test_file import RigSection
from support.paths import DEFAULT_TEST


def args(**values: object) -> argparse.Namespace:
    base = {'key': None, 'no_authentication': False, 'site': 'bridge'}
    base.update(values)
    return argparse.Namespace(**base)


@pytest.fixture(autouse=True)
def private_home(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv('XDG_STATE_HOME', str(tmp_path / 'state'))
    monkeypatch.setenv('XDG_CONFIG_HOME', str(tmp_path / 'config'))
    monkeypatch.delenv('PD_KEY_FILE', raising=False)


def test_the_rig_section_gives_the_domain_and_discovery(tmp_path: Path) -> None:
    rig_file = tmp_path / 'rig.yaml'
    rig_file.write_text('rig: {domain_id: 17, key_file: keys/lab.key}\n')
    test_file = tmp_path / 'test.yaml'
    rig = load_rig(RigSection(domain_id=42), test_file, rig_file)
    assert rig.domain_id == 42  # the test file's value wins over the rig file's
    assert rig.key_file == tmp_path / 'keys' / 'lab.key'
    assert rig.sources == (str(rig_file), str(test_file))
    env = rig.environment({'ROS_DOMAIN_ID': '3', 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'SUBNET'})
    assert env['ROS_DOMAIN_ID'] == '42' and env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'
    subnet = RigSettings(discovery='subnet', static_peers=('10.0.0.2', '10.0.0.3'))
    env = subnet.environment({})
    assert env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'SUBNET'
    assert env['ROS_STATIC_PEERS'] == '10.0.0.2;10.0.0.3'
    assert 'ROS_DOMAIN_ID' not in RigSettings().environment({})
    # a default of the section does not override the rig file's value (only what is given)
    rig_file.write_text('{discovery: subnet, static_peers: [10.0.0.2]}\n')
    rig = load_rig(RigSection(domain_id=5), test_file, rig_file)
    assert (rig.domain_id, rig.discovery, rig.static_peers) == (5, 'subnet', ('10.0.0.2',))
    rig_file.write_text('')  # an empty rig file: no settings
    assert load_rig(None, test_file, rig_file) == RigSettings()


def test_the_typed_rig_section_reaches_the_plan(tmp_path: Path) -> None:
    raw = read_yaml_file(DEFAULT_TEST)
    raw['ground_motion']['file'] = str(DEFAULT_TEST.parent / raw['ground_motion']['file'])
    raw['rig'] = {'domain_id': 42, 'key_file': 'keys/lab.key'}
    test_file = tmp_path / 'test.yaml'
    test_file.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    generate_key(tmp_path / 'keys' / 'lab.key')
    args = parse_args([str(test_file), '--site', 'direct', '--out', str(tmp_path / 'run'),
                       '--no-figures'])
    plan, _, rig = plan_new_run(args)
    assert rig.domain_id == 42 and rig.key_file == tmp_path / 'keys' / 'lab.key'
    assert plan.environment['ROS_DOMAIN_ID'] == '42'
    assert plan.key_file == tmp_path / 'keys' / 'lab.key'


@pytest.mark.parametrize(('section', 'pattern'), [
    ({'domain_id': 300}, r'rig\.domain_id: must be an integer in 0-101 or 215-232, got 300$'),
    ({'domain_id': 150}, r'rig\.domain_id: must be an integer in 0-101 or 215-232, got 150$'),
    ({'domain_id': True}, r'rig\.domain_id: must be an integer, got true$'),
    ({'discovery': 'everywhere'}, r'rig\.discovery: must be one of .localhost., .subnet.'),
    ({'static_peers': 'host'}, r'rig\.static_peers: must be a list'),
    ({'domian_id': 1}, r'rig\.domian_id: unknown key$'),
    ('lab', r'rig: must be a mapping'),
])
def test_bad_rig_settings_name_the_file_and_the_key(tmp_path: Path, section: object,
                                                    pattern: str) -> None:
    # in the test file: refused by its schema when it is read, one line
    raw = read_yaml_file(DEFAULT_TEST)
    raw['rig'] = section
    test_file = tmp_path / 'test.yaml'
    test_file.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    with pytest.raises(SchemaError, match=r'^test\.yaml: ' + pattern) as info:
        read_test_file(test_file)
    assert '\n' not in str(info.value)
    # in a rig file (run_test --rig): the same schema, the same line
    rig_file = tmp_path / 'lab_rig.yaml'
    rig_file.write_text(yaml.safe_dump({'rig': section}), encoding='utf-8')
    with pytest.raises(RigError, match=r'^lab_rig\.yaml: ' + pattern) as info:
        load_rig(None, test_file, rig_file)
    assert '\n' not in str(info.value)


def test_a_simulated_test_gets_a_key_of_its_own(tmp_path: Path) -> None:
    path = resolve_key(args(), RigSettings(), 'my-test')
    assert path is not None and path.is_relative_to(tmp_path / 'state' / 'pd' / 'keys')
    assert path.name.startswith('my-test-')
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert resolve_key(args(), RigSettings(), 'my-test') != path  # a new one per run


def test_the_key_comes_from_the_option_the_rig_or_the_environment(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    given, rig_key, env_key = (tmp_path / name for name in ('given.key', 'rig.key', 'env.key'))
    for path in (given, rig_key, env_key):
        generate_key(path)
    monkeypatch.setenv('PD_KEY_FILE', str(env_key))
    rig = RigSettings(key_file=rig_key)
    assert resolve_key(args(key=str(given)), rig, 't') == given
    assert resolve_key(args(), rig, 't') == rig_key
    assert resolve_key(args(), RigSettings(), 't') == env_key
    assert resolve_key(args(no_authentication=True), rig, 't') is None


def test_a_physical_site_needs_the_rig_key(tmp_path: Path) -> None:
    with pytest.raises(LaunchError, match='--site none: no key file given'):
        resolve_key(args(site='none'), RigSettings(), 't')
    default = tmp_path / 'config' / 'pd' / 'keys' / 'rig.key'
    key = generate_key(default)
    path = resolve_key(args(site='none'), RigSettings(), 't')
    assert path == default and load_key(path) == key


def test_a_readable_key_is_refused_before_anything_starts(tmp_path: Path) -> None:
    path = tmp_path / 'open.key'
    generate_key(path)
    os.chmod(path, 0o640)
    with pytest.raises(LaunchError, match='mode 0640'):
        resolve_key(args(key=str(path)), RigSettings(), 't')


def test_every_node_gets_the_key_parameter() -> None:
    node = ['main', '--ros-args', '-p', 'x:=1']
    assert with_key(node, Path('/k/rig.key'))[-2:] == ['-p', 'key_file:=/k/rig.key']
    assert with_key(node, None)[-2:] == ['-p', 'authentication:=false']
    opensees = ['opensees_site', '--port', '1234']
    assert with_key(opensees, Path('/k/rig.key')) == opensees  # not a ROS node


def test_old_per_test_keys_are_pruned_the_newest_kept(tmp_path: Path) -> None:
    directory = tmp_path / 'keys'
    now = 1.0e9
    ages = {f'old{i}': 40.0 for i in range(5)} | {f'new{i}': 1.0 for i in range(3)}
    for name, days in ages.items():
        generate_key(directory / f'{name}.key')
        os.utime(directory / f'{name}.key', (now - days * 86400.0,) * 2)
    (directory / 'notes.txt').write_text('not a key', encoding='utf-8')
    removed = prune_test_keys(directory, days=30.0, kept=4, now=now)
    # 8 keys, the newest 4 kept whatever their age: the 3 new ones and one old one stay
    assert len(removed) == 4 and all(path.name.startswith('old') for path in removed)
    left = sorted(path.name for path in directory.glob('*.key'))
    assert len(left) == 4 and {f'new{i}.key' for i in range(3)} <= set(left)
    assert (directory / 'notes.txt').exists()  # only keys are pruned
    assert prune_test_keys(directory, days=30.0, kept=4, now=now) == []
    # run_test's new key prunes the real folder (nothing old there: nothing removed)
    path = new_test_key('t')
    assert path.parent == state_key_dir() and path.exists()
