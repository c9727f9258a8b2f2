"""``./pd serve``'s check of the test file: the typed schema's one line, then the scheme and
the address (``element_server.main`` returns 2 with one line on stderr, no traceback)."""

from __future__ import annotations

from pathlib import Path

import pytest

from pd_actuator_bridge.element_server import ServeError, check_test_file, main
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
