"""A run goes to a new or empty folder: ``--out`` naming anything else is one line, exit 2.

A folder with other files in it (a user's ``--out ~/results``) would get ``summary.json``,
``response.csv``, figures ... mixed in, replacing files of the same names; a file is no
folder. Both ``./pd run`` (``run_test``) and ``./pd offline`` refuse them before anything runs,
and leave them as they were; a folder holding a run keeps its resume hint.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pd_bringup.launcher import main as run_test
from pd_core.errors import ConfigError
from pd_core.run.runner import check_new_run_folder
from pd_integrator import offline


def snapshot(path: Path) -> dict[str, bytes]:
    if path.is_file():
        return {path.name: path.read_bytes()}
    return {str(p.relative_to(path)): p.read_bytes() if p.is_file() else b'<dir>'
            for p in sorted(path.rglob('*'))}


def test_the_check_takes_a_new_or_empty_folder_only(tmp_path: Path) -> None:
    check_new_run_folder(tmp_path / 'new')                 # not there yet: made by the run
    (tmp_path / 'empty').mkdir()
    check_new_run_folder(tmp_path / 'empty')
    results = tmp_path / 'results'
    results.mkdir()
    (results / 'response.csv').write_text('mine\n', encoding='utf-8')
    with pytest.raises(ConfigError, match=r'results: not empty \(1 entry: response\.csv\)'):
        check_new_run_folder(results)
    for name in ('a', 'b', 'c', 'd'):
        (results / name).write_text('', encoding='utf-8')
    with pytest.raises(ConfigError, match=r'not empty \(5 entries: a, b, c, \.\.\.\)'):
        check_new_run_folder(results)
    (results / 'bag').mkdir()                              # a run: the resume hint instead
    with pytest.raises(ConfigError, match=r'already holds a run \(bag\).*--resume'):
        check_new_run_folder(results)
    with pytest.raises(ConfigError, match=r'notes\.txt: not a folder'):
        (tmp_path / 'notes.txt').write_text('', encoding='utf-8')
        check_new_run_folder(tmp_path / 'notes.txt')


@pytest.mark.parametrize('what', ['folder', 'file'])
def test_run_and_offline_refuse_it_in_one_line_and_leave_it_as_it_was(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], what: str) -> None:
    out = tmp_path / 'results'
    if what == 'folder':
        out.mkdir()
        (out / 'response.csv').write_text('an earlier study\n', encoding='utf-8')
        reason = 'not empty (1 entry: response.csv); a run goes to a new or empty folder'
    else:
        out.write_text('notes\n', encoding='utf-8')
        reason = 'not a folder; a run goes to a new or empty folder'
    before = snapshot(out)
    assert run_test(['--site', 'direct', '--out', str(out), '--no-figures']) == 2
    err = capsys.readouterr().err
    assert err.startswith(f'run_test: error: --out {out}: {reason}') and err.count('\n') == 1
    assert offline.main(['--out', str(out), '--no-figures', '--quiet']) == 2
    err = capsys.readouterr().err
    assert err.startswith(f'offline: error: {out}: {reason}') and err.count('\n') == 1
    assert snapshot(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ['results']
