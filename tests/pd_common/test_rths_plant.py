"""The vRTHS benchmark's transfer system: model, exact discretisation, perturbed plants."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from pd_common.errors import RthsError
from pd_common.rths.base import IdealPlant
from pd_common.rths.plant import (
    PERTURBATION_STD,
    BenchmarkPlant,
    BenchmarkPlantParameters,
    benchmark_state_space,
    benchmark_transfer_function,
    equivalent_delay,
    frequency_response,
    plant_from_config,
)

DT = 1.0 / 4096.0
NOMINAL = BenchmarkPlantParameters.nominal()


def _block_diagram_response(params: BenchmarkPlantParameters, f_hz: np.ndarray) -> np.ndarray:
    """G(jω) composed block by block from the issue's formulas (complex arithmetic)."""
    s = 2j * np.pi * f_hz
    sp = params.specimen
    g_s = params.a1_beta0 / (s * s + params.beta1 * s + params.beta2)
    g_a = 1.0 / (s + params.a3)
    g_e = 1.0 / (sp.mass * s * s + sp.damping * s + sp.stiffness)
    g_0 = g_a * g_e / (1.0 + params.a2 * s * g_a * g_e)
    return params.gain * g_s * g_0 / (1.0 + g_s * g_0)


@pytest.mark.parametrize('params', [NOMINAL,
                                    BenchmarkPlantParameters.perturbed(np.random.default_rng(3))])
def test_transfer_function_and_state_space_match_the_block_diagram(
        params: BenchmarkPlantParameters) -> None:
    f = np.logspace(-2, 3, 60)
    reference = _block_diagram_response(params, f)
    np.testing.assert_allclose(frequency_response(params, f), reference, rtol=1e-10)
    a, b, c, _d = benchmark_state_space(params)
    s = 2j * np.pi * f
    h_both = np.array([c @ np.linalg.solve(sk * np.eye(5) - a, b) for sk in s])[:, :, 0]
    h, h_force = h_both[:, 0], h_both[:, 1]
    np.testing.assert_allclose(h, reference, rtol=1e-10)
    # The second output is the actuator force: f = (m s² + c s + k) x.
    sp = params.specimen
    np.testing.assert_allclose(
        h_force, (sp.mass * s * s + sp.damping * s + sp.stiffness) * reference, rtol=1e-9)


def test_equivalent_delay_is_about_25_ms_at_1_hz() -> None:
    delay = equivalent_delay(NOMINAL, 1.0)
    assert 0.024 < delay < 0.026
    # Phase delay by a finite difference of the phase is close to it at low frequency.
    h = frequency_response(NOMINAL, [1e-3])[0]
    assert -math.atan2(h.imag, h.real) / (2 * math.pi * 1e-3) == pytest.approx(delay, rel=0.02)
    with pytest.raises(RthsError, match='frequency_hz'):
        equivalent_delay(NOMINAL, 0.0)


def _zoh_alias_sum(params: BenchmarkPlantParameters, f_hz: np.ndarray, dt: float,
                   terms: int = 400) -> np.ndarray:
    """The frequency response of the ZOH-discretised plant by the alias sum
    G_d(e^{jωT}) = Σ_k G(jω_k) (1 − e^{−jωT}) / (jω_k T), ω_k = ω + 2πk/T."""
    omega = 2 * np.pi * f_hz
    total = np.zeros_like(omega, dtype=complex)
    for k in range(-terms, terms + 1):
        omega_k = omega + 2 * np.pi * k / dt
        g = _block_diagram_response(params, omega_k / (2 * np.pi))
        total += g * (1.0 - np.exp(-1j * omega * dt)) / (1j * omega_k * dt)
    return total


def test_discrete_frequency_response_equals_the_zoh_equivalent_below_nyquist_over_10() -> None:
    plant = BenchmarkPlant(DT, NOMINAL)
    f = np.linspace(0.05, 0.1 * 0.5 / DT, 40)
    z = np.exp(2j * np.pi * f * DT)
    h = np.array([np.linalg.solve(zk * np.eye(5) - plant.a_discrete, plant.b_discrete)[3, 0]
                  for zk in z])
    exact = _zoh_alias_sum(NOMINAL, f, DT)
    np.testing.assert_allclose(h, exact, rtol=1e-10)
    # and to the continuous G(jω) up to the hold's half-sample delay, O((ωT)²).
    continuous = frequency_response(NOMINAL, f) * np.exp(-1j * np.pi * f * DT)
    error = np.abs(h - continuous) / np.abs(continuous)
    assert np.all(error <= 0.05 * (2 * np.pi * f * DT) ** 2 + 1e-11)


def test_step_equals_the_continuous_solution_at_the_samples() -> None:
    plant = BenchmarkPlant(DT, NOMINAL)
    n = 2000
    x = np.empty(n)
    force = np.empty(n)
    for k in range(n):
        x[k] = plant.output()
        force[k] = plant.actuator_force()
        plant.advance(0.01)
    t = np.arange(n) * DT
    # Closed form: partial fractions of G(s)/s (distinct poles), times the step 0.01 m.
    num, den = benchmark_transfer_function(NOMINAL)
    residues, poles, _direct = signal.residue(num, np.polymul(den, [1.0, 0.0]))
    exact = 0.01 * np.real(np.exp(np.outer(t, poles)) @ residues)
    np.testing.assert_allclose(x, exact, rtol=0, atol=1e-11 * 0.01)
    # and scipy's lsim of the continuous model (its own discretisation, looser).
    a, b, c, d = benchmark_state_space(NOMINAL)
    _t, y, _x = signal.lsim((a, b, c, d), np.full(n, 0.01), t)
    np.testing.assert_allclose(x, y[:, 0], rtol=0, atol=1e-7 * 0.01)
    np.testing.assert_allclose(force, y[:, 1], rtol=0, atol=1e-6 * 0.01 * 1.19e6)
    # the final value of a step is the DC gain
    assert x[-1] == pytest.approx(0.01 * num[-1] / den[-1], rel=2e-3)
    plant.reset()
    assert plant.output() == 0.0
    assert plant.actuator_force() == 0.0


def test_perturbed_draws_follow_the_stated_distributions() -> None:
    rng = np.random.default_rng(2026)
    draws = [BenchmarkPlantParameters.perturbed(rng) for _ in range(4000)]
    values = {
        'k_e': np.array([p.specimen.stiffness for p in draws]),
        'beta1': np.array([p.beta1 for p in draws]),
        'beta2': np.array([p.beta2 for p in draws]),
        'a3': np.array([p.a3 for p in draws]),
    }
    means = {'k_e': 1.19e6, 'beta1': 425.0, 'beta2': 9.9976e4, 'a3': 3.3}
    for name, sample in values.items():
        std = PERTURBATION_STD[name]
        assert abs(sample.mean() - means[name]) < 5 * std / math.sqrt(sample.size)
        assert sample.std(ddof=1) == pytest.approx(std, rel=0.06)
    # independent draws
    corr = np.corrcoef(np.vstack(list(values.values())))
    assert np.all(np.abs(corr - np.eye(4)) < 0.08)
    # untouched parameters and the damping coefficient that follows k_e
    first = draws[0]
    assert (first.a1_beta0, first.a2, first.gain) == (NOMINAL.a1_beta0, NOMINAL.a2, NOMINAL.gain)
    assert first.specimen.damping == pytest.approx(
        2 * 0.0097 * math.sqrt(first.specimen.stiffness * 29.13))


def test_perturbed_draw_order_is_k_e_beta1_beta2_a3() -> None:
    z = np.random.default_rng(7).standard_normal(4)
    plant = BenchmarkPlantParameters.perturbed(np.random.default_rng(7))
    assert plant.specimen.stiffness == 1.19e6 + 5e4 * z[0]
    assert plant.beta1 == 425.0 + 3.3 * z[1]
    assert plant.beta2 == 9.9976e4 + 3.3e3 * z[2]
    assert plant.a3 == 3.3 + 1.3 * z[3]


def test_plant_from_config() -> None:
    nominal = plant_from_config(None, DT, 'plant')
    assert isinstance(nominal, BenchmarkPlant)
    assert nominal.params == NOMINAL
    assert isinstance(plant_from_config({'model': 'ideal'}, DT, 'plant'), IdealPlant)
    drawn = plant_from_config({'model': 'benchmark', 'perturbed': True, 'seed': 5}, DT, 'p')
    assert isinstance(drawn, BenchmarkPlant)
    assert drawn.params == BenchmarkPlantParameters.perturbed(np.random.default_rng(5))
    assert drawn.dt == DT


@pytest.mark.parametrize(('section', 'match'), [
    ({'modle': 'ideal'}, r"^t\.yaml: plant: unknown key 'modle'"),
    ({'model': 'linear'}, r'^t\.yaml: plant\.model: must be one of'),
    ({'perturbed': 1}, r'^t\.yaml: plant\.perturbed: must be true or false'),
    ({'seed': -1}, r'^t\.yaml: plant\.seed: must be an integer'),
    ({'seed': 1.5}, r'^t\.yaml: plant\.seed: must be an integer'),
    ({'model': 'ideal', 'perturbed': True}, r'^t\.yaml: plant\.perturbed: applies to'),
    (['benchmark'], r'^t\.yaml: plant: must be a mapping'),
])
def test_plant_from_config_refuses_bad_input(section: object, match: str) -> None:
    with pytest.raises(RthsError, match=match) as error:
        plant_from_config(section, DT, 't.yaml: plant')  # type: ignore[arg-type]
    assert '\n' not in str(error.value)


def test_parameters_are_checked() -> None:
    with pytest.raises(RthsError, match='a1_beta0'):
        BenchmarkPlantParameters(a1_beta0=0.0)
    with pytest.raises(RthsError, match='beta1'):
        BenchmarkPlantParameters(beta1=math.nan)
