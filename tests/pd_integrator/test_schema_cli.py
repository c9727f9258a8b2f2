"""Every command that loads a test file refuses a broken one with the typed schema's one line
(pd_common.config.schema, run by ``load_test_file`` after the integrator's own checks): exit
code 2, one line on stderr naming the file and the dotted path, no traceback."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from pd_common.config import read_yaml_file
from pd_core.errors import ConfigError
from pd_core.run.test_file import load_test_file
from support.paths import CONFIG, REPO

OFFLINE = REPO / 'ros2_ws' / 'install' / 'pd_integrator' / 'lib' / 'pd_integrator' / 'offline'

#: Broken copies of the default test: (old text, new text, expected line after the file name).
#: The first two are refused by the integrator's own checks (their messages stay), the others
#: by the schema only (the integrator does not read the simulated specimen).
BROKEN = {
    'string dt': ('  dt: 0.01', "  dt: '0.01'", r"test\.dt: must be a number, got '0\.01'"),
    'boolean mass': ('  mass: 2543.4', '  mass: true',
                     (r'structure\.mass: expected a number or an array of numbers, got a '
                     r'boolean \(true\)')),
    'negative yield force': ('yield_force: 10000.0', 'yield_force: -1',
                             (r'specimen\.elements\.0\.backbone\.bilinear\.yield_force: must be '
                             r'> 0, got -1')),
    'unknown specimen key': ('      beyond_last_point: extrapolate',
                             '      memory_mode: none\n      beyond_last_point: extrapolate',
                             r'specimen\.elements\.0\.memory_mode: unknown key'),
    'unknown specimen section key': ('  topology: independent\n', ('  topology: independent\n'
                                  '  column_height: 3.0\n'),
                                  r'specimen\.column_height: unknown key'),
}


def broken_file(tmp_path: Path, case: str) -> Path:
    old, new, _ = BROKEN[case]
    text = (CONFIG / 'default_test.yaml').read_text(encoding='utf-8')
    assert old in text, old
    ground = (CONFIG.parent / 'data').resolve()
    text = text.replace(old, new, 1).replace('../data', str(ground))
    path = tmp_path / 'bad.yaml'
    path.write_text(text, encoding='utf-8')
    return path


def test_the_default_test_has_what_the_cases_change() -> None:
    raw = read_yaml_file(CONFIG / 'default_test.yaml')
    assert raw['specimen']['elements'][0]['backbone']['bilinear']['yield_force'] == 10000.0


@pytest.mark.parametrize('case', sorted(BROKEN))
def test_load_test_file_refuses_a_broken_file_with_one_line(tmp_path: Path, case: str) -> None:
    path = broken_file(tmp_path, case)
    with pytest.raises(ConfigError, match=rf'^bad\.yaml: {BROKEN[case][2]}$'):
        load_test_file(path)


@pytest.mark.parametrize('case', ['negative yield force', 'string dt', 'unknown specimen key'])
def test_offline_refuses_a_broken_file_with_one_line(tmp_path: Path, case: str) -> None:
    path = broken_file(tmp_path, case)
    command = ([str(OFFLINE)] if OFFLINE.is_file()
               else [sys.executable, '-m', 'pd_integrator.offline'])
    env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
    result = subprocess.run([*command, str(path), '--quiet', '--no-figures', '--out',
                             str(tmp_path / 'out')], cwd=tmp_path, env=env, text=True,
                            capture_output=True, stdin=subprocess.DEVNULL, timeout=60,
                            check=False)
    assert result.returncode == 2, result.stderr
    assert 'Traceback' not in result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith('offline: error: bad.yaml: '), lines[0]
    assert lines[0].endswith(BROKEN[case][2].replace('\\', '')), lines[0]
    assert not (tmp_path / 'out').exists()
