"""``./pd serve``'s check of the test file: the typed schema's one line, then the scheme and
the address (``element_server.main`` returns 2 with one line on stderr, no traceback)."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from pd_actuator_bridge.element_server import ServeError, check_test_file, main
from pd_core.run.record.journal import JOURNAL_FILE
from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file
from support import journals
from support.paths import CONFIG


def test_the_shipped_served_files_are_served_on_loopback() -> None:
    for name in ('serve_epp.yaml', 'serve_two_story.yaml', 'serve_one_bay_frame.yaml'):
        assert check_test_file(CONFIG / name) == ('127.0.0.1:44000', [])


@pytest.mark.parametrize(('old', 'new', 'message'), [
    ('dt: 0.01 ', 'dt: -1 ', 'bad.yaml: test.dt: must be > 0, got -1'),
    ('scheme: opensees_element ', 'scheme: newmark_explicit ',
     "test.scheme: must be opensees_element to serve an element, got 'newmark_explicit'"),
    ('host: 127.0.0.1 ', 'host: 10.0.0.1 ', 'test.scheme_parameters.'),
])
def test_a_refused_file_is_one_line_with_its_dotted_path(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], old: str, new: str,
        message: str) -> None:
    text = (CONFIG / 'serve_epp.yaml').read_text()
    assert old in text
    path = tmp_path / 'bad.yaml'
    path.write_text(text.replace(old, new))
    with pytest.raises(ServeError, match=message.replace('.', r'\.')):
        check_test_file(path)
    assert main([str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and message in err and 'Traceback' not in err


@pytest.mark.parametrize(('args', 'message'), [
    (['--resume', 'RUN', 'x.yaml'], '--resume: takes no test file, --out or --offline'),
    (['--resume', 'RUN', '--offline'], '--resume: takes no test file, --out or --offline'),
    (['--resume', 'NOWHERE'], 'not a run folder'),
    (['--resume', 'RUN'], ("not a served run (scheme 'newmark_explicit'): continue it with "
                           './pd run --resume')),
])
def test_resume_refuses_what_is_not_a_stopped_served_run(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str],
        message: str) -> None:
    run = tmp_path / 'RUN'
    definition = load_test_file(CONFIG / 'default_test.yaml', overrides={'duration': 0.05})
    run_offline(definition, run, figures=False)
    kept = journals.records(run / JOURNAL_FILE)  # as a killed run leaves it: no last status
    journals.cut(run / JOURNAL_FILE, run / JOURNAL_FILE, len(kept) - 1)
    args = [str(tmp_path / a) if a in ('RUN', 'NOWHERE') else a for a in args]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and message in err and 'Traceback' not in err, err


def test_a_port_that_is_taken_is_one_line_before_anything_is_made(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The element's link would fail to bind only inside the running test (a run folder made,
    a held test): the server says it first, and makes nothing."""
    with socket.socket() as taken:
        taken.bind(('127.0.0.1', 0))
        taken.listen()
        port = taken.getsockname()[1]
        text = (CONFIG / 'serve_epp.yaml').read_text()
        path = tmp_path / 'taken.yaml'
        path.write_text(text.replace('port: 44000 ', f'port: {port} ').replace(
            'file: ../data/', f'file: {CONFIG}/../data/'))
        assert f'port: {port} ' in path.read_text()  # (else main would serve: exec)
        out = tmp_path / 'out'
        assert main([str(path), '--offline', '--out', str(out)]) == 2
    err = capsys.readouterr().err
    assert err == (f'element_server: error: {path}: test.scheme_parameters.port: cannot bind '
                   f'127.0.0.1:{port} (Address already in use); another element server or '
                   'program holds it\n')
    assert not out.exists()
