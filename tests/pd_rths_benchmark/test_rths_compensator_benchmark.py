"""The default compensator on the vRTHS benchmark (Case 1, El Centro ×0.4, the benchmark loop):
better than PI-P on every J, J1 ≤ 0.5 ms, J2 near the noise floor, capacity not reached."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pd_common.rths import (
    BENCHMARK_CAPACITY,
    BENCHMARK_NOISE,
    BENCHMARK_QUANTUM,
    BENCHMARK_SPECIMEN,
    make_compensator,
)
from pd_common.rths.compensation import DEFAULT_COMPENSATOR
from pd_common.rths.plant import BenchmarkPlant
from pd_rths_benchmark.core.benchmark_loop import run_benchmark_loop
from pd_rths_benchmark.core.criteria import J_KEYS, j_criteria, noise_floor_percent
from pd_rths_benchmark.core.problem import (
    benchmark_case,
    prepare_ground_motion,
    reference_response,
)

DT = 1.0 / 4096.0
RECORD = (Path(__file__).resolve().parents[2]
          / 'src/pd_integrator/data/ground_motions/elcentro_1940_ns_chopra.csv')


@pytest.fixture(scope='module')
def elcentro() -> tuple[np.ndarray, np.ndarray]:
    """The benchmark's input: El Centro NS (g → m/s²) ×0.4, 5 s of zeros each side, 4096 Hz."""
    data = np.loadtxt(RECORD, delimiter=',', comments='#')
    return prepare_ground_motion(data[:, 1] * 9.80665, float(data[1, 0] - data[0, 0]), 0.4)


def _j(name: str, t: np.ndarray, ag: np.ndarray) -> tuple[dict[str, float], float, bool]:
    case = benchmark_case(1)
    result = run_benchmark_loop(case, t, ag, make_compensator(name, DT), BenchmarkPlant(DT),
                                BENCHMARK_SPECIMEN, BENCHMARK_NOISE, BENCHMARK_QUANTUM,
                                BENCHMARK_CAPACITY)
    j = j_criteria(result.x_d, result.x_m, result.floors, reference_response(case, t, ag), DT)
    floor = noise_floor_percent(BENCHMARK_NOISE.displacement_std(DT), result.x_d)
    return j, floor, result.capacity_reached


def test_default_compensator_beats_pi_p_on_every_j(
        elcentro: tuple[np.ndarray, np.ndarray]) -> None:
    t, ag = elcentro
    baseline, _floor, _reached = _j('pi_p', t, ag)
    best, floor, reached = _j(DEFAULT_COMPENSATOR, t, ag)
    for key in J_KEYS:
        assert best[key] < baseline[key], key
    assert best['J1'] <= 0.5
    assert best['J2'] <= 1.15 * floor
    assert not reached
