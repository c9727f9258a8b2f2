"""``./pd offline -p NAME:=VALUE`` takes the test's parameters as ``./pd run`` does.

The reference is independent of the override path: the whole default test run offline, whose
first rows an explicit scheme's shorter run must repeat byte for byte (a step never depends on
the test's duration).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file
from pd_integrator import offline
from support.paths import CONFIG

DEFAULT_TEST = CONFIG / 'default_test.yaml'


def test_a_shorter_duration_on_the_command_line_is_the_start_of_the_whole_run(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    whole = run_offline(load_test_file(DEFAULT_TEST), tmp_path / 'whole', figures=False)
    out = tmp_path / 'short'
    assert offline.main([str(DEFAULT_TEST), '-p', 'duration:=1', '--param', 'test_id:=short',
                         '--out', str(out), '--no-figures', '--quiet']) == 0
    assert 'finished: 100 steps' in capsys.readouterr().out
    rows = (out / 'response.csv').read_text(encoding='utf-8').splitlines()
    reference = (whole.directory / 'response.csv').read_text(encoding='utf-8').splitlines()
    assert len(rows) == 102  # the header, steps 0..100
    assert rows == reference[:len(rows)]
