"""Rehearsals that apply the lab's limits: ``./pd offline`` holds where the bridges would.

Each case runs a test file offline with its sites' bridge limits
(:func:`~pd_core.run.bridge_limits.site_limits`) and, next to it, drives the real
:class:`~pd_actuator_bridge.core.ActuatorBridge` core in-process (a synchronous driver in front
of the same simulated specimen, keyed as ``sim_servo`` keys its moves) through the same session
and step loop. Both must hold at the same step, with the bridge's message, after the same
history; the pre-test must predict that step.
"""

from __future__ import annotations

import json
from collections import deque
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from pd_actuator_bridge.core import (
    ActuatorBridge,
    ActuatorDriver,
    ActuatorMeasurement,
    DriverError,
    SafetyLimits,
    StepId,
    force_substep_key,
)
from pd_common.config import default_bridge_parameter_file, read_yaml_file
from pd_common.config.schema_bridge import SiteBridgeParameters
from pd_common.config.schema_test_file import SiteSettings
from pd_common.errors import BridgeConfigError
from pd_common.protocol import Command, Feedback, FeedbackStatus, StepKey
from pd_common.protocol import TestState as State
from pd_core.errors import ConfigError
from pd_core.run.bridge_limits import SiteLimits, site_limits
from pd_core.run.definition import TestDefinition as Definition
from pd_core.run.loop.dispatch import StepDispatcher
from pd_core.run.loop.session import TestSession as Session
from pd_core.run.runner import RunResult, run_offline, site_servers
from pd_core.run.test_file import from_dict, load_test_file
from pd_integrator import offline
from pd_pretest.core import build_plan, execute, read_bridge_limits
from support.paths import CONFIG

RECORD = CONFIG.parent / 'data' / 'ground_motions' / 'elcentro_1940_ns_chopra.csv'


# -- the bridge core, in-process ------------------------------------------------------------------
class SpecimenDriver(ActuatorDriver):
    """A synchronous driver in front of a simulated specimen: each move (and force sub-step)
    goes to the specimen keyed as ``sim_servo`` keys it; the position is the last measured one
    (the specimen's own before the first move, as its offer)."""

    driver_name = 'specimen'

    def __init__(self, server: Any, n_dof: int) -> None:
        super().__init__()
        self.server = server
        self._n_dof = n_dof
        self.test_id = ''
        self._position = [float(x) for x in getattr(server, 'position', [0.0] * n_dof)]

    @property
    def n_dof(self) -> int:
        return self._n_dof

    def force_control_problem(self) -> str | None:
        return None

    def command(self, step: StepId, target: Sequence[float]) -> None:
        number, iteration = step if isinstance(step, tuple) else (step, 0)
        self._answer(step, self.server.handle(self.test_id, number, target,
                                              iteration=iteration))

    def command_force(self, step: StepId, target: Sequence[float],
                      control_mode: Sequence[int], target_force: Sequence[float]) -> None:
        number, iteration = force_substep_key(step)
        self._answer(step, self.server.handle(self.test_id, number, target, iteration=iteration,
                                              control_mode=control_mode,
                                              target_force=target_force))

    def _answer(self, step: StepId, answer: Feedback | None) -> None:
        if answer is None or answer.status is not FeedbackStatus.OK:
            raise DriverError(f'specimen: {answer}')
        self._position = [float(x) for x in answer.measured_displacement]
        self._emit(ActuatorMeasurement(step, tuple(self._position),
                                       tuple(float(f) for f in answer.restoring_force)))

    def hold(self) -> None:
        pass

    def position(self) -> list[float]:
        return list(self._position)


def bridge_core_run(definition: Definition, limits: dict[str, SafetyLimits],
                    on_limit: str = 'hold') -> tuple[Session, dict[str, ActuatorBridge]]:
    """The test through the same session and step loop, each site behind a real bridge core."""
    servers = site_servers(definition)
    names = {site: (tuple(definition.model.actuator_names(site)) if definition.model
                    else tuple(definition.dof_names)) for site in servers}
    drivers = {site: SpecimenDriver(servers[site], len(names[site])) for site in servers}
    bridges = {site: ActuatorBridge(drivers[site], limits[site], list(names[site]),
                                    on_limit=on_limit) for site in servers}
    session = Session(definition)
    queue: deque[tuple[str, Command]] = deque()

    def send(site: str, command: Command) -> None:
        queue.append((site, command))

    dispatcher = StepDispatcher(session, send)
    dispatcher.start()
    while queue:
        site, command = queue.popleft()
        drivers[site].test_id = command.test_id
        reply = bridges[site].handle_command(
            command.test_id, StepKey(command.step, command.iteration),
            command.target_displacement, control_mode=command.control_mode,
            target_force=command.target_force)
        assert reply is not None
        dispatcher.on_feedback(site, reply)  # the bridge answers in the protocol's Feedback
    return session, bridges


# -- the test files -------------------------------------------------------------------------------
def _write(path: Path, raw: dict[str, Any]) -> Path:
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    return path


def _raw(name: str) -> dict[str, Any]:
    raw: dict[str, Any] = yaml.safe_load((CONFIG / name).read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(RECORD)
    return raw


def collapsing_column(tmp_path: Path) -> Path:
    """The issue's column: P-Δ under its axial load, a softening bilinear (-0.02), El Centro x2,
    its site's bridge with ``max_displacement: 1.0`` (the load is force-controlled)."""
    raw = _raw('column_axial.yaml')
    raw['test']['id'] = 'column-collapse-limits'
    raw['ground_motion']['scale'] = 2.0
    raw['sites']['lab']['specimen']['column']['lateral']['hardening_ratio'] = -0.02
    raw['sites']['lab']['bridge']['max_displacement'] = 1.0
    return _write(tmp_path / 'collapse.yaml', raw)


def bridge_file(tmp_path: Path, **changes: Any) -> Path:
    """The shipped bridge parameters with ``changes``."""
    raw = yaml.safe_load(default_bridge_parameter_file().read_text(encoding='utf-8'))
    raw['/**']['ros__parameters'].update(changes)
    return _write(tmp_path / 'bridge.yaml', raw)


def two_sites_force(tmp_path: Path) -> Path:
    """The two-site example; lab3's bridge allows 100 kN (its story reaches ~0.2 MN)."""
    raw = _raw('three_story_two_sites.yaml')
    raw['sites']['lab3']['bridge']['max_force'] = 1.0e5
    return _write(tmp_path / 'two_sites.yaml', raw)


def default_test(tmp_path: Path) -> Path:
    return _write(tmp_path / 'default.yaml', _raw('default_test.yaml'))


#: Per case: the test file, the bridge file (None: the shipped one), the limits each site's
#: bridge is configured with (stated here, not read by the code under test), the limit that
#: holds it.
CASES: dict[str, tuple[Any, Any, dict[str, SafetyLimits], str]] = {
    'max_displacement': (collapsing_column, None, {'lab': SafetyLimits(
        max_displacement=1.0, max_increment=0.02, max_force=6.0e4,
        max_force_increment=2500.0)}, 'max_displacement'),
    'max_increment': (default_test, lambda p: bridge_file(p, max_increment=0.004),
                      {'': SafetyLimits(max_displacement=0.25, max_increment=0.004,
                                        max_force=1.0e5)}, 'max_increment'),
    'max_force': (two_sites_force, None, {
        'lab1': SafetyLimits(max_displacement=0.1, max_increment=0.01, max_force=1.0e6),
        'lab3': SafetyLimits(max_displacement=0.1, max_increment=0.01, max_force=1.0e5)},
        'max_force'),
}


def _offline(test_file: Path, bridge: Path | None, out: Path, *, past_limits: bool = False
             ) -> RunResult:
    definition = load_test_file(test_file)
    return run_offline(definition, out, figures=False, limits=site_limits(definition, bridge),
                       past_limits=past_limits)


@pytest.mark.parametrize('case', list(CASES))
def test_offline_holds_where_the_bridge_core_holds(tmp_path: Path, case: str) -> None:
    make_file, make_bridge, limits, limit = CASES[case]
    test_file = make_file(tmp_path)
    bridge = make_bridge(tmp_path) if make_bridge is not None else None
    definition = load_test_file(test_file)
    resolved = site_limits(definition, bridge)
    assert {site: entry.limits for site, entry in resolved.items()} == limits

    session, bridges = bridge_core_run(definition, limits)
    assert session.state is State.HOLDING
    pending = session.protocol.pending
    assert pending is not None
    holding = [site for site, core in bridges.items() if core.state == 'holding']
    assert len(holding) == 1
    site = holding[0]

    result = _offline(test_file, bridge, tmp_path / 'run')
    summary = result.summary
    held = summary['bridge_limits']['held']
    print(f'{case}: offline held at step {held["step"]}, the bridge core at step '
          f'{pending.step} ({held["limit"]})')
    assert summary['state'] == 'held' and summary['partial'] is True
    assert held['step'] == pending.step and held['iteration'] == pending.iteration
    assert summary['steps'] == session.committed_step == pending.step - 1
    assert held['site'] == (site or 'default') and held['limit'] == limit
    assert held['message'] == bridges[site].hold_reason  # the bridge's words
    assert result.session.message == session.message  # the integrator's hold, word for word
    assert summary['message'] == session.message
    n = session.history.n_committed
    assert result.session.history.n_committed == n
    np.testing.assert_array_equal(result.session.history.displacement[:n],
                                  session.history.displacement[:n])
    np.testing.assert_array_equal(result.session.history.restoring_force[:n],
                                  session.history.restoring_force[:n])
    on_disk = json.loads((result.directory / 'summary.json').read_text(encoding='utf-8'))
    assert on_disk['state'] == 'held' and on_disk['bridge_limits']['held'] == held


def test_a_saturating_bridge_holds_the_test_at_the_same_step(tmp_path: Path) -> None:
    """``on_limit: saturate``: the bridge clips and answers LIMIT; the integrator holds."""
    test_file = default_test(tmp_path)
    bridge = bridge_file(tmp_path, max_increment=0.004, on_limit='saturate')
    definition = load_test_file(test_file)
    limits = {'': SafetyLimits(max_displacement=0.25, max_increment=0.004, max_force=1.0e5)}
    session, bridges = bridge_core_run(definition, limits, on_limit='saturate')
    assert bridges[''].state == 'ready' and session.state is State.HOLDING
    result = _offline(test_file, bridge, tmp_path / 'run')
    held = result.summary['bridge_limits']['held']
    assert result.summary['state'] == 'held'
    assert held['message'].startswith('saturated: ') and held['limit'] == 'max_increment'
    assert session.protocol.pending is not None
    assert held['step'] == session.protocol.pending.step
    assert result.session.message == session.message


def test_the_cli_holds_with_a_nonzero_exit_and_names_the_limit(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    test_file = default_test(tmp_path)
    bridge = bridge_file(tmp_path, max_increment=0.004)
    out = tmp_path / 'run'
    code = offline.main([str(test_file), '--bridge', str(bridge), '--out', str(out),
                         '--no-figures', '--quiet'])
    text = capsys.readouterr().out
    assert code == 1
    assert ('HELD at step 201 by the bridge of site default (max_increment): DOF 0 (top): '
            'displacement increment') in text
    assert 'held: 200 steps' in text
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'held' and summary['bridge_limits']['held']['step'] == 201


def test_past_limits_runs_to_the_end_and_reports_where_the_bridge_would_have_held(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    test_file = default_test(tmp_path)
    bridge = bridge_file(tmp_path, max_increment=0.004)
    held = _offline(test_file, bridge, tmp_path / 'held').summary['bridge_limits']['held']
    out = tmp_path / 'past'
    code = offline.main([str(test_file), '--bridge', str(bridge), '--out', str(out),
                         '--no-figures', '--quiet', '--past-limits'])
    captured = capsys.readouterr()
    assert code == 0
    warning = captured.err.strip().splitlines()
    assert len(warning) == 1 and warning[0].startswith('offline: warning: --past-limits')
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished' and summary['steps'] == 3118
    limits = summary['bridge_limits']
    assert limits['applied'] is False and 'held' not in limits
    assert limits['would_have_held'] == held  # where the held run stopped
    assert [record['limit'] for record in limits['exceeded']] == ['max_increment']
    assert (f'past limits: the bridge of site default would have held at step {held["step"]} '
            f'(max_increment): {held["message"]}') in captured.out
    assert 'finished: 3118 steps' in captured.out


def test_an_ordinary_run_is_unchanged_by_the_limits(tmp_path: Path) -> None:
    """The default test stays within the shipped limits: the same run, byte for byte."""
    definition = load_test_file(CONFIG / 'default_test.yaml')
    plain = run_offline(definition, tmp_path / 'plain', figures=False)
    checked = run_offline(definition, tmp_path / 'checked', figures=False,
                          limits=site_limits(definition))
    assert ((checked.directory / 'response.csv').read_bytes()
            == (plain.directory / 'response.csv').read_bytes())
    assert checked.summary['state'] == 'finished'
    assert checked.summary['bridge_limits']['held'] is None
    assert checked.summary['bridge_limits']['sites']['default']['source'] == 'bridge.yaml'
    assert 'bridge_limits' not in plain.summary


def test_site_limits_are_the_bridge_file_then_the_sites_mapping(tmp_path: Path) -> None:
    definition = load_test_file(collapsing_column(tmp_path))
    lab = site_limits(definition)['lab']
    assert isinstance(lab, SiteLimits)
    assert lab.dof_names == ('horizontal', 'vertical') and lab.on_limit == 'hold'
    assert lab.source == 'bridge.yaml + collapse.yaml: sites.lab.bridge'
    # 0 = off, as the bridge node reads its parameters
    off = site_limits(definition, bridge_file(tmp_path, step_duration=0.0, max_velocity=0.0,
                                              tracking_tolerance=0.01))['lab']
    assert off.limits.step_duration is None and off.limits.max_velocity is None
    assert off.limits.tracking_tolerance == 0.01
    raw = yaml.safe_load((tmp_path / 'collapse.yaml').read_text(encoding='utf-8'))
    raw['sites']['lab']['bridge']['max_increment'] = -1.0
    # (the typed schema refuses the file when it is read, from_dict too: the sites are typed
    # there; the limits' own check stays, for a definition whose raw sites bypass it)
    with pytest.raises(ConfigError, match=r'^bad\.yaml: sites\.lab\.bridge\.max_increment: '
                                          r'must be > 0, got -1\.0$'):
        load_test_file(_write(tmp_path / 'bad.yaml', raw))
    with pytest.raises(ConfigError, match=r'^bad\.yaml: sites\.lab\.bridge\.max_increment: '
                                          r'must be > 0, got -1\.0$'):
        from_dict(read_yaml_file(tmp_path / 'bad.yaml'), source='bad.yaml', base_dir=tmp_path)
    # a site's settings built without the schema (model_construct) still meet the limits'
    # own check, as the bridge would refuse them
    unchecked = SiteSettings.model_construct(
        bridge=SiteBridgeParameters.model_construct(max_increment=-1.0))
    bad = replace(definition, source='bad.yaml', site_settings={'lab': unchecked})
    with pytest.raises(BridgeConfigError, match=r'^bad\.yaml: sites\.lab\.bridge: max_increment '):
        site_limits(bad)
    # a site given as null takes the bridge file's limits, as run_test passes none
    bare = replace(definition, site_settings={'lab': SiteSettings()})
    assert site_limits(bare)['lab'].source == 'bridge.yaml'
    with pytest.raises(ConfigError, match=r'no_such\.yaml: cannot read the bridge parameter '
                                          r'file \(No such file'):
        site_limits(definition, tmp_path / 'no_such.yaml')


def test_a_bad_bridge_file_is_one_line_and_exit_2(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    bridge = bridge_file(tmp_path, on_limit='clip')
    code = offline.main([str(default_test(tmp_path)), '--bridge', str(bridge), '--out',
                         str(tmp_path / 'run'), '--no-figures', '--quiet'])
    err = capsys.readouterr().err
    assert code == 2
    # the bridge's parameter file is read through its schema: the file and the dotted path
    assert err.strip().splitlines() == [
        ("offline: error: bridge.yaml: /**.ros__parameters.on_limit: must be one of 'hold', "
         "'saturate', got 'clip'")]
    assert not (tmp_path / 'run').exists()


@pytest.mark.parametrize(('changes', 'limit'), [
    ({'max_increment': 0.004}, 'max_increment'),
    ({'max_force': 9000.0}, 'max_force'),
    ({'max_displacement': 0.03}, 'max_displacement'),
])
def test_pretest_predicts_the_step_offline_holds_at(tmp_path: Path, changes: dict[str, float],
                                                    limit: str) -> None:
    test_file = default_test(tmp_path)
    bridge = bridge_file(tmp_path, **changes)
    held = _offline(test_file, bridge, tmp_path / 'run').summary['bridge_limits']['held']
    (outcome,) = execute(build_plan(test_file), read_bridge_limits(bridge))
    assert outcome.hold is not None
    assert (outcome.hold.step, outcome.hold.limit, outcome.hold.message) == (
        held['step'], limit, held['message'])
    assert limit in outcome.trips


def test_pretest_predicts_each_runs_step(tmp_path: Path) -> None:
    """Several runs at once (only the runs that trip are integrated again): each run's step is
    the one its own offline run holds at."""
    raw = _raw('default_test.yaml')
    bridge = bridge_file(tmp_path, max_displacement=0.04)
    outcomes = execute(build_plan(_write(tmp_path / 'sweep.yaml', raw),
                                  scales=[0.5, 0.75, 1.0, 1.5]), read_bridge_limits(bridge))
    assert [o.hold is None for o in outcomes] == [True, False, False, False]
    for o in outcomes[1:]:
        raw['ground_motion']['scale'] = o.run.scale
        one = _write(tmp_path / f'scale-{o.run.scale}.yaml', raw)
        held = _offline(one, bridge, tmp_path / f'run-{o.run.scale}').summary['bridge_limits']
        assert o.hold is not None
        assert (o.hold.step, o.hold.message) == (held['held']['step'], held['held']['message'])
