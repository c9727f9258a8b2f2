"""Collapse: a negative tangent beyond the stated drift is found, reported and acted on."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pd_core.errors import ConfigError
from pd_core.run.collapse import CollapseMonitor, CollapseSettings
from pd_core.run.runner import run_offline
from pd_core.run.test_file import from_dict, load_test_file
from support.paths import CONFIG

K = 1000.0


def monitor(**kwargs: Any) -> CollapseMonitor:
    settings = CollapseSettings(drift=(0.1,), **kwargs)
    return CollapseMonitor(settings, ['top'], np.array([[K]]), 0.01)


def first_collapse(m: CollapseMonitor, x: np.ndarray, r: np.ndarray) -> int | None:
    for step in range(len(x)):
        if m.observe(step, x[:, None], r[:, None]) is not None:
            return step
    return None


def softening_path() -> tuple[np.ndarray, np.ndarray]:
    """Out to 0.2 m: elastic to 0.05 m (50 N), then descending at -0.1 K."""
    x = np.linspace(0.0, 0.2, 201)
    r = np.where(x <= 0.05, K * x, 50.0 - 0.1 * K * (x - 0.05))
    return x, r


def test_found_at_the_first_step_beyond_the_drift_on_the_negative_branch() -> None:
    x, r = softening_path()
    m = monitor()
    step = first_collapse(m, x, r)
    assert step is not None
    assert x[step] > 0.1 >= x[step - 1]
    found = m.found
    assert found is not None
    assert found.tangent == pytest.approx(-0.1 * K)
    assert found.dof == 'top'
    assert found.time == pytest.approx(step * 0.01)
    assert 'COLLAPSE of top' in found.message() and '-100.00 N/m' in found.message()
    assert m.observe(len(x) - 1, x[:, None], r[:, None]) is None      # reported once


def test_not_found_within_the_drift_while_unloading_or_on_a_positive_tangent() -> None:
    x, r = softening_path()
    assert first_collapse(monitor(), x, K * x) is None                   # hardening
    assert first_collapse(monitor(), x[x < 0.1], r[x < 0.1]) is None     # within the drift
    back = x[::-1].copy() + 0.05                                         # coming back inwards
    assert first_collapse(monitor(), back, 50.0 + K * (back - 0.25)) is None
    # mirror: negative displacement, descending force magnitude
    assert first_collapse(monitor(), -x, -r) is not None
    # a tangent ratio below the branch's slope ignores it
    assert first_collapse(monitor(tangent_ratio=-0.2), x, r) is None


def collapse_test(action: str) -> dict[str, Any]:
    raw: dict[str, Any] = json.loads(
        load_test_file(CONFIG / 'column_collapse.yaml').to_json())
    raw['collapse']['action'] = action
    return raw


@pytest.mark.parametrize('action', ['stop', 'hold', 'continue'])
def test_column_rehearsal_collapses(tmp_path: Path, action: str) -> None:
    definition = from_dict(collapse_test(action), source='column_collapse.yaml')
    result = run_offline(definition, tmp_path / action, figures=False)
    summary = result.summary
    collapse = summary['collapse']
    assert collapse is not None and collapse['dof'] == 'top'
    assert abs(collapse['displacement']) > 0.15
    # the tangent is the backbone's descending slope, -5 % of k_ini
    assert collapse['tangent'] == pytest.approx(-0.05 * 312559.0, rel=1e-6)
    assert summary['state'] == ('holding' if action == 'hold' else 'finished')
    if action in ('stop', 'hold'):
        assert summary['steps'] == collapse['step'] < definition.n_steps
        assert summary['message'].startswith('COLLAPSE of top')
    else:
        assert summary['steps'] == definition.n_steps
    assert 'softening:' in result.session.stability.message


def test_an_elastic_test_with_a_collapse_section_does_not_collapse(tmp_path: Path) -> None:
    raw = collapse_test('stop')
    raw['specimen'] = {'elements': [{'model': 'elastic', 'stiffness': 312559.0}]}
    result = run_offline(from_dict(raw, source='elastic.yaml'), tmp_path, figures=False)
    assert result.summary['collapse'] is None
    assert result.summary['steps'] == result.session.definition.n_steps


@pytest.mark.parametrize(('section', 'message'), [
    ({'action': 'stop'}, r'collapse\.drift: is required'),
    ({'drift': -0.1}, r'collapse\.drift: must be a positive number'),
    ({'drift': [0.1, 0.2]}, r'collapse\.drift: must be .* list of 1'),
    ({'drift': 0.1, 'action': 'run'},
     r"collapse\.action: must be one of 'stop', 'hold', 'continue', got 'run'"),
    ({'drift': 0.1, 'tangent_ratio': 0.1}, r'collapse\.tangent_ratio: must be <= 0'),
    ({'drift': 0.1, 'window': 0}, r'collapse\.window: must be >= 1, got 0'),
    ({'drift': 0.1, 'drfit': 1}, r"collapse\.drfit: unknown key"),
])
def test_bad_collapse_sections(section: dict[str, Any], message: str) -> None:
    raw = collapse_test('stop')
    raw['collapse'] = copy.deepcopy(section)
    with pytest.raises(ConfigError, match=message):
        from_dict(raw, source='t.yaml')
