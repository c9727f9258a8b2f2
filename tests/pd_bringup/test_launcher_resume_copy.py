"""``run_test --resume RUN``: the plan is the folder's it is given (nothing is started).

A run folder copied or moved elsewhere resumes there: every path of its ``launch.json`` that
pointed into the folder the run started in (the integrator's output, the simulators' state
files, the bridges' records, the fault proxies' reports) points into the folder given; a
damaged ``launch.json`` is one line.
"""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import pytest

from pd_bringup.launcher import parse_args, plan_resumed_run
from pd_bringup.plan import LaunchError, LaunchPlan
from support.paths import CONFIG
from support.run_folders import stopped_run

DEFAULT = CONFIG / 'default_test.yaml'
SITES = CONFIG / 'three_story_two_sites.yaml'
FAULTS = 'drop=0.1,seed=3'


def every_path(plan: LaunchPlan) -> list[str]:
    """Every item of the plan's command lines and state files (the resumed integrator's)."""
    items = plan.integrator_command(resume=True)
    for child in plan.children:
        items += [*child.command, child.state_file]
    return items


@pytest.mark.parametrize('test_file', [DEFAULT, SITES], ids=['single-site', 'two-sites'])
@pytest.mark.parametrize('how', ['copied', 'moved'])
def test_a_run_folder_elsewhere_resumes_where_it_is(tmp_path: Path, test_file: Path,
                                                    how: str) -> None:
    original = tmp_path / 'runs' / 'first'
    started = stopped_run(original, test_file, '--faults', FAULTS)
    before = every_path(started)
    old = str(original.resolve())
    assert sum(old in item for item in before) >= 4  # state files, records, reports, output
    copy = tmp_path / 'elsewhere' / 'second'
    copy.parent.mkdir()
    if how == 'copied':
        shutil.copytree(original, copy)
    else:
        shutil.move(original, copy)

    plan = plan_resumed_run(parse_args(['--resume', str(copy)]))

    assert plan.out == copy
    after = every_path(plan)
    new = str(copy.resolve())
    assert not [item for item in after if old in item]
    assert [item.replace(old, new) for item in before] == after  # the same plan, elsewhere
    assert f'resume_from:={new}' in plan.integrator_command(resume=True)
    assert any(item == f'test_file:={test_file.resolve()}' for item in after)  # kept
    for child in plan.children:
        if child.state_file:
            assert Path(child.state_file).parent == copy.resolve()


def test_a_relative_folder_resumes_from_where_it_is_given(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    stopped_run(tmp_path / 'first', DEFAULT, '--faults', FAULTS)
    shutil.copytree(tmp_path / 'first', tmp_path / 'other' / 'copy')
    monkeypatch.chdir(tmp_path / 'other')
    plan = plan_resumed_run(parse_args(['--resume', 'copy']))
    assert plan.out == Path('copy')
    resolved = str((tmp_path / 'other' / 'copy').resolve())
    assert f'resume_from:={resolved}' in plan.integrator_command(resume=True)
    assert all(Path(child.state_file).parent == Path(resolved)
               for child in plan.children if child.state_file)


def test_the_folder_it_started_in_is_kept_as_it_was(tmp_path: Path) -> None:
    plan = stopped_run(tmp_path / 'run', DEFAULT, '--faults', FAULTS)
    again = LaunchPlan.load(tmp_path / 'run')
    assert again.integrator == plan.integrator
    assert again.children == plan.children


@pytest.mark.parametrize(('content', 'reason'), [
    (b'\xff\xfe{}', r'line 1: not UTF-8 text, byte 0xff at offset 0'),
    (b'[' * 100_000 + b']' * 100_000, r'JSON nested too deep'),
    (b'[1, 2]', r'a JSON list, not an object'),
    (b'{"test_id": "t"}', r"no 'out'"),
    (None, r'not a regular file but a FIFO'),
], ids=['not-utf8', 'deep', 'a-list', 'incomplete', 'fifo'])
def test_a_damaged_launch_plan_is_one_line(tmp_path: Path, content: bytes | None,
                                           reason: str) -> None:
    stopped_run(tmp_path / 'run', DEFAULT, '--faults', FAULTS)
    path = tmp_path / 'run' / 'launch.json'
    path.unlink()
    if content is None:
        os.mkfifo(path)
    else:
        path.write_bytes(content)
    with pytest.raises(LaunchError) as info:
        plan_resumed_run(parse_args(['--resume', str(tmp_path / 'run')]))
    message = str(info.value)
    assert '\n' not in message
    assert message.startswith(f'{path}: unreadable launch plan (')
    assert re.search(reason, message), message


def test_a_plan_whose_commands_are_not_command_lines_is_refused(tmp_path: Path) -> None:
    stopped_run(tmp_path / 'run', DEFAULT, '--faults', FAULTS)
    path = tmp_path / 'run' / 'launch.json'
    path.write_text(path.read_text(encoding='utf-8').replace(
        '"integrator": [', '"integrator": [1, '), encoding='utf-8')
    with pytest.raises(LaunchError, match=r'unreadable launch plan \(integrator: not a command '
                                          r'line\)$'):
        LaunchPlan.load(tmp_path / 'run')
