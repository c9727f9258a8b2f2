"""``./pd rths_benchmark``: outputs, records, the written test file, one-line errors."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from scipy import io

from pd_core.dynamics.record_readers import read_ground_motion
from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file
from pd_rths_benchmark.core.benchmark import (
    BenchmarkOptions,
    load_record,
    run_benchmark,
)
from pd_rths_benchmark.core.criteria import J_KEYS
from pd_rths_benchmark.rths_benchmark import main

RECORD = (Path(__file__).resolve().parents[2] / 'src' / 'pd_integrator' / 'data'
          / 'ground_motions' / 'elcentro_1940_ns_chopra.csv')


@pytest.fixture(scope='module')
def short_record(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The first 3 s of El Centro (g), as a two-column file."""
    motion = read_ground_motion(RECORD, units='g')
    n = round(3.0 / motion.dt)
    path = tmp_path_factory.mktemp('record') / 'elcentro_3s.csv'
    with path.open('w', newline='') as handle:
        writer = csv.writer(handle)
        for i in range(n):
            writer.writerow([f'{i * motion.dt:.6f}', repr(float(motion.acceleration[i] / 9.81))])
    return path


@pytest.mark.parametrize('loop', ['benchmark', 'native'])
def test_the_outputs_of_a_run(short_record: Path, tmp_path: Path, loop: str,
                              capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / loop
    code = main(['--record', str(short_record), '--loop', loop, '--controller', 'model_based',
                 '--out', str(out), '--perturbed', '2', *(['--no-figures'] if loop ==
                                                           'native' else [])])
    assert code == 0
    printed = capsys.readouterr().out
    assert 'J1' in printed and 'worst' in printed
    document = json.loads((out / 'j_values.json').read_text())
    for key in (*J_KEYS, 'noise_floor_percent'):
        assert isinstance(document[key], float)
    assert document['controller'] == 'model_based' and document['loop'] == loop
    assert document['capacity_reached'] is False
    assert document['perturbed']['n'] == 2 and 'worst' in document['perturbed']['J2']
    # the perturbed plants are the seed's first two: their J2 rows are in perturbed.csv
    rows = list(csv.DictReader((out / 'perturbed.csv').open()))
    assert [row['plant'] for row in rows] == ['perturbed 0 (seed 0)', 'perturbed 1 (seed 0)']
    worst = max(float(row['J2']) for row in rows)
    assert document['perturbed']['J2']['worst'] == pytest.approx(worst, rel=1e-5)
    header = (out / 'histories.csv').read_text().splitlines()[0]
    assert header == 't,x_d,x_m,x1,x2,x3,x1_ref,x2_ref,x3_ref'
    if loop == 'benchmark':
        assert (out / 'tracking.png').stat().st_size > 10_000
        assert (out / 'floors.png').stat().st_size > 10_000


def test_a_mat_record_is_read_in_m_s2(short_record: Path, tmp_path: Path) -> None:
    """The benchmark's own records: MATLAB files, rows [time; acceleration m/s²]."""
    motion = read_ground_motion(short_record, units='g')
    mat = tmp_path / 'record.mat'
    t = np.arange(motion.n_samples) * motion.dt
    io.savemat(mat, {'accel': np.vstack([t, motion.acceleration])})
    options = BenchmarkOptions(controller='model_based')
    from_csv = run_benchmark(options, load_record(short_record))
    from_mat = run_benchmark(options, load_record(mat))
    for key in J_KEYS:
        assert from_mat.j[key] == pytest.approx(from_csv.j[key], rel=1e-9, abs=1e-12)


def test_the_written_test_file_runs_offline_as_the_native_loop(short_record: Path,
                                                               tmp_path: Path) -> None:
    path = tmp_path / 'case2.yaml'
    assert main(['--record', str(short_record), '--case', '2', '--controller', 'model_based',
                 '--loop', 'native', '--write-test', str(path)]) == 0
    written = path.read_bytes()
    # written once: a second --write-test to the same file is one line, the file kept
    assert main(['--record', str(short_record), '--case', '2', '--loop', 'native',
                 '--write-test', str(path)]) == 2
    assert path.read_bytes() == written
    definition = load_test_file(path)
    assert definition.sites is not None
    assert definition.sites['lab1']['bridge']['driver'] == 'transfer_system'
    result = run_offline(definition, tmp_path / 'run', figures=False)
    native = run_benchmark(BenchmarkOptions(case=2, controller='model_based', loop='native'),
                           load_record(short_record))
    history = result.session.history
    np.testing.assert_array_equal(history.displacement[:history.n_committed], native.floors)


@pytest.mark.parametrize(('argv', 'message'), [
    (['--record', '/no/such/record.csv'], '--record /no/such/record.csv: no such file'),
    (['--controller', 'nope'], "unknown compensator 'nope'"),
    (['--set', 'delay=slow'], 'parameter delay must be float'),
    (['--set', 'delay'], '--set: expected NAME=VALUE'),
    (['--intensity', '-1'], '--intensity: must be a positive number'),
    (['--loop', 'native', '--dt', '0.001'], '--dt: the integration step must be a whole'),
    (['--perturbed', '-2'], '--perturbed: must be 0 to 10,000 plants, got -2'),
    (['--ideal', '--perturbed', '1'], 'an ideal transfer system has no perturbed plants'),
])
def test_bad_input_is_one_line_and_exit_2(argv: list[str], message: str, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    assert main([*argv, '--out', str(tmp_path / 'out'), '--no-figures']) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and '\n' not in err and 'Traceback' not in err
    assert not (tmp_path / 'out' / 'j_values.json').exists()
