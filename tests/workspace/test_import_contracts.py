"""The import contracts of pyproject.toml hold, and they fail when a rule is broken.

lint-imports runs on a copy of the source tree in which one import is added: a pure core
importing rclpy, a node package importing another, a cycle. Each must break the contract that
forbids it (so CI, which runs the same contracts, would catch it).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from support.paths import PACKAGES, REPO


def lint_imports(src: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ)
    env['PYTHONPATH'] = os.pathsep.join(str(src / package) for package in PACKAGES)
    linter = Path(sys.executable).with_name('lint-imports')
    return subprocess.run([str(linter), '--no-cache', '--config', str(REPO / 'pyproject.toml')],
                          capture_output=True, text=True, env=env, cwd=src, check=False,
                          timeout=120)


@pytest.fixture
def source_copy(tmp_path: Path) -> Path:
    """The Python packages of src/ (no build products)."""
    for package in PACKAGES:
        shutil.copytree(REPO / 'src' / package / package, tmp_path / package / package,
                        ignore=shutil.ignore_patterns('__pycache__'))
    return tmp_path


def test_the_contracts_hold_on_the_source_tree(source_copy: Path) -> None:
    result = lint_imports(source_copy)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'BROKEN' not in result.stdout
    assert result.stdout.count('KEPT') == 8


@pytest.mark.parametrize(('module', 'line', 'contract'), [
    ('pd_core/pd_core/run/record/history.py', 'import rclpy',
     'Pure cores import no ROS'),
    ('pd_common/pd_common/specimen/backbone.py', 'import pd_common.ros',
     'Pure cores import no ROS'),
    ('pd_actuator_bridge/pd_actuator_bridge/core/force_control.py', 'import pd_msgs.msg',
     'Pure cores import no ROS'),
    ('pd_actuator_bridge/pd_actuator_bridge/node.py', 'import pd_specimen_sim.node',
     'Node and tool packages are peers'),
    ('pd_core/pd_core/run/record/outputs.py', 'import pd_actuator_bridge.core',
     'Node and tool packages are peers'),
    ('pd_common/pd_common/protocol/messages.py', 'import pd_core.errors',
     'The libraries are layered'),
    ('pd_core/pd_core/schemes/base.py',
     'import pd_core.run.record.history',
     "The integrator's core is layered"),
    ('pd_common/pd_common/errors.py', 'import pd_common.specimen.backbone',
     'No import cycles'),
    ('pd_common/pd_common/jsonl.py', 'import rclpy', 'Pure cores import no ROS'),
    ('pd_bringup/pd_bringup/plan.py', 'import rclpy', 'Pure cores import no ROS'),
    ('pd_bringup/pd_bringup/supervisor.py', 'import pd_actuator_bridge.core',
     'Node and tool packages are peers'),
    ('pd_pretest/pd_pretest/pretest.py', 'import pd_integrator.offline',
     'Node and tool packages are peers'),
    ('pd_studies/pd_studies/study_errors.py', 'import pd_scheme_analysis.analyze',
     'Node and tool packages are peers'),
    ('pd_core/pd_core/run/runner.py', 'import pd_console.core.model', 'The shared libraries'),
    ('pd_console/pd_console/core/model.py', 'import rclpy', 'Pure cores import no ROS'),
    ('pd_rths_benchmark/pd_rths_benchmark/core/problem.py', 'import pd_msgs.msg',
     'Pure cores import no ROS'),
    ('pd_actuator_bridge/pd_actuator_bridge/core/drivers/base.py',
     'import pd_actuator_bridge.core.force_control', "The bridge's core is layered"),
    ('pd_core/pd_core/run/record/outputs.py',
     'import pd_core.run.loop.session', 'The record of a run never imports the step'),
    ('pd_common/pd_common/auth/__init__.py', 'import pd_common.ros', 'Pure cores import no ROS'),
    ('pd_common/pd_common/cli.py', 'import std_msgs.msg', 'Pure cores import no ROS'),
])
def test_a_forbidden_import_breaks_its_contract(source_copy: Path, module: str, line: str,
                                                contract: str) -> None:
    path = source_copy / module
    path.write_text(path.read_text(encoding='utf-8') + f'\n{line}  # injected\n',
                    encoding='utf-8')
    result = lint_imports(source_copy)
    assert result.returncode != 0
    broken = [text for text in result.stdout.splitlines() if text.endswith('BROKEN')]
    assert any(text.startswith(contract) for text in broken), result.stdout


def test_every_part_of_pd_common_but_ros_is_a_pure_core() -> None:
    """A new module of pd_common is not left out of the pure-core contract."""
    config = tomllib.loads((REPO / 'pyproject.toml').read_text(encoding='utf-8'))
    pure = next(contract for contract in config['tool']['importlinter']['contracts']
                if contract['name'].startswith('Pure cores import no ROS'))
    root = REPO / 'src' / 'pd_common' / 'pd_common'
    parts = {f'pd_common.{path.stem}' for path in root.iterdir()
             if (path.suffix == '.py' and path.stem != '__init__')
             or (path.is_dir() and (path / '__init__.py').is_file())}
    assert parts - set(pure['source_modules']) == {'pd_common.ros'}


def test_every_package_is_under_the_contracts() -> None:
    """A new package of src/ is a root of the contracts and a peer (or a shared library)."""
    config = tomllib.loads((REPO / 'pyproject.toml').read_text(encoding='utf-8'))
    linter = config['tool']['importlinter']
    assert set(linter['root_packages']) == set(PACKAGES)
    contracts = {contract['name']: contract for contract in linter['contracts']}
    peers = set(contracts['Node and tool packages are peers: none imports another']['modules'])
    shared = next(contract for name, contract in contracts.items()
                  if name.startswith('The shared libraries'))
    assert set(shared['source_modules']) == {'pd_common', 'pd_core'}
    assert peers == set(PACKAGES) - {'pd_common', 'pd_core'}
    assert set(shared['forbidden_modules']) == peers
    acyclic = next(contract for contract in linter['contracts']
                   if contract['type'] == 'acyclic_siblings')
    assert set(acyclic['ancestors']) == set(PACKAGES)
