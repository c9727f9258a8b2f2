"""The vRTHS benchmark problem: cases, partition, ground motion, reference response."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import linalg

from pd_common.rths import BENCHMARK_SPECIMEN
from pd_core.errors import ConfigError
from pd_rths_benchmark.core.problem import (
    BenchmarkCase,
    benchmark_case,
    numerical_substructure,
    prepare_ground_motion,
    reference_response,
)

CASE_1_FREQUENCIES = np.array([3.6124, 15.9966, 38.0862])


@pytest.mark.parametrize(('number', 'mass', 'ratio'),
                         [(1, 1000.0, 0.05), (2, 1100.0, 0.04), (3, 1300.0, 0.03),
                          (4, 1000.0, 0.03)])
def test_cases_frequencies_and_classical_damping(number: int, mass: float, ratio: float) -> None:
    case = benchmark_case(number)
    np.testing.assert_array_equal(case.mass, np.eye(3) * mass)
    # K is the same in every case: frequencies scale with 1/√m
    np.testing.assert_allclose(case.natural_frequencies(),
                               CASE_1_FREQUENCIES * math.sqrt(1000.0 / mass), rtol=2e-5)
    # Φᵀ C Φ = diag(2 ζ ω) for the mass-normalised modes: the ratio in every mode
    eigenvalues, modes = linalg.eigh(case.stiffness, case.mass)
    modal = modes.T @ case.damping @ modes
    omega = np.sqrt(eigenvalues)
    np.testing.assert_allclose(np.diag(modal) / (2 * omega), ratio, rtol=1e-10)
    off_diagonal = modal - np.diag(np.diag(modal))
    assert np.max(np.abs(off_diagonal)) < 1e-9 * np.max(np.abs(modal))
    np.testing.assert_allclose(case.damping, case.damping.T, rtol=0, atol=0)
    assert case.damping_ratio == ratio


def test_bad_case() -> None:
    for bad in (0, 5, True):
        with pytest.raises(ConfigError, match='benchmark case'):
            benchmark_case(bad)


def test_numerical_substructure_is_the_case_without_the_specimen() -> None:
    case = benchmark_case(1)
    m_n, c_n, k_n = numerical_substructure(case, BENCHMARK_SPECIMEN)
    e = np.zeros((3, 3))
    e[0, 0] = 1.0
    np.testing.assert_allclose(m_n + BENCHMARK_SPECIMEN.mass * e, case.mass, rtol=1e-15)
    np.testing.assert_allclose(k_n + BENCHMARK_SPECIMEN.stiffness * e, case.stiffness,
                               rtol=1e-15)
    np.testing.assert_allclose(c_n + BENCHMARK_SPECIMEN.damping * e, case.damping, rtol=1e-13)
    assert BENCHMARK_SPECIMEN.damping == pytest.approx(
        2 * 0.0097 * math.sqrt(1.19e6 * 29.13))


def test_prepare_ground_motion_pads_scales_and_interpolates() -> None:
    record = np.array([0.0, 1.0, -2.0, 0.5])
    t, ag = prepare_ground_motion(record, 0.02, intensity=0.4, rate=1000.0, padding=0.5)
    assert t[1] - t[0] == pytest.approx(1e-3)
    assert t[-1] == pytest.approx(2 * 0.5 + 3 * 0.02)
    assert t.size == 1061
    assert np.all(ag[t < 0.5 - 1e-12] == 0.0)
    assert np.all(ag[t >= 0.58 - 1e-12] == 0.0)
    # the zeros are samples: one record step from the last sample (0.4 * 0.5) down to zero
    k = round(0.57 * 1000)
    assert ag[k] == pytest.approx(0.4 * 0.5 / 2, abs=1e-12)
    padded = np.concatenate([np.zeros(25), record, np.zeros(25)])
    np.testing.assert_allclose(ag, 0.4 * np.interp(t, np.arange(padded.size) * 0.02, padded),
                               rtol=0, atol=1e-15)
    # at the record's samples: the record × intensity; between them: linear
    for i, value in enumerate(record):
        k = round((0.5 + 0.02 * i) * 1000)
        assert ag[k] == pytest.approx(0.4 * value, abs=1e-12)
    k = round(0.53 * 1000)  # halfway between samples 1 and 2
    assert ag[k] == pytest.approx(0.4 * (1.0 - 2.0) / 2, abs=1e-12)
    with pytest.raises(ConfigError, match='dt_record'):
        prepare_ground_motion(record, 0.0)
    with pytest.raises(ConfigError, match='intensity'):
        prepare_ground_motion(record, 0.02, intensity=-1.0)
    with pytest.raises(ConfigError, match='acceleration'):
        prepare_ground_motion(np.array([1.0]), 0.02)


def _modes(case: BenchmarkCase) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    eigenvalues, modes = linalg.eigh(case.stiffness, case.mass)
    participation = modes.T @ case.mass @ np.ones(3)
    return np.sqrt(eigenvalues), modes, participation


def test_reference_step_response_equals_the_modal_closed_form() -> None:
    # A constant ground acceleration a0 from t = 0 is linear between samples: exact.
    case = benchmark_case(1)
    a0 = 2.0
    t = np.arange(6000) / 4096.0
    x = reference_response(case, t, np.full(t.size, a0))
    omega, modes, gamma = _modes(case)
    zeta = case.damping_ratio
    q = np.empty((t.size, 3))
    for i in range(3):
        wd = omega[i] * math.sqrt(1 - zeta ** 2)
        decay = np.exp(-zeta * omega[i] * t)
        q[:, i] = -gamma[i] * a0 / omega[i] ** 2 * (
            1 - decay * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta ** 2) * np.sin(wd * t)))
    exact = q @ modes.T
    np.testing.assert_allclose(x, exact, rtol=0, atol=1e-10 * np.max(np.abs(exact)))


def _harmonic_closed_form(case: BenchmarkCase, t: np.ndarray, amplitude: float,
                          frequency: float) -> np.ndarray:
    """Floors under ẍ_g = A sin Ωt from rest: per mode, steady state plus the free vibration
    that cancels its initial displacement and velocity."""
    omega, modes, gamma = _modes(case)
    zeta = case.damping_ratio
    w = 2 * math.pi * frequency
    q = np.empty((t.size, 3))
    for i in range(3):
        wn = omega[i]
        wd = wn * math.sqrt(1 - zeta ** 2)
        force = -gamma[i] * amplitude          # q̈ + 2ζω q̇ + ω² q = force sin Ωt
        denominator = (wn ** 2 - w ** 2) ** 2 + (2 * zeta * wn * w) ** 2
        a = force * (wn ** 2 - w ** 2) / denominator     # sin coefficient
        b = -force * 2 * zeta * wn * w / denominator     # cos coefficient
        q0, v0 = -b, -a * w                              # cancel q_p(0), q̇_p(0)
        decay = np.exp(-zeta * wn * t)
        homogeneous = decay * (q0 * np.cos(wd * t)
                               + (v0 + zeta * wn * q0) / wd * np.sin(wd * t))
        q[:, i] = a * np.sin(w * t) + b * np.cos(w * t) + homogeneous
    return np.asarray(q @ modes.T)


def test_reference_harmonic_response_converges_at_second_order_to_the_closed_form() -> None:
    case = benchmark_case(4)
    errors = []
    for rate in (512.0, 1024.0, 2048.0):
        t = np.arange(int(3.0 * rate) + 1) / rate
        ag = 3.0 * np.sin(2 * math.pi * 4.0 * t)
        x = reference_response(case, t, ag)
        exact = _harmonic_closed_form(case, t, 3.0, 4.0)
        errors.append(np.max(np.abs(x - exact)) / np.max(np.abs(exact)))
    assert errors[-1] < 3e-5
    for coarse, fine in zip(errors, errors[1:], strict=False):
        assert 3.5 < coarse / fine < 4.5


def test_reference_refuses_bad_times() -> None:
    case = benchmark_case(1)
    with pytest.raises(ConfigError, match='uniformly'):
        reference_response(case, np.array([0.0, 1.0, 3.0]), np.zeros(3))
    with pytest.raises(ConfigError, match='same length'):
        reference_response(case, np.arange(3.0), np.zeros(4))
