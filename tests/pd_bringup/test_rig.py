"""run_test's rig settings and keys: domain and discovery of the rig, which key every node gets."""

from __future__ import annotations

import argparse
import os
import stat
from pathlib import Path

import pytest

from pd_bringup.launcher import resolve_key
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
    rig = load_rig({'rig': {'domain_id': 42}}, test_file, rig_file)
    assert rig.domain_id == 42  # the test file's value wins over the rig file's
    assert rig.key_file == tmp_path / 'keys' / 'lab.key'
    env = rig.environment({'ROS_DOMAIN_ID': '3', 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'SUBNET'})
    assert env['ROS_DOMAIN_ID'] == '42' and env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'
    subnet = RigSettings(discovery='subnet', static_peers=('10.0.0.2', '10.0.0.3'))
    env = subnet.environment({})
    assert env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'SUBNET'
    assert env['ROS_STATIC_PEERS'] == '10.0.0.2;10.0.0.3'
    assert 'ROS_DOMAIN_ID' not in RigSettings().environment({})


@pytest.mark.parametrize(('section', 'pattern'), [
    ({'domain_id': 300}, r'test\.yaml: rig\.domain_id: must be an integer'),
    ({'domain_id': True}, r'rig\.domain_id'),
    ({'discovery': 'everywhere'}, r'rig\.discovery: must be one of localhost, subnet'),
    ({'static_peers': 'host'}, r'rig\.static_peers'),
    ({'domian_id': 1}, r'rig\.domian_id: unknown key'),
    ('lab', r'test\.yaml: rig: must be a mapping'),
])
def test_bad_rig_settings_name_the_file_and_the_key(tmp_path: Path, section: object,
                                                    pattern: str) -> None:
    with pytest.raises(RigError, match=pattern) as info:
        load_rig({'rig': section}, tmp_path / 'test.yaml', None)
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
