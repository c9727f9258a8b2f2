"""The vRTHS benchmark's records run as the benchmark runs them; ``--ideal`` has no delay.

The benchmark ships its records as MATLAB files (``ElCentroAccelNoScaling.mat``,
``KobeAccelNoScaling.mat``, ``MorganAccelNoScaling.mat``: one array of rows ``[t; a]``, m/s²)
that already carry their zeros ("a zero vector of around 10 sec has been added to each
earthquake", ``F1_input_file.m``), and its model runs from 0 to ``tend = X(1, end)`` at the
fixed step 1/4096 s: ``⌊tend · 4096⌋ + 1`` samples. Its El Centro is the 31.18 s record with
5 s of zeros at each end, 41.18 s. The Kobe and Morgan Hill files are not redistributable
here; records of the same form (other steps, a first sample that is not zero) stand in for
them.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import io

from pd_core.dynamics.record_readers import read_ground_motion
from pd_core.errors import ConfigError
from pd_rths_benchmark.core.benchmark import (
    BenchmarkOptions,
    BenchmarkRecord,
    benchmark_ground_motion,
    load_record,
    native_benchmark_file,
    run_benchmark,
)
from pd_rths_benchmark.core.criteria import J_KEYS, tracking_delay
from pd_rths_benchmark.core.problem import padding_needed, prepare_ground_motion

RECORD = (Path(__file__).resolve().parents[2] / 'src' / 'pd_integrator' / 'data'
          / 'ground_motions' / 'elcentro_1940_ns_chopra.csv')
RATE = 4096.0
G = 9.81  # the readers' g (the thesis's MATLAB)


def _benchmark_file(path: Path, name: str, acceleration: np.ndarray, dt: float,
                    padding: float = 5.0) -> float:
    """Write ``acceleration`` (m/s²) as the benchmark ships a record: ``padding`` s of zeros at
    each end, rows ``[t; a]`` under ``name``; returns its last time (the benchmark's tend)."""
    zeros = np.zeros(round(padding / dt))
    padded = np.concatenate([zeros, acceleration, zeros])
    t = np.arange(padded.size) * dt
    io.savemat(path, {name: np.vstack([t, padded])})
    return float(t[-1])


def _elcentro() -> tuple[np.ndarray, float]:
    motion = read_ground_motion(RECORD, units='g')
    return np.asarray(motion.acceleration, dtype=float), float(motion.dt)


def _synthetic(seconds: float, dt: float, seed: int) -> np.ndarray:
    """A windowed random motion (m/s²) whose first and last samples are not zero."""
    rng = np.random.default_rng(seed)
    n = round(seconds / dt) + 1
    window = 0.2 + np.sin(np.pi * np.arange(n) / (n - 1))
    return np.asarray(2.0 * window * rng.standard_normal(n), dtype=float)


def _records(tmp_path: Path) -> dict[str, tuple[Path, float]]:
    elcentro, dt = _elcentro()
    records = {}
    for name, acceleration, step in (
            ('ElCentroAccel', elcentro, dt),
            ('KobeAccel', _synthetic(20.0, 0.01, 1), 0.01),
            ('MorganAccel', _synthetic(12.0, 0.005, 2), 0.005)):
        path = tmp_path / f'{name}NoScaling.mat'
        records[name] = (path, _benchmark_file(path, name, acceleration, step))
    return records


def test_benchmark_records_are_not_padded_again(tmp_path: Path) -> None:
    records = _records(tmp_path)
    # the benchmark's El Centro: 31.18 s + 2 × 5 s
    assert records['ElCentroAccel'][1] == pytest.approx(41.18, abs=1e-9)
    for name, (path, tend) in records.items():
        record = load_record(path)
        t, ag = benchmark_ground_motion(record, 0.4)
        expected = math.floor(tend * RATE + 1e-9) + 1
        assert t.size == expected, name
        assert t[-1] <= tend + 1e-12 and tend - t[-1] < 1.0 / RATE
        # the record itself × 0.4, linear between its samples, nothing added
        data = io.loadmat(path)[name]
        np.testing.assert_allclose(ag, 0.4 * np.interp(t, data[0], data[1]), rtol=0,
                                   atol=1e-12 * np.max(np.abs(ag)))
        # the native loop's test file: the record as it is, the duration the benchmark's
        options = BenchmarkOptions(loop='native', controller='none')
        raw = native_benchmark_file(options, record)
        inline = raw['ground_motion']['inline']
        np.testing.assert_array_equal(inline['acceleration'], record.acceleration)
        assert raw['test']['duration'] == pytest.approx(
            math.floor(tend / options.integration_dt + 1e-9) * options.integration_dt)
    assert load_record(records['ElCentroAccel'][0]).acceleration.size == 2060
    # 168,674 samples: 41.18 s at 4096 Hz from 0 (51.18 s, 209,634 samples, when padded twice)
    record = load_record(records['ElCentroAccel'][0])
    assert benchmark_ground_motion(record, 0.4)[0].size == 168_674


def test_the_shipped_record_gets_the_zeros_of_the_benchmarks(tmp_path: Path) -> None:
    """The shipped El Centro (no zeros) padded here is the benchmark's El Centro as shipped:
    the same samples, the same reference, noise floor and J-values."""
    path, _tend = _records(tmp_path)['ElCentroAccel']
    shipped = load_record(RECORD)
    benchmark = load_record(path)
    t_shipped, ag_shipped = benchmark_ground_motion(shipped, 0.4)
    t_benchmark, ag_benchmark = benchmark_ground_motion(benchmark, 0.4)
    np.testing.assert_array_equal(t_shipped, t_benchmark)
    np.testing.assert_allclose(ag_benchmark, ag_shipped, rtol=0,
                               atol=1e-12 * np.max(np.abs(ag_shipped)))
    options = BenchmarkOptions(controller='pi_p')
    runs = [run_benchmark(options, record) for record in (shipped, benchmark)]
    assert runs[0].samples == runs[1].samples == 168_674
    assert runs[1].noise_floor_percent == pytest.approx(runs[0].noise_floor_percent,
                                                        rel=1e-9)
    for key in J_KEYS:
        assert runs[1].j[key] == pytest.approx(runs[0].j[key], rel=1e-6, abs=1e-9), key


def test_padding_only_where_the_zeros_are_missing() -> None:
    record = np.array([0.0, 0.0, 0.0, 1.0, -1.0, 0.5, 0.0])
    assert padding_needed(record, 3) == (False, True)   # 3 zeros before, 1 after
    assert padding_needed(record, 2) == (False, True)
    assert padding_needed(record, 4) == (True, True)
    assert padding_needed(record[::-1], 3) == (True, False)
    assert padding_needed(record, 0) == (False, False)
    assert padding_needed(np.zeros(5), 3) == (False, False)
    # an end that has its zeros keeps its times; the other end gets the whole padding
    dt = 0.5
    t, ag = prepare_ground_motion(record, dt, intensity=1.0, rate=4.0, padding=1.5)
    assert t[-1] == pytest.approx((record.size - 1) * dt + 1.5)
    np.testing.assert_allclose(ag[:t.size - 6], np.interp(t[:t.size - 6],
                                                           np.arange(record.size) * dt, record))
    assert np.all(ag[t >= (record.size - 1) * dt] == 0.0)


@pytest.fixture(scope='module')
def short_record() -> BenchmarkRecord:
    """The first 3 s of El Centro."""
    acceleration, dt = _elcentro()
    return BenchmarkRecord(acceleration=acceleration[:round(3.0 / dt)], dt=dt, source='3 s')


@pytest.mark.parametrize('loop', ['benchmark', 'native'])
def test_ideal_transfer_system_has_no_delay(short_record: BenchmarkRecord, loop: str) -> None:
    """``--ideal``: x_m = x_d at every sample (the same sample), so J1 = J2 = J3 = 0."""
    run = run_benchmark(BenchmarkOptions(loop=loop, ideal=True, controller='none'),
                        short_record)
    np.testing.assert_array_equal(run.x_m, run.x_d)
    assert np.max(np.abs(run.x_d)) > 1e-4
    assert tracking_delay(run.x_d, run.x_m, 1.0 / RATE) == 0.0
    assert run.j['J1'] == 0.0
    assert run.j['J2'] == 0.0 and run.j['J3'] == 0.0
    # what is left is the loop's own error: the benchmark loop's one-sample force delay and
    # backward differences, against the exact reference
    assert run.j['J4'] > 0.0 and run.noise_floor_percent == 0.0


def test_ideal_takes_no_controller() -> None:
    with pytest.raises(ConfigError, match=r'--ideal: .* --controller must be none'):
        BenchmarkOptions(ideal=True, controller='pi_p')
