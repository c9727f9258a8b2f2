"""The vRTHS benchmark's own loop: against an independent implementation, convergence, noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pd_common.rths import (
    BENCHMARK_NOISE,
    BENCHMARK_QUANTUM,
    BENCHMARK_SPECIMEN,
    IdealPlant,
    SensorNoise,
    make_compensator,
)
from pd_common.rths.plant import BenchmarkPlant
from pd_core.errors import ConfigError
from pd_rths_benchmark.core.benchmark_loop import (
    rk4_linear_map,
    run_benchmark_loop,
    substructure_state_space,
)
from pd_rths_benchmark.core.problem import (
    benchmark_case,
    numerical_substructure,
    prepare_ground_motion,
    reference_response,
)

DT = 1.0 / 4096.0


def _record(rate: float, seconds: float = 3.0) -> tuple[np.ndarray, np.ndarray]:
    """A smooth synthetic record (two tones in a window), padded as the benchmark pads."""
    dt_record = 0.01
    tr = np.arange(int(seconds / dt_record) + 1) * dt_record
    window = np.sin(math.pi * tr / tr[-1]) ** 2
    acc = 1.0 * window * (np.sin(2 * math.pi * 2.5 * tr) + 0.4 * np.sin(2 * math.pi * 9.0 * tr))
    return prepare_ground_motion(acc, dt_record, intensity=1.0, rate=rate, padding=0.5)


def _independent_loop(case_number: int, t: np.ndarray, ag: np.ndarray) -> np.ndarray:
    """The same scheme written from its description with numpy: ideal plant (y[k] = x_d[k−1]),
    no noise, backward-difference force, unit delay, RK4 with the midpoint of ẍ_g."""
    case = benchmark_case(case_number)
    h = float(t[1] - t[0])
    m_n, c_n, k_n = numerical_substructure(case, BENCHMARK_SPECIMEN)
    iota_load = case.mass @ np.ones(3)
    e1 = np.array([1.0, 0.0, 0.0])

    def rate(z: np.ndarray, g: float, force: float) -> np.ndarray:
        x, v = z[:3], z[3:]
        acc = np.linalg.solve(m_n, -k_n @ x - c_n @ v - iota_load * g - e1 * force)
        return np.concatenate([v, acc])

    sp = BENCHMARK_SPECIMEN
    z = np.zeros(6)
    x_d = np.zeros(t.size)
    y_hist = [0.0, 0.0]             # y[k−1], y[k−2]
    command_prev = 0.0
    force_hist = [0.0]              # F_m[k−1]
    g = np.append(ag, ag[-1])
    for k in range(t.size):
        x_d[k] = z[0]
        y = command_prev
        force = (sp.stiffness * y + sp.damping * (y - y_hist[0]) / h
                 + sp.mass * (y - 2 * y_hist[0] + y_hist[1]) / h ** 2)
        command_prev = z[0]
        fd = force_hist[0]
        gm = 0.5 * (g[k] + g[k + 1])
        k1 = rate(z, g[k], fd)
        k2 = rate(z + h / 2 * k1, gm, fd)
        k3 = rate(z + h / 2 * k2, gm, fd)
        k4 = rate(z + h * k3, g[k + 1], fd)
        z = z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        force_hist[0] = force
        y_hist = [y, y_hist[0]]
    return x_d


def test_ideal_plant_loop_equals_an_independent_implementation() -> None:
    t, ag = _record(4096.0, seconds=1.5)
    case = benchmark_case(1)
    result = run_benchmark_loop(case, t, ag, make_compensator('none', DT), IdealPlant(DT),
                                BENCHMARK_SPECIMEN)
    expected = _independent_loop(1, t, ag)
    np.testing.assert_allclose(result.x_d, expected, rtol=0,
                               atol=1e-10 * np.max(np.abs(expected)))
    # the ideal plant: x_m[k] = u[k−1] = x_d[k−1]; no noise, no quantisation
    np.testing.assert_array_equal(result.x_m[1:], result.x_d[:-1])
    np.testing.assert_array_equal(result.u, result.x_d)
    np.testing.assert_array_equal(result.floors[:, 0], result.x_d)


def test_ideal_plant_loop_converges_to_the_reference_at_first_order() -> None:
    # The force's delays (one sample of the plant, one of the unit delay, backward
    # differences) are O(h): halving h halves the error of every floor.
    case = benchmark_case(1)
    errors = []
    for rate in (2048.0, 4096.0, 8192.0):
        h = 1.0 / rate
        t, ag = _record(rate)
        reference = reference_response(case, t, ag)
        result = run_benchmark_loop(case, t, ag, make_compensator('none', h), IdealPlant(h),
                                    BENCHMARK_SPECIMEN)
        errors.append(np.max(np.abs(result.floors - reference)) / np.max(np.abs(reference)))
    for coarse, fine in zip(errors, errors[1:], strict=False):
        assert 1.8 < coarse / fine < 2.2


def test_perfect_actuator_leaves_the_force_delay_error() -> None:
    # x_m = x_d exactly; the hybrid run still differs from the reference by the unit delay and
    # the backward differences: O(h), halving with h (the J4 ≈ 1.8 % at 4096 Hz).
    case = benchmark_case(4)
    errors = []
    for rate in (4096.0, 8192.0):
        h = 1.0 / rate
        t, ag = _record(rate)
        reference = reference_response(case, t, ag)
        result = run_benchmark_loop(case, t, ag, make_compensator('none', h), IdealPlant(h),
                                    BENCHMARK_SPECIMEN, perfect_actuator=True)
        np.testing.assert_array_equal(result.x_m, result.x_d)
        errors.append(np.std(result.floors - reference) / np.std(reference))
    assert 1.8 < errors[0] / errors[1] < 2.2


def test_rk4_linear_map_is_one_rk4_step() -> None:
    a, b = substructure_state_space(benchmark_case(2), BENCHMARK_SPECIMEN)
    a_rk, p, q, r = rk4_linear_map(a, b, DT)
    rng = np.random.default_rng(0)
    z = rng.standard_normal(6) * 1e-3
    g0, g1, force = 1.3, -0.7, 250.0

    def f(x: np.ndarray, g: float) -> np.ndarray:
        return np.asarray(a @ x + b[:, 0] * g + b[:, 1] * force)

    k1 = f(z, g0)
    k2 = f(z + DT / 2 * k1, (g0 + g1) / 2)
    k3 = f(z + DT / 2 * k2, (g0 + g1) / 2)
    k4 = f(z + DT * k3, g1)
    expected = z + DT / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    np.testing.assert_allclose(a_rk @ z + p * g0 + q * g1 + r * force, expected,
                               rtol=1e-12, atol=1e-18)
    # and RK4's stability function on the eigenvalues: A_rk = Σ (hA)^j / j!, j ≤ 4
    ha = DT * a
    series = np.eye(6) + ha + ha @ ha / 2 + ha @ ha @ ha / 6 + ha @ ha @ ha @ ha / 24
    np.testing.assert_allclose(a_rk, series, rtol=1e-12, atol=1e-14)


def test_noise_statistics_and_determinism_by_seed() -> None:
    n = 40000
    t = np.arange(n) * DT
    ag = np.zeros(n)
    case = benchmark_case(1)
    noise = SensorNoise(BENCHMARK_NOISE.displacement_power, BENCHMARK_NOISE.force_power, seed=4)
    first = run_benchmark_loop(case, t, ag, make_compensator('none', DT), IdealPlant(DT),
                               BENCHMARK_SPECIMEN, noise)
    again = run_benchmark_loop(case, t, ag, make_compensator('none', DT), IdealPlant(DT),
                               BENCHMARK_SPECIMEN, noise)
    np.testing.assert_array_equal(first.x_m, again.x_m)
    np.testing.assert_array_equal(first.floors, again.floors)
    other = run_benchmark_loop(case, t, ag, make_compensator('none', DT), IdealPlant(DT),
                               BENCHMARK_SPECIMEN,
                               SensorNoise(noise.displacement_power, noise.force_power, seed=5))
    assert not np.array_equal(first.x_m, other.x_m)
    # At rest with u = x_d = 0 (the noise drives the structure only through the force, and
    # x_d = 0 holds until the first noisy force arrives), the first samples are pure noise.
    assert first.x_m[0] == pytest.approx(
        np.random.default_rng(4).standard_normal(1)[0] * math.sqrt(6.25e-14 * 4096))
    # The recorded measurement is y + noise; y is the ideal plant's last command (x_d[k−1]).
    noise_x = first.x_m - np.concatenate([[0.0], first.u[:-1]])
    assert np.std(noise_x) == pytest.approx(1.6e-5, rel=0.02)
    # the force noise: the measured force minus the specimen force of y
    y = first.x_m - noise_x
    y1 = np.concatenate([[0.0], y[:-1]])
    y2 = np.concatenate([[0.0, 0.0], y[:-2]])
    sp = BENCHMARK_SPECIMEN
    clean = (sp.stiffness * y + sp.damping * (y - y1) / DT
             + sp.mass * (y - 2 * y1 + y2) / DT ** 2)
    assert np.std(first.force - clean) == pytest.approx(math.sqrt(1.16e-3 * 4096), rel=0.02)


def test_quantised_commands_capacity_and_the_benchmark_plant() -> None:
    t, ag = _record(4096.0, seconds=2.0)
    case = benchmark_case(1)
    result = run_benchmark_loop(case, t, ag, make_compensator('pi_p', DT), BenchmarkPlant(DT),
                                BENCHMARK_SPECIMEN, BENCHMARK_NOISE, BENCHMARK_QUANTUM, 8900.0)
    steps = result.u / BENCHMARK_QUANTUM
    np.testing.assert_allclose(steps, np.round(steps), rtol=0, atol=1e-9)
    assert np.all(np.isfinite(result.x_m))
    assert result.peak_force == pytest.approx(np.max(np.abs(result.actuator_force)))
    assert not result.capacity_reached
    # PI-P tracks: the error is a fraction of the motion
    assert np.std(result.x_m - result.x_d) < 0.3 * np.std(result.x_d)
    low = run_benchmark_loop(case, t, ag, make_compensator('pi_p', DT), BenchmarkPlant(DT),
                             BENCHMARK_SPECIMEN, None, 0.0, 0.5 * result.peak_force)
    assert low.capacity_reached


def test_inconsistent_rates_are_refused() -> None:
    t, ag = _record(4096.0, seconds=0.5)
    with pytest.raises(ConfigError, match='plant runs at'):
        run_benchmark_loop(benchmark_case(1), t, ag, make_compensator('none', DT),
                           IdealPlant(2 * DT), BENCHMARK_SPECIMEN)
    with pytest.raises(ConfigError, match='quantum'):
        run_benchmark_loop(benchmark_case(1), t, ag, make_compensator('none', DT),
                           IdealPlant(DT), BENCHMARK_SPECIMEN, None, -1.0)
