"""``./pd journal RUN``: a run's binary journal printed as lines or JSON objects.

The reference is the journal read by its documented layout (``support.journals``) and decoded
by the codec, not the command's own reader.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from pd_common.protocol import Command, Feedback, FeedbackStatus
from pd_core.run.record.journal import JOURNAL_FILE
from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file
from pd_integrator.journal import main
from support import journals
from support.paths import DEFAULT_TEST


@pytest.fixture(scope='module')
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished 20-step run (offline)."""
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': 0.2})
    return run_offline(definition, tmp_path_factory.mktemp('journal') / 'run',
                       figures=False).directory


def printed(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, list[str], str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out.splitlines(), err


def test_every_record_is_one_json_object_with_its_fields(run_dir: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    code, lines, err = printed(capsys, str(run_dir), '--json')
    assert (code, err) == (0, '')
    records = journals.records(run_dir / JOURNAL_FILE)
    objects = [json.loads(line) for line in lines]
    assert len(objects) == len(records) > 40
    assert [(o['n'], o['kind'], o['t_ns'], o['topic']) for o in objects] == [
        (n, r.kind, r.t_ns, r.topic) for n, r in enumerate(records, start=1)]
    for record, obj in zip(records, objects, strict=True):
        item: Any = record.item
        if isinstance(item, Command):
            assert obj['target_displacement'] == list(item.target_displacement)  # exact
            assert (obj['step'], obj['iteration'], obj['test_id']) == (
                item.step, item.iteration, item.test_id)
            assert obj['signature'] is None  # an offline run signs nothing
        elif isinstance(item, Feedback):
            assert obj['restoring_force'] == list(item.restoring_force)
            assert obj['status'] == item.status.name
    assert objects[0]['kind'] == 'def'
    assert objects[0]['definition']['test']['id'] == 'thesis-5.1-elcentro'


def test_lines_tail_and_kinds(run_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    records = journals.records(run_dir / JOURNAL_FILE)
    code, lines, _ = printed(capsys, str(run_dir / JOURNAL_FILE))
    assert code == 0
    assert len(lines) == len(records)
    code, lines, _ = printed(capsys, str(run_dir), '--tail', '3')
    assert [int(line.split()[0]) for line in lines] == [len(records) - 2, len(records) - 1,
                                                        len(records)]
    code, lines, _ = printed(capsys, str(run_dir), '--kind', 'fb', '--tail', '1')
    (line,) = lines
    last = [r for r in records if r.kind == 'fb'][-1].item
    assert last.status is FeedbackStatus.OK
    assert f'step {last.step}.0  ok  xm [{last.measured_displacement[0]:.6g}]' in line
    assert f'r [{last.restoring_force[0]:.6g}]' in line
    number = [n for n, r in enumerate(records, start=1) if r.kind == 'fb'][-1]
    assert int(line.split()[0]) == number  # the record's own number, not the filtered one
    assert not math.isnan(last.restoring_force[0])


def test_a_torn_journal_prints_its_records_and_says_what_was_ignored(
        run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    records = journals.records(run_dir / JOURNAL_FILE)
    journals.cut(run_dir / JOURNAL_FILE, tmp_path / JOURNAL_FILE, 10, partial=9)
    code, lines, err = printed(capsys, str(tmp_path))
    assert code == 0
    assert len(lines) == 10
    assert err.startswith(f'journal: ignored the last record of {JOURNAL_FILE}, cut short ')
    assert err.count('\n') == 1
    assert len(records) > 10


@pytest.mark.parametrize(('args', 'message'), [
    (['--tail', '0'], "argument --tail: '0': not a number of records >= 1"),
    (['--kind', 'cmd,xyz'], 'argument --kind: xyz: not a record kind'),
])
def test_bad_options_are_one_line(run_dir: Path, capsys: pytest.CaptureFixture[str],
                                  args: list[str], message: str) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([str(run_dir), *args])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert message in err
    assert 'Traceback' not in err
