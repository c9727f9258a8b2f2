"""The continuous actuator: predictor–corrector sub-stepping, slow-down and hold, sensors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pd_common.errors import RthsError
from pd_common.rths import (
    BENCHMARK_SPECIMEN,
    ContinuousActuator,
    continuous_from_config,
)

WHERE = 'test.yaml: sites.lab1.transfer_system'


def _actuator(dt: float = 1.0 / 1024.0, **section: object) -> ContinuousActuator:
    config = continuous_from_config({'plant': {'model': 'ideal'}, **section}, WHERE)
    return ContinuousActuator(config, dt)


@pytest.mark.parametrize(('interpolation', 'power'), [('linear', 1), ('cubic', 3)])
def test_the_corrector_is_exact_for_targets_on_a_polynomial_of_its_order(
        interpolation: str, power: int) -> None:
    """Targets d[n] = p(t_n), p of the corrector's order: every sample's x_d is p(t)."""
    actuator = _actuator(interpolation=interpolation)
    h = actuator.integration_dt

    def p(t: float) -> float:
        return 1e-3 * (t / 0.01) ** power - 2e-4 * t

    # the polynomial history before the first steps is 0 (rest): start after it has filled
    for n in range(1, 12):
        measurement = actuator.step(p(n * h))
        if n > 4:
            expected = [p(t) for t in measurement.times]
            np.testing.assert_allclose(measurement.desired, expected, rtol=1e-12, atol=1e-18)
        assert measurement.desired[-1] == p(n * h)        # the target itself at the step's end
        assert measurement.times[-1] == pytest.approx(n * h, rel=1e-15)
        assert measurement.samples == 4


def test_a_late_target_brakes_the_actuator_to_a_hold_and_it_recovers() -> None:
    actuator = _actuator(realtime={'hold_at': 0.75, 'slowdown_samples': 2.0})
    for n in range(1, 5):
        actuator.step(1e-4 * n)   # a ramp: the predictor extrapolates it
    counters = actuator.counters
    assert counters.predicted_samples == 0 and counters.slowed_samples == 0
    phases = []
    for _ in range(10):                       # no target: predictor, slowing, holding
        assert actuator.tick() is None
        phases.append(actuator.phase)
    assert phases[-1] == pytest.approx(0.75 * 4)
    assert all(b >= a for a, b in zip(phases, phases[1:], strict=False))
    assert counters.predicted_samples == 10 and counters.held_samples > 0
    assert counters.slowdowns == 1
    # the predictor is linear extrapolation of the ramp: the desired displacement held is
    # d[4] + 0.75 · (d[4] − d[3])
    assert actuator.measured_displacement == pytest.approx(4e-4 + 0.75e-4, rel=1e-12)
    actuator.set_next_target(5e-4)
    result = None
    for _ in range(20):
        result = actuator.tick()
        if result is not None:
            break
    assert result is not None and result.step == 5
    assert result.desired[-1] == pytest.approx(5e-4, rel=1e-12)   # the step ends on its target
    assert result.slowed_samples > 0 and result.predicted_samples == 10
    assert 0.0 < counters.slowdown_fraction < 1.0
    with pytest.raises(RthsError, match='already set'):
        actuator.set_next_target(6e-4)
        actuator.set_next_target(6e-4)


def test_noise_and_quantum_of_the_sensors() -> None:
    section = {'noise': {'displacement_power': 6.25e-14, 'force_power': 1.16e-3, 'seed': 3},
               'quantum': 2.0 ** -18}
    first = _actuator(**section)
    again = _actuator(**section)
    a = [first.step(1e-3 * math.sin(0.05 * n)) for n in range(1, 400)]
    b = [again.step(1e-3 * math.sin(0.05 * n)) for n in range(1, 400)]
    measured = np.concatenate([m.measured for m in a])
    np.testing.assert_array_equal(measured, np.concatenate([m.measured for m in b]))
    steps = measured / 2.0 ** -18
    np.testing.assert_allclose(steps, np.round(steps), rtol=0, atol=1e-9)
    desired = np.concatenate([m.desired for m in a])
    # an ideal plant: y[k+1] = u[k] = x_d[k+1]; the rest is noise of σ = √(6.25e-14 · 4096)
    assert np.std(measured - desired) == pytest.approx(1.6e-5, rel=0.1)


def test_inertia_subtract_removes_the_mass_force_of_the_measured_motion() -> None:
    measured = _actuator(inertia='measured')
    subtract = _actuator(inertia='subtract')
    for n in range(1, 50):
        target = 1e-3 * math.sin(0.2 * n)
        m = measured.step(target)
        s = subtract.step(target)
        y = m.measured[-3:] if m.samples >= 3 else None
        assert y is not None
        h = measured.controller_dt
        inertia = BENCHMARK_SPECIMEN.mass * (y[2] - 2 * y[1] + y[0]) / h ** 2
        assert s.force == pytest.approx(m.force - inertia, rel=1e-9, abs=1e-9)


@pytest.mark.parametrize(('section', 'match'), [
    ({'controller_rate': -1.0}, r'transfer_system\.controller_rate'),
    ({'interpolation': 'quintic'}, r'transfer_system\.interpolation'),
    ({'inertia': 'ignore'}, r'transfer_system\.inertia'),
    ({'compensator': {'name': 'none', 'gain': 2.0}}, r'transfer_system\.compensator'),
    ({'noise': {'seed': -1}}, r'transfer_system\.noise\.seed'),
    ({'realtime': {'hold_at': 1.5}}, r'realtime\.hold_at'),
    ({'realtime': {'cpu_latency': -1e-6}}, r'realtime\.cpu_latency'),
    ({'realtime': {'cpu_latency': 'none'}}, r'realtime\.cpu_latency'),
    ({'realtime': {'cpu_latency': 1e4}}, r'realtime\.cpu_latency'),
    ({'colour': 'red'}, r'transfer_system\.colour: unknown key'),
])
def test_bad_sections_are_one_line_naming_the_key(section: dict, match: str) -> None:
    with pytest.raises(RthsError, match=match) as error:
        continuous_from_config({'plant': {'model': 'ideal'}, **section}, WHERE)
    assert '\n' not in str(error.value) and str(error.value).startswith('test.yaml')


def test_the_wall_clock_asks_for_awake_cpus_unless_the_file_says_otherwise() -> None:
    plant = {'plant': {'model': 'ideal'}}
    assert continuous_from_config(plant, WHERE).cpu_latency == 0.0
    assert continuous_from_config({**plant, 'realtime': {'cpu_latency': None}},
                                  WHERE).cpu_latency is None
    assert continuous_from_config({**plant, 'realtime': {'cpu_latency': 5e-5}},
                                  WHERE).cpu_latency == 5e-5


def test_the_integration_step_must_be_whole_controller_samples() -> None:
    config = continuous_from_config({'plant': {'model': 'ideal'}}, WHERE)
    with pytest.raises(RthsError, match='whole multiple'):
        ContinuousActuator(config, 1.0 / 1000.0)
