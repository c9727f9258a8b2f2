"""run_test reads the bridge's parameter file once, typed, before any process starts.

A bad file (an unknown key, a negative limit, a boolean for a number) is one line naming the
file and the dotted path, through the real command (``run_test --bridge-params``), and nothing
is started (no run folder).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pd_bringup.launcher import main


@pytest.mark.parametrize(('parameters', 'message'), [
    ('{max_forse: 1.0}', 'bad_bridge.yaml: /**.ros__parameters.max_forse: unknown key'),
    ('{max_increment: -0.02}',
     'bad_bridge.yaml: /**.ros__parameters.max_increment: must be > 0, got -0.02'),
    ('{max_force: true}',
     'bad_bridge.yaml: /**.ros__parameters.max_force: must be a number, got true'),
])
def test_a_bad_bridge_parameter_file_is_refused_before_anything_starts(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], parameters: str,
        message: str) -> None:
    params = tmp_path / 'bad_bridge.yaml'
    params.write_text(f'/**:\n  ros__parameters: {parameters}\n', encoding='utf-8')
    out = tmp_path / 'run'
    assert main(['--site', 'bridge', '--bridge-params', str(params), '--out', str(out),
                 '--no-figures']) == 2
    assert capsys.readouterr().err == f'run_test: error: {message}\n'
    assert not out.exists()
