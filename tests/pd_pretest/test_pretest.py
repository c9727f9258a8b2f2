"""The batch pre-test (``./pd pretest``): vectorised runs equal one-at-a-time session runs.

Each batch is checked against the project's own ROS-free loop (``TestSession`` +
``SpecimenServer``, the loop ``run_offline`` drives, without its bag), with each run's
definition read by the project's loader from the test file with that run's scale and
parameter values written into it.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from pd_common.protocol import TestState as State
from pd_common.specimen import server_from_config
from pd_core.run.loop.session import TestSession as Session
from pd_core.run.record.history import ResponseHistory
from pd_core.run.test_file import from_dict
from pd_core.verification import nigam_jennings
from pd_pretest import pretest
from pd_pretest.core import (
    BatchSystems,
    BridgeLimits,
    EPPBatch,
    PretestError,
    build_plan,
    execute,
    integrate,
    parse_scales,
    parse_variation,
    read_bridge_limits,
    response_spectrum,
)
from pd_pretest.core.execute import batches
from support.paths import CONFIG

DEFAULT = CONFIG / 'default_test.yaml'
RECORD = CONFIG.parent / 'data' / 'ground_motions' / 'elcentro_1940_ns_chopra.csv'
DURATION = 12.0  # s of El Centro: the strong motion, yielding both ways

ELEMENTS: dict[str, dict[str, Any]] = {
    'epp': {'model': 'epp', 'stiffness': 312559.0, 'yield_force': 10000.0},
    'bilinear_softening': {'model': 'bilinear', 'stiffness': 312559.0, 'yield_force': 10000.0,
                           'hardening_ratio': -0.04, 'residual_force': 4000.0},
    'pushover': {'model': 'pushover',
                 'backbone': {'bilinear': {'stiffness': 312559.0, 'yield_force': 10000.0,
                                           'hardening_ratio': 0.01, 'max_displacement': 0.08}},
                 'beyond_last_point': 'extrapolate'},
}
#: The parameter varied per model (with 4 values x 5 scales = 20 systems).
VARIED = {'epp': 'specimen.elements.0.yield_force',
          'bilinear_softening': 'specimen.elements[0].yield_force',
          'pushover': 'specimen.elements.0.backbone.bilinear.yield_force'}


def _raw() -> dict[str, Any]:
    raw: dict[str, Any] = yaml.safe_load(DEFAULT.read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(RECORD)
    raw['test']['duration'] = DURATION
    return raw


def _write(tmp_path: Path, raw: dict[str, Any], name: str = 'test.yaml') -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(raw), encoding='utf-8')
    return path


def _set(raw: dict[str, Any], dotted: str, value: Any) -> None:
    keys: list[Any] = [int(k) if k.isdigit() else k
                       for k in dotted.replace('[0]', '.0').split('.')]
    node: Any = raw
    for key in keys[:-1]:
        node = node[key]
    node[keys[-1]] = value


def session_history(raw: dict[str, Any], base_dir: Path) -> ResponseHistory:
    """One run, one at a time: the project's loader, session and simulated specimen."""
    definition = from_dict(copy.deepcopy(raw), source='test.yaml', base_dir=base_dir)
    server = server_from_config(definition.specimen, base_dir=base_dir, source='test.yaml',
                                dof_names=definition.dof_names)
    session = Session(definition)
    while (command := session.next_command()) is not None:
        answer = server.handle(command.test_id, command.step, command.target_displacement)
        assert answer is not None
        session.on_feedback(answer)
    assert session.state is State.FINISHED, session.message
    return session.history


@pytest.mark.parametrize('name', sorted(ELEMENTS))
def test_batch_equals_single_session_runs(tmp_path: Path, name: str) -> None:
    raw = _raw()
    raw['specimen']['elements'] = [ELEMENTS[name]]
    path = _write(tmp_path, raw)
    variation = parse_variation(f'{VARIED[name]}=7000:13000:4')
    plan = build_plan(path, scales=parse_scales('0.5:2.5:0.5'), variations=[variation])
    assert len(plan.runs) == 20
    (batch,) = batches(plan)
    result = integrate(batch.systems, batch.models, history=True)
    yielded = 0
    for j, run in enumerate(batch.runs):
        single = copy.deepcopy(raw)
        single['ground_motion']['scale'] = run.scale
        _set(single, VARIED[name], run.values[0])
        history = session_history(single, tmp_path)
        x = history.displacement[:, 0]
        peak = float(np.max(np.abs(x)))
        assert result.peak_displacement[j] == pytest.approx(peak, rel=1e-12, abs=0.0)
        increments = np.abs(np.diff(x, prepend=0.0))
        assert result.max_increment[j] == pytest.approx(float(np.max(increments)), rel=1e-12)
        force = history.restoring_force[:, 0]
        assert result.peak_force[j] == pytest.approx(float(np.max(np.abs(force))), rel=1e-12)
        if j % 7 == 0:  # the whole history of a few runs
            for key, column in (('x', x), ('v', history.velocity[:, 0]),
                                ('a', history.acceleration[:, 0]), ('r', force)):
                scale = float(np.max(np.abs(column)))
                np.testing.assert_allclose(result.history[key][:, j], column, rtol=0.0,
                                           atol=1e-12 * scale, err_msg=f'{name} run {j} {key}')
        yielded += float(np.max(np.abs(force))) > 0.99 * run.values[0]
    assert yielded >= 10  # nonlinear runs, not only elastic ones


def test_records_of_different_lengths_and_formats(tmp_path: Path) -> None:
    """An .AT2 record (its own dt and length) next to the CSV: one batch each, both exact."""
    t = np.arange(0.0, 6.0, 0.005)
    ag = 0.25 * np.sin(2.0 * math.pi * t / 0.6) * np.exp(-0.3 * t)  # in g
    values = ''.join(f'{v:15.7E}' + ('\n' if (i + 1) % 5 == 0 else '')
                     for i, v in enumerate(ag))
    at2 = tmp_path / 'PULSE.AT2'
    at2.write_text('PEER NGA STRONG MOTION DATABASE RECORD\nsynthetic pulse\n'
                   'ACCELERATION TIME SERIES IN UNITS OF G\n'
                   f'NPTS= {t.size}, DT= .0050 SEC\n{values}\n', encoding='utf-8')
    raw = _raw()
    raw['test']['duration'] = None
    raw['specimen']['elements'] = [ELEMENTS['epp']]
    path = _write(tmp_path, raw)
    plan = build_plan(path, records=[RECORD, at2], scales=[0.8, 1.6])
    assert [r.name for r in plan.records] == [RECORD.name, 'PULSE.AT2']
    assert len(batches(plan)) == 2
    limits = BridgeLimits(max_displacement=1.0, max_increment=1.0, max_force=1e6)
    outcomes = execute(plan, limits)
    for o in outcomes:
        single = copy.deepcopy(raw)
        single['ground_motion']['scale'] = o.run.scale
        if o.run.record == 1:
            single['ground_motion'].update(file=str(at2), format='auto')
        x = session_history(single, tmp_path).displacement[:, 0]
        assert o.peak_stroke == pytest.approx(float(np.max(np.abs(x))), rel=1e-12)
        assert o.status == 'ok'
        assert o.trips == ()


def test_structure_variation_changes_mass_and_damping(tmp_path: Path) -> None:
    raw = _raw()
    path = _write(tmp_path, raw)
    plan = build_plan(path, variations=[parse_variation('structure.mass=2000:3000:3')])
    limits = BridgeLimits(max_displacement=1.0, max_increment=1.0, max_force=1e6)
    for o in execute(plan, limits):
        single = copy.deepcopy(raw)
        single['structure']['mass'] = o.run.values[0]
        x = session_history(single, tmp_path).displacement[:, 0]
        assert o.peak_stroke == pytest.approx(float(np.max(np.abs(x))), rel=1e-12)


def test_limit_report_flags_exactly_the_runs_beyond_the_limits(tmp_path: Path) -> None:
    raw = _raw()
    raw['specimen']['elements'] = [ELEMENTS['epp']]
    path = _write(tmp_path, raw)
    plan = build_plan(path, scales=parse_scales('0.4:2.0:0.2'))
    loose = BridgeLimits(max_displacement=10.0, max_increment=10.0, max_force=1e9)
    peaks = execute(plan, loose)
    strokes = sorted(o.peak_stroke for o in peaks)
    increments = sorted(o.max_increment for o in peaks)
    # Limits exactly at one run's peak (that run passes: the bridge allows a value at a limit).
    bridge = tmp_path / 'bridge.yaml'
    bridge.write_text(yaml.safe_dump({'/**': {'ros__parameters': {
        'driver': 'sim_servo', 'max_displacement': strokes[4], 'max_increment': 1.0,
        'max_force': 9999.0, 'max_velocity': 0.0, 'step_duration': 0.0}}}), encoding='utf-8')
    step_duration = 0.02
    limits = read_bridge_limits(bridge, ({'max_velocity': increments[6] / step_duration,
                                          'step_duration': step_duration}, '--limit'))
    assert limits.max_displacement == strokes[4]
    outcomes = execute(plan, limits)
    for o, loose_o in zip(outcomes, peaks):
        single = copy.deepcopy(raw)
        single['ground_motion']['scale'] = o.run.scale
        history = session_history(single, tmp_path)
        x = history.displacement[:, 0]
        expected = []
        if np.max(np.abs(x)) > strokes[4]:
            expected.append('max_displacement')
        if np.max(np.abs(np.diff(x, prepend=0.0))) / step_duration > limits.max_velocity:
            expected.append('max_velocity')
        if np.max(np.abs(history.restoring_force)) > 9999.0:
            expected.append('max_force')
        assert o.trips == tuple(expected), o.run.scale
        assert loose_o.trips == ()
    assert sum('max_displacement' in o.trips for o in outcomes) == len(outcomes) - 5
    assert sum('max_velocity' in o.trips for o in outcomes) == len(outcomes) - 7
    assert 0 < sum('max_force' in o.trips for o in outcomes) < len(outcomes)
    off = read_bridge_limits(bridge)
    assert off.max_velocity is None and off.step_duration is None
    assert all('max_velocity' not in o.trips for o in execute(plan, off))


def test_spectrum_equals_the_exact_method_period_by_period() -> None:
    from pd_core.dynamics.record_readers import read_ground_motion  # noqa: PLC0415

    motion = read_ground_motion(RECORD, units='g', g=9.81)
    periods = np.array([0.05, 0.2, 0.567, 1.0, 3.0])
    spectrum = response_spectrum(motion.acceleration, motion.dt, periods, damping=0.05)
    for period, sa in zip(periods, spectrum.pseudo_acceleration):
        omega = 2.0 * math.pi / period
        x, _, _ = nigam_jennings(omega, 0.05, motion.dt, -motion.acceleration)
        assert sa == pytest.approx(omega**2 * float(np.max(np.abs(x))), rel=1e-12)


def test_spectrum_of_a_constant_acceleration_is_the_closed_form() -> None:
    """A step ``a_g = a0`` from rest: ``x_max = a0/ω² (1 + exp(−πζ/√(1−ζ²)))`` at π/ω_D."""
    a0, zeta, period = 2.0, 0.05, 0.8
    omega = 2.0 * math.pi / period
    t_peak = math.pi / (omega * math.sqrt(1.0 - zeta**2))
    dt = t_peak / 400  # the peak is a sample
    ag = np.full(2000, a0)
    spectrum = response_spectrum(ag, dt, np.array([period]), damping=zeta)
    expected = a0 * (1.0 + math.exp(-math.pi * zeta / math.sqrt(1.0 - zeta**2)))
    assert spectrum.pseudo_acceleration[0] == pytest.approx(expected, rel=1e-9)


def test_two_processes_give_the_same_results() -> None:
    n, steps = 4200, 300
    ag = 3.0 * np.sin(np.arange(steps + 1) * 0.02 * 7.0)
    systems = BatchSystems(mass=np.ones(n), damping=np.full(n, 0.25), load_factor=np.ones(n),
                           motions=np.outer(ag, np.linspace(0.5, 1.5, 7)),
                           motion_index=np.arange(n) % 7, dt=0.02)
    fy = np.linspace(0.5, 1.5, n)
    from pd_common.specimen import ElasticPerfectlyPlastic  # noqa: PLC0415

    models = [ElasticPerfectlyPlastic(39.478, f) for f in fy]
    one = integrate(systems, models, workers=1)
    two = integrate(systems, models, workers=2)
    np.testing.assert_array_equal(one.peak_displacement, two.peak_displacement)
    np.testing.assert_array_equal(one.peak_force, two.peak_force)
    assert EPPBatch(np.full(3, 1.0), np.full(3, 1.0)).n == 3


def test_cli_writes_csv_figures_and_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                          ) -> None:
    raw = _raw()
    path = _write(tmp_path, raw)
    out = tmp_path / 'out'
    code = pretest.main([str(path), '--scales', '0.5:1.5:0.5', '--vary',
                         'specimen.elements.0.backbone.bilinear.yield_force=9000:11000:2',
                         '--step-duration', '0.05', '--limit', 'max_velocity=0.09',
                         '--out', str(out)])
    assert code == 0
    text = capsys.readouterr().out
    assert '6 runs' in text and 'max_velocity:' in text
    rows = (out / 'pretest.csv').read_text(encoding='utf-8').splitlines()
    assert len(rows) == 7
    assert rows[0].startswith('run,record,scale,specimen.elements.0.backbone.bilinear.yield_force')
    assert any('max_velocity' in row for row in rows[1:])
    for name in ('spectra.csv', 'spectra.png', 'demand.png'):
        assert (out / name).stat().st_size > 0


def _bad(tmp_path: Path, change: dict[str, Any] | None = None) -> Path:
    raw = _raw()
    for dotted, value in (change or {}).items():
        _set(raw, dotted, value)
    return _write(tmp_path, raw, 'bad.yaml')


@pytest.mark.parametrize(('args', 'change', 'expected'), [
    (['--scales', '1.5:0.5:0.1'], None, '--scales'),
    (['--scales', '-1'], None, '--scales'),
    (['--vary', 'specimen.elements.0.yield=1:2:3'], None,
     ("unknown key 'yield' (allowed: backbone, beyond_last_point, memory, model, "
      'unloading_stiffness) (with --vary specimen.elements.0.yield=1)')),
    (['--vary', 'specimen.elements.3.stiffness=1:2:3'], None, 'specimen.elements'),
    (['--vary', 'structure.mass=1:2'], None, 'NAME=LO:HI:N'),
    (['--vary', 'structure.mass=-5:2:2'], None, 'structure.mass'),
    (['--records', 'no_such_record.AT2'], None, 'no_such_record.AT2'),
    (['--limit', 'max_speed=1'], None, '--limit'),
    (['--bridge', 'no_such_bridge.yaml'], None, 'no_such_bridge.yaml'),
    ([], {'test.scheme': 'alpha_os'}, "test.scheme 'alpha_os' is not supported"),
    ([], {'specimen.elements.0': {'model': 'bouc_wen', 'stiffness': 312559.0,
                                  'post_yield_ratio': 0.05, 'exponent': 1.0, 'beta': 25.0,
                                  'gamma': 25.0}}, 'BoucWen is not supported'),
    ([], {'specimen.elements.0.memory': 'kinematic'}, "memory 'kinematic' is not supported"),
    ([], {'structure.initial_stiffness': 'probe'}, "'probe' is not supported"),
    ([], {'test.dt': -0.01}, 'test.dt'),
])
def test_bad_input_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                      args: list[str], change: dict[str, Any] | None,
                                      expected: str) -> None:
    path = _bad(tmp_path, change)
    code = pretest.main([str(path), '--out', str(tmp_path / 'out'), '--no-figures', *args])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1, err
    assert expected in err and 'Traceback' not in err


@pytest.mark.parametrize(('parameters', 'args', 'expected'), [
    # the bridge's file is read through its schema, as ./pd run reads it: file + dotted path
    ({'max_force': True}, [], 'bad_bridge.yaml: /**.ros__parameters.max_force: '),
    ({'max_increment': -0.02}, [], ('bad_bridge.yaml: /**.ros__parameters.max_increment: '
                                    'must be > 0, got -0.02')),
    ({'max_displacment': 0.1}, [], ('bad_bridge.yaml: /**.ros__parameters.max_displacment: '
                                    'unknown key')),
    # an override is checked by the same schema, and the limits together as the bridge does
    ({}, ['--step-duration', '-1'], '--step-duration: step_duration: must be >= 0, got -1.0'),
    ({}, ['--limit', 'max_velocity=0.1'], 'max_velocity requires step_duration'),
])
def test_a_bridge_file_or_override_the_bridge_would_refuse_is_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], parameters: dict[str, Any],
        args: list[str], expected: str) -> None:
    bridge = tmp_path / 'bad_bridge.yaml'
    bridge.write_text(yaml.safe_dump({'/**': {'ros__parameters': {'driver': 'sim_servo',
                                                                  **parameters}}}),
                      encoding='utf-8')
    code = pretest.main([str(_bad(tmp_path, None)), '--out', str(tmp_path / 'out'),
                         '--no-figures', '--bridge', str(bridge), *args])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1, err
    assert expected in err and 'Traceback' not in err
    assert not (tmp_path / 'out').exists()


@pytest.mark.parametrize(('test_file', 'expected'), [
    ('three_story_two_sites.yaml', 'substructured test'),
    ('column_axial.yaml', 'substructured test'),
])
def test_substructured_tests_are_refused(capsys: pytest.CaptureFixture[str], test_file: str,
                                         expected: str) -> None:
    assert pretest.main([str(CONFIG / test_file), '--no-figures']) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and expected in err and test_file in err


def test_plan_refuses_a_duplicate_variation(tmp_path: Path) -> None:
    path = _write(tmp_path, _raw())
    variation = parse_variation('structure.mass=1000:2000:2')
    with pytest.raises(PretestError, match='given twice'):
        build_plan(path, variations=[variation, variation])
