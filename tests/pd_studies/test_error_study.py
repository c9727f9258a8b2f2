"""Experimental errors: injection by the simulated specimen, monitors in the outputs, the study.

* ``specimen.errors`` makes the simulator undershoot/overshoot, delay, add noise and bias, the
  same way (float for float) as the bridge's ``ErrorModel``; without errors nothing changes;
* every run writes ``tracking.csv``, ``summary.tracking`` and ``tracking.png`` (error
  ``xm - x`` and the tracking indicator: negative = energy added), rebuilt identically by the
  replay;
* ``study_errors`` shows systematic errors growing much faster than random ones.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from pd_actuator_bridge.core.error_models import ErrorInjector, ErrorModel
from pd_actuator_bridge.core.errors import BridgeConfigError
from pd_common.config import read_yaml_file
from pd_common.experimental import ErrorModel as SimulatedErrors
from pd_common.experimental import error_model as errors_model
from pd_common.experimental import tracking_error, tracking_indicator
from pd_common.specimen import (
    Elastic,
    PushoverHysteresis,
    Specimen,
    SpecimenConfigError,
    bilinear_backbone,
    specimen_from_config,
)
from pd_common.specimen.server import SpecimenServer, server_from_config
from pd_core.errors import ConfigError
from pd_core.run.record.outputs import read_response_csv
from pd_core.run.runner import rebuild_outputs, run_offline
from pd_core.run.test_file import load_test_file
from pd_studies import study_errors
from support.paths import DEFAULT_TEST, REPO

RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')
K = 312559.0


def write_test(directory: Path, name: str, *, errors: dict[str, Any] | None = None,
               duration: float = 2.0, elastic: bool = False) -> Path:
    """The default test (shortened), optionally elastic and with ``specimen.errors``."""
    raw = yaml.safe_load(DEFAULT_TEST.read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(RECORD)
    raw['test']['duration'] = duration
    raw['test']['id'] = name
    if elastic:
        raw['specimen']['elements'] = [{'model': 'elastic', 'stiffness': K}]
    if errors is not None:
        raw['specimen']['errors'] = errors
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f'{name}.yaml'
    path.write_text(yaml.safe_dump(raw), encoding='utf-8')
    return path


def run(directory: Path, name: str, *, figures: bool = False, **options: Any) -> Any:
    """Run the test written by :func:`write_test` without ROS into ``directory/name``."""
    test_file = write_test(directory / 'tests', name, **options)
    return run_offline(load_test_file(test_file), directory / name, figures=figures)


def read_rows(path: Path) -> list[dict[str, str]]:
    with path.open(encoding='utf-8', newline='') as stream:
        return list(csv.DictReader(stream))


# -- injection ---------------------------------------------------------------------------------
def test_undershoot_measures_target_minus_five_percent_of_the_increment() -> None:
    server = SpecimenServer(Specimen([Elastic(K)], dof_names=['top']),
                            SimulatedErrors(systematic=-0.05))
    previous = 0.0
    for step, target in enumerate([0.0, 0.004, 0.010, 0.007, -0.002, -0.0025]):
        answer = server.handle('t', step, [target])
        assert answer is not None
        expected = target - 0.05 * (target - previous)
        assert answer.measured_displacement[0] == pytest.approx(expected, rel=1e-14, abs=1e-18)
        assert answer.restoring_force[0] == pytest.approx(K * expected, rel=1e-12, abs=1e-12)
        assert server.imposed == answer.measured_displacement  # no noise: measured = reached
        previous = answer.measured_displacement[0]
    # A re-sent command: the same answer, no motion.
    again = server.handle('t', 5, [-0.0025])
    assert again is not None
    assert again.measured_displacement[0] == previous
    assert server.repeated == 1


def test_undershoot_through_a_whole_offline_run(tmp_path: Path) -> None:
    result = run(tmp_path, 'under', elastic=True, errors={'systematic': -0.05})
    history = result.session.history
    x = history.displacement[:, 0]
    xm = history.measured_displacement[:, 0]
    fs = history.restoring_force[:, 0]
    assert xm[0] == 0.0
    expected = x[1:] - 0.05 * (x[1:] - xm[:-1])
    np.testing.assert_allclose(xm[1:], expected, rtol=1e-12, atol=1e-16)
    np.testing.assert_allclose(fs, K * xm, rtol=1e-12, atol=1e-9)
    assert np.max(np.abs(xm - x)) > 1e-5  # the error is really there


def test_noise_is_seeded(tmp_path: Path) -> None:
    noise = {'displacement_noise': 2e-5, 'force_noise': 5.0, 'force_bias': 1.5}
    first = run(tmp_path, 'a', errors={**noise, 'seed': 7})
    second = run(tmp_path, 'b', errors={**noise, 'seed': 7})
    other = run(tmp_path, 'c', errors={**noise, 'seed': 8})
    data = [read_response_csv(r.directory / 'response.csv') for r in (first, second, other)]
    for key in ('x_top', 'xm_top', 'fs_top'):
        assert np.array_equal(data[0][key], data[1][key]), key
    assert not np.array_equal(data[0]['xm_top'], data[2]['xm_top'])
    assert not np.array_equal(data[0]['fs_top'], data[2]['fs_top'])
    # The displacement noise has the requested size; the specimen itself is not displaced.
    error = data[0]['xm_top'] - first.session.history.displacement[:, 0]
    assert 1.5e-5 < np.std(error) < 2.5e-5


def test_error_free_run_is_unchanged_bit_for_bit(tmp_path: Path) -> None:
    plain = run(tmp_path, 'same', duration=3.0)
    reference = (plain.directory / 'response.csv').read_bytes()
    for label, errors in (('empty', {}), ('zeros', {'systematic': 0.0, 'delay_steps': 0,
                                                    'displacement_noise': 0.0,
                                                    'force_noise': 0.0, 'force_bias': 0.0,
                                                    'seed': 3})):
        other = run(tmp_path / label, 'same', duration=3.0, errors=errors)
        assert (other.directory / 'response.csv').read_bytes() == reference, label
    history = plain.session.history
    assert np.array_equal(history.measured_displacement, history.displacement)
    tracking = read_response_csv(plain.directory / 'tracking.csv')
    assert not np.any(tracking['error_top'])
    assert not np.any(tracking['indicator_top'])


def test_simulator_and_bridge_share_one_error_model() -> None:
    """The bridge's ErrorModel/ErrorInjector are the simulator's, with the bridge's checks."""
    assert issubclass(ErrorModel, errors_model.ErrorModel)
    assert issubclass(ErrorInjector, errors_model.ErrorInjector)
    assert fields(ErrorModel) == fields(SimulatedErrors)
    # The bridge subclasses only translate exceptions and check inputs: they add no behaviour.
    assert set(vars(ErrorModel)) <= {'__module__', '__doc__', '_invalid', 'from_mapping'}
    assert {'peek', 'step', '_advance'}.isdisjoint(vars(ErrorInjector))
    mapping = {'systematic': 0.03, 'delay_steps': 2, 'displacement_noise': 1e-5,
               'force_noise': 20.0, 'force_bias': -4.0, 'seed': 11}
    section = {'elements': [{'model': 'pushover', 'backbone': {'bilinear': {
        'stiffness': K, 'yield_force': 1000.0, 'hardening_ratio': 0.02}}},
        {'model': 'elastic', 'stiffness': 2.0e5}], 'topology': 'shear_building'}
    server = server_from_config({**section, 'errors': mapping}, base_dir=REPO,
                                source='t.yaml', dof_names=['a', 'b'])
    specimen = specimen_from_config(section, base_dir=REPO, source='t.yaml',
                                    dof_names=['a', 'b'])
    injector = ErrorInjector(ErrorModel.from_mapping(mapping), 2)

    def restoring_force(x: np.ndarray) -> np.ndarray:
        force = specimen.restoring_force(x)
        specimen.commit()
        return force

    targets = 0.01 * np.sin(np.outer(np.arange(120) * 0.15, [1.0, 1.7]))
    for step, target in enumerate(targets):
        answer = server.handle('t', step, target.tolist())
        expected = injector.apply(target, restoring_force)
        assert answer is not None
        assert answer.measured_displacement == tuple(expected.displacement.tolist())
        assert answer.restoring_force == tuple(expected.force.tolist())
        assert server.imposed == tuple(expected.imposed.tolist())


@pytest.mark.parametrize(('values', 'name'), [
    ({'systematic': -1.0}, 'systematic'),
    ({'systematic': 1.5}, 'systematic'),
    ({'displacement_noise': -1e-6}, 'displacement_noise'),
    ({'force_noise': math.inf}, 'force_noise'),
    ({'force_bias': 'ten'}, 'force_bias'),
    ({'delay_steps': 1.5}, 'delay_steps'),
    ({'seed': -2}, 'seed'),
])
def test_both_error_models_refuse_the_same_values(values: dict[str, Any], name: str) -> None:
    with pytest.raises(SpecimenConfigError, match=rf'^t\.yaml: specimen\.errors\.{name}: '):
        SimulatedErrors.from_mapping(values, 't.yaml')
    with pytest.raises(BridgeConfigError, match=name):
        ErrorModel.from_mapping(values)


def test_bad_errors_section_is_refused_before_anything_is_written(tmp_path: Path) -> None:
    test_file = write_test(tmp_path, 'bad', errors={'undershoot': 0.05})
    # (refused when the file is loaded, by the typed schema: pd_common.config.schema)
    with pytest.raises(ConfigError,
                       match=r'^bad\.yaml: specimen\.errors\.undershoot: unknown key$'):
        run_offline(load_test_file(test_file), tmp_path / 'run')
    raw = read_yaml_file(test_file)  # the simulator's own check says the same
    with pytest.raises(SpecimenConfigError,
                       match=r"bad\.yaml: specimen\.errors: unknown key 'undershoot'"):
        server_from_config(raw['specimen'], base_dir=tmp_path, source='bad.yaml',
                           dof_names=['top'])
    assert not (tmp_path / 'run').exists()
    with pytest.raises(SpecimenConfigError, match='must be a mapping'):
        SimulatedErrors.from_mapping([0.05], 'bad.yaml')


def test_a_fault_does_not_advance_the_delay_line() -> None:
    backbone = bilinear_backbone(1000.0, 10.0, 0.01, max_displacement=0.1)
    element = PushoverHysteresis(backbone, beyond='error')
    server = SpecimenServer(Specimen([element], dof_names=['u']),
                            SimulatedErrors(delay_steps=1))
    first = server.handle('t', 0, [0.01])  # one step late: executes the initial position
    assert first is not None
    assert server.imposed == (0.0,)
    second = server.handle('t', 1, [0.5])  # executes 0.01
    assert second is not None
    assert second.status == 0
    assert server.imposed == (0.01,)
    beyond = server.handle('t', 2, [0.02])  # executes 0.5: beyond the backbone, a fault
    assert beyond is not None
    assert beyond.status != 0
    assert server.imposed == (0.01,)  # no motion
    retry = server.handle('t', 3, [0.03])  # the refused 0.5 is still next in line
    assert retry is not None
    assert retry.status != 0


# -- monitors in the outputs -------------------------------------------------------------------
@pytest.fixture(scope='module')
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """Elastic 6 s runs: clean, 5 % undershoot (with figures) and 5 % overshoot."""
    root = tmp_path_factory.mktemp('monitors')
    return {
        'clean': run(root, 'clean', elastic=True, duration=6.0),
        'under': run(root, 'under', elastic=True, duration=6.0, figures=True,
                     errors={'systematic': -0.05}),
        'over': run(root, 'over', elastic=True, duration=6.0, errors={'systematic': 0.05}),
    }


def test_undershoot_adds_energy_with_a_negative_tracking_indicator(runs: dict[str, Any]
                                                                   ) -> None:
    summaries = {name: result.summary for name, result in runs.items()}
    under = summaries['under']['tracking']['dofs']['top']
    over = summaries['over']['tracking']['dofs']['top']
    clean = summaries['clean']['tracking']['dofs']['top']
    # Undershoot: the measured displacement lags the command -> indicator < 0 (energy added);
    # overshoot leads it -> indicator > 0 (energy removed); a perfect actuator: 0.
    assert under['final_indicator'] < 0.0 < over['final_indicator']
    assert clean['final_indicator'] == 0.0
    assert 'negative = energy added' in summaries['under']['tracking']['indicator_sign']
    # The indicator times the stiffness is the energy the actuator error put in (J): it is the
    # energy-balance error of the run, and the elastic response grows (undershoot) or shrinks.
    for name in ('under', 'over'):
        energy = summaries[name]['energy']['error']
        indicator = summaries[name]['tracking']['dofs']['top']['final_indicator']
        assert energy == pytest.approx(K * indicator, rel=0.02)
    peak = {name: s['dofs']['top']['peaks']['displacement']['abs']
            for name, s in summaries.items()}
    assert peak['over'] < peak['clean'] < peak['under']
    # A larger energy error than the clean run (whose error is the scheme's own).
    assert summaries['under']['energy']['max_error_ratio'] > (
        10 * summaries['clean']['energy']['max_error_ratio'])
    assert summaries['under']['energy']['max_error_ratio'] > 0.01


def test_tracking_outputs(runs: dict[str, Any]) -> None:
    directory = runs['under'].directory
    path = directory / 'tracking.png'
    assert path.is_file()
    assert path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    assert path.stat().st_size > 10_000
    assert not (runs['clean'].directory / 'tracking.png').exists()  # figures=False
    response = read_response_csv(directory / 'response.csv')
    tracking = read_response_csv(directory / 'tracking.csv')
    assert list(tracking) == ['time', 'step', 'error_top', 'indicator_top']
    np.testing.assert_array_equal(tracking['step'], response['step'])
    np.testing.assert_array_equal(
        tracking['error_top'], tracking_error(response['x_top'], response['xm_top']))
    np.testing.assert_array_equal(
        tracking['indicator_top'], tracking_indicator(response['x_top'], response['xm_top']))
    summary = json.loads((directory / 'summary.json').read_text(encoding='utf-8'))
    block = summary['tracking']['dofs']['top']
    error = tracking['error_top']
    assert block['max_abs_error'] == float(np.max(np.abs(error)))
    assert block['rms_error'] == pytest.approx(float(np.sqrt(np.mean(error ** 2))), rel=1e-12)
    assert block['final_indicator'] == tracking['indicator_top'][-1]
    assert summary['tracking']['units'] == {'error': 'm', 'indicator': 'm^2'}


def test_replay_rebuilds_the_tracking_outputs(runs: dict[str, Any], tmp_path: Path) -> None:
    original = runs['under'].directory
    replay = rebuild_outputs(original / 'bag', tmp_path / 'replay', figures=True)
    for name in ('response.csv', 'tracking.csv', 'energy.csv'):
        assert (replay.directory / name).read_bytes() == (original / name).read_bytes(), name
    assert (replay.directory / 'tracking.png').is_file()
    rebuilt = json.loads((replay.directory / 'summary.json').read_text(encoding='utf-8'))
    stored = json.loads((original / 'summary.json').read_text(encoding='utf-8'))
    assert rebuilt['tracking'] == stored['tracking']
    assert rebuilt['energy'] == stored['energy']
    # The injected errors are part of the recorded test definition.
    definition = json.loads((original / 'test_definition.json').read_text(encoding='utf-8'))
    assert definition['specimen']['errors'] == {'systematic': -0.05}


# -- the study command -------------------------------------------------------------------------
def test_study_errors_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'study'
    code = study_errors.main([str(write_test(tmp_path, 'study', duration=6.0)), '--out',
                              str(out), '--levels', '1%', '0.05', '--seeds', '2', '--quiet'])
    assert code == 0, capsys.readouterr().err
    for name in ('errors_table.csv', 'errors_summary.csv', 'errors_growth.png',
                 'errors_response.png', 'study.json'):
        assert (out / name).is_file(), name
        assert (out / name).stat().st_size > 100, name
    assert not (out / 'runs').exists()  # no --keep-runs
    table = read_rows(out / 'errors_table.csv')
    assert len(table) == 1 + 2 * (2 + 2)  # clean + per level: under, over, 2 seeds
    assert {row['state'] for row in table} == {'finished'}
    rows = study_errors.read_table(out / 'errors_summary.csv')
    value = {(row['kind'], row['level']): row for row in rows}

    def systematic(level: float, key: str) -> float:
        return 0.5 * (value['undershoot', level][key] + value['overshoot', level][key])

    for level in (0.01, 0.05):
        random = value['random', level]
        # At the same RMS size, systematic errors move the peak several times more than
        # random ones, even than the worst seed.
        assert systematic(level, 'peak_error') > 2.5 * random['peak_error_max'], level
        assert systematic(level, 'response_error') > 3 * random['response_error'], level
        assert min(value[kind, level]['energy_error_max'] for kind in ('undershoot',
                                                                         'overshoot')) > (
            3 * random['energy_error_max']), level
    # ... and they grow faster with the level.
    assert (systematic(0.05, 'peak_error') - systematic(0.01, 'peak_error')) > 2 * (
        value['random', 0.05]['peak_error'] - value['random', 0.01]['peak_error'])
    for kind in ('undershoot', 'overshoot'):
        assert value[kind, 0.05]['energy_error_max'] > 3 * value[kind, 0.01]['energy_error_max']
        assert value[kind, 0.05]['response_error'] > 3 * value[kind, 0.01]['response_error']
    assert value['undershoot', 0.05]['tracking_indicator'] < 0.0
    assert value['overshoot', 0.05]['tracking_indicator'] > 0.0
    study = json.loads((out / 'study.json').read_text(encoding='utf-8'))
    assert study['levels'] == [0.01, 0.05]
    assert study['increment_rms'] > 0.0
    # A second study into the same folder is refused.
    assert study_errors.main(['--out', str(out), '--duration', '1', '--quiet']) == 2
