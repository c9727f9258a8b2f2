"""The vRTHS benchmark's J criteria on synthetic signals with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from pd_core.errors import ConfigError
from pd_rths_benchmark.core.criteria import (
    J_KEYS,
    j_criteria,
    noise_floor_percent,
    tracking_delay,
)

DT = 1.0 / 4096.0


def _broadband(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    b, a = signal.butter(4, 20.0 * 2 * DT)
    return np.asarray(signal.lfilter(b, a, rng.standard_normal(n)))


@pytest.mark.parametrize('lag', [0, 1, 7, 30, 49])
def test_j1_is_a_known_shift(lag: int) -> None:
    x_d = _broadband(20000)
    x_m = np.concatenate([np.zeros(lag), x_d[:x_d.size - lag]])
    assert tracking_delay(x_d, x_m, DT) == pytest.approx(lag * DT, abs=1e-15)
    j = j_criteria(x_d, x_m, np.column_stack([x_d] * 3), np.column_stack([x_d] * 3), DT)
    assert j['J1'] == pytest.approx(1000.0 * lag * DT, abs=1e-12)


def test_j1_searches_lags_below_50_samples_only() -> None:
    x_d = _broadband(20000, seed=1)
    x_m = np.concatenate([np.zeros(80), x_d[:-80]])
    assert tracking_delay(x_d, x_m, DT) <= 49 * DT


def test_tracking_amplitude_and_offset_give_known_j2_j3() -> None:
    t = np.arange(4096 * 2) * DT
    x_d = np.sin(2 * math.pi * 2.0 * t)          # whole periods
    floors = np.column_stack([x_d, 2 * x_d, 3 * x_d])
    j = j_criteria(x_d, 1.1 * x_d, floors, floors, DT)
    assert j['J2'] == pytest.approx(10.0, rel=1e-12)
    assert j['J3'] == pytest.approx(10.0, rel=1e-12)
    # a constant offset does not count in J2 (std), fully in J3 (peak)
    j = j_criteria(x_d, x_d + 0.05, floors, floors, DT)
    assert j['J2'] == pytest.approx(0.0, abs=1e-12)
    assert j['J3'] == pytest.approx(5.0, rel=1e-9)


def test_floor_errors_give_known_j4_to_j9() -> None:
    t = np.arange(4096 * 2) * DT
    base = np.sin(2 * math.pi * 2.0 * t)
    reference = np.column_stack([base, 2 * base, 3 * base])
    floors = np.column_stack([1.03 * base, 2 * 1.02 * base, 3 * 0.95 * base])
    x_m = 0.98 * base                        # J4, J5 use the measured floor 1
    j = j_criteria(floors[:, 0], x_m, floors, reference, DT)
    expected = {'J4': 2.0, 'J5': 2.0, 'J6': 2.0, 'J7': 5.0, 'J8': 2.0, 'J9': 5.0}
    for key, value in expected.items():
        assert j[key] == pytest.approx(value, rel=1e-9), key
    assert tuple(j) == J_KEYS


def test_nrms_is_std_ratio_peak_is_max_ratio() -> None:
    rng = np.random.default_rng(3)
    x_d = rng.standard_normal(5000)
    error = 0.01 * rng.standard_normal(5000)
    j = j_criteria(x_d, x_d + error, np.column_stack([x_d] * 3), np.column_stack([x_d] * 3),
                   DT)
    assert j['J2'] == pytest.approx(100 * np.std(error, ddof=1) / np.std(x_d, ddof=1))
    assert j['J3'] == pytest.approx(100 * np.max(np.abs(error)) / np.max(np.abs(x_d)))


def test_noise_floor() -> None:
    t = np.arange(8192) * DT
    x_d = 2e-3 * np.sin(2 * math.pi * 4.0 * t)        # std = 2e-3/√2
    assert noise_floor_percent(1.6e-5, x_d) == pytest.approx(
        100 * 1.6e-5 / (2e-3 / math.sqrt(2)), rel=1e-3)
    with pytest.raises(ConfigError, match='displacement_noise_std'):
        noise_floor_percent(-1.0, x_d)


def test_bad_shapes() -> None:
    x = np.zeros(10)
    with pytest.raises(ConfigError, match='x_m'):
        j_criteria(x, np.zeros(9), np.zeros((10, 3)), np.zeros((10, 3)), DT)
    with pytest.raises(ConfigError, match='floors'):
        j_criteria(x, x, np.zeros((10, 2)), np.zeros((10, 3)), DT)
    with pytest.raises(ConfigError, match='dt'):
        tracking_delay(x, x, 0.0)
