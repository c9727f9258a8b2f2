"""./pd's command registry (pd_common.cli): help generated from it, dispatch through it."""

from __future__ import annotations

import os
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest

from pd_common.cli import COMMANDS, WORKSPACE_COMMANDS, CliCommand, executable, help_text
from support.paths import INSTALL, REPO

#: Every command ./pd had when its help was written by hand (none may go missing).
EARLIER = ('run', 'test', 'lint', 'offline', 'replay', 'analyze', 'study_ch5', 'study_errors',
           'pretest', 'rths_benchmark', 'keygen', 'control', 'console', 'bench', 'setup',
           'shell', 'docs', 'recover', 'schema')


def _pd(*args: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    return subprocess.run(['bash', str(REPO / 'pd'), *args], capture_output=True, text=True,
                          timeout=120, env=env, check=False)


def test_every_registered_command_runs_an_installed_executable() -> None:
    names = COMMANDS.names()
    assert not COMMANDS.broken, COMMANDS.broken
    assert set(EARLIER) <= set(names) | {command.name for command in WORKSPACE_COMMANDS}
    scripts = {(point.value.split('.')[0], point.name)
               for point in metadata.entry_points(group='console_scripts')}
    for name in names:
        command = COMMANDS[name]
        assert command.package is not None
        assert (command.package, command.executable) in scripts, name  # ros2 run works too
        assert executable(name, INSTALL).is_file()


def test_help_is_generated_from_the_registry() -> None:
    text = help_text()
    for command in (*WORKSPACE_COMMANDS, *(COMMANDS[name] for name in COMMANDS.names())):
        line = f'./pd {command.name}'
        assert any(row.strip().startswith(line) for row in text.splitlines()), line
        assert command.summary.split()[0] in text
    done = _pd('help')
    assert done.returncode == 0 and done.stdout == text, done.stderr


def test_an_unknown_command_is_one_line_and_exit_2() -> None:
    done = _pd('no_such_command')
    assert done.returncode == 2
    lines = [line for line in done.stderr.strip().splitlines()
             if not line.startswith('[setup]')]  # (setup.sh says what it did)
    assert len(lines) == 1 and "unknown command 'no_such_command'" in lines[0]
    assert 'offline' in lines[0] and 'Traceback' not in done.stderr


def test_a_plugin_command_is_listed_and_dispatched(tmp_path: Path) -> None:
    plugin = CliCommand('lab_report', 'the lab\'s own report of a run', 'RUN',
                        'pd_lab_tools', 'report')
    lib = tmp_path / 'pd_lab_tools' / 'lib' / 'pd_lab_tools'
    lib.mkdir(parents=True)
    (lib / 'report').write_text('#!/bin/sh\n')
    with COMMANDS.added('lab_report', plugin):
        assert "./pd lab_report RUN" in help_text()
        with pytest.raises(ValueError, match='not installed'):
            executable('lab_report', tmp_path)
        (lib / 'report').chmod(0o755)
        assert executable('lab-report', tmp_path) == lib / 'report'
    assert 'lab_report' not in COMMANDS.names()


def test_a_command_is_refused_without_a_summary_or_of_the_wrong_type() -> None:
    with pytest.raises(ValueError, match='summary'):
        CliCommand('empty', ' ')
    with pytest.raises(ValueError, match='CliCommand is required'):
        COMMANDS.copy().register('odd', object())
    with pytest.raises(ValueError, match='names'):
        COMMANDS.copy().register('other', CliCommand('offline', 'x'))


def test_the_module_runs_as_a_program() -> None:
    done = subprocess.run([sys.executable, '-m', 'pd_common.cli', 'which', 'offline',
                           str(INSTALL)], capture_output=True, text=True, timeout=60,
                          check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == str(INSTALL / 'pd_integrator' / 'lib' / 'pd_integrator'
                                      / 'offline')
