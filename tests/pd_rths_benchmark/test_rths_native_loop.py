"""The vRTHS benchmark through the session and step protocol (``--loop native``).

Checked against independent computations: a plain numpy explicit Newmark of the full structure
(with an ideal actuator and a pure spring specimen the hybrid run is that, to round-off), the
exact reference (convergence at the scheme's order as Δt_int falls), and the semantics of a
continuous site (rest, repeats, iterations, capacity).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pd_common.protocol import FeedbackStatus
from pd_common.rths import (
    BENCHMARK_SPECIMEN,
    ContinuousActuator,
    ContinuousSiteServer,
    PhysicalSpecimen,
    continuous_from_config,
)
from pd_common.rths.plant import BenchmarkPlant, perturbed_plants
from pd_core.dynamics.record_readers import read_ground_motion
from pd_core.errors import ConfigError
from pd_core.run.test_file import from_dict
from pd_rths_benchmark.core.native_loop import native_test_file, run_native_loop
from pd_rths_benchmark.core.problem import (
    benchmark_case,
    prepare_ground_motion,
    reference_response,
)

RECORD = (Path(__file__).resolve().parents[2] / 'src' / 'pd_integrator' / 'data'
          / 'ground_motions' / 'elcentro_1940_ns_chopra.csv')
RATE = 4096.0


def _record(seconds: float = 3.0) -> tuple[np.ndarray, float]:
    motion = read_ground_motion(RECORD, units='g')
    return np.asarray(motion.acceleration[:round(seconds / motion.dt)]), float(motion.dt)


def _file(dt: float, *, specimen: PhysicalSpecimen = BENCHMARK_SPECIMEN, seconds: float = 3.0,
          padding: int = 50, **transfer: object) -> dict:
    acc, record_dt = _record(seconds)
    section: dict = {'plant': {'model': 'ideal'}, **transfer}
    if specimen is not BENCHMARK_SPECIMEN:
        section['specimen'] = {'mass': specimen.mass, 'stiffness': specimen.stiffness,
                               'damping_ratio': specimen.damping_ratio}
    return native_test_file(benchmark_case(1), acc, record_dt, padding_samples=padding,
                            intensity=0.4, integration_dt=dt, transfer_system=section,
                            specimen=specimen)


def _newmark_explicit(mass: np.ndarray, damping: np.ndarray, stiffness: np.ndarray,
                      ag: np.ndarray, h: float) -> np.ndarray:
    """Explicit Newmark (β = 0, γ = ½), written out independently of the schemes."""
    n = mass.shape[0]
    x, v, a = np.zeros(n), np.zeros(n), np.zeros(n)
    lhs = mass + 0.5 * h * damping
    out = [x.copy()]
    for k in range(1, ag.size):
        x = x + h * v + 0.5 * h * h * a
        v_star = v + 0.5 * h * a
        a = np.linalg.solve(lhs, -mass @ np.ones(n) * ag[k] - stiffness @ x - damping @ v_star)
        v = v_star + 0.5 * h * a
        out.append(x.copy())
    return np.array(out)


def test_ideal_spring_specimen_is_the_numerical_newmark_to_round_off() -> None:
    """An ideal actuator and a spring specimen: the hybrid run is explicit Newmark on M, C, K."""
    spring = PhysicalSpecimen(mass=0.0, stiffness=1.19e6, damping_ratio=0.0)
    h = 1.0 / 1024.0
    result = run_native_loop(_file(h, specimen=spring))
    assert result.completed, result.state
    case = benchmark_case(1)
    acc, record_dt = _record()
    _t, ag = prepare_ground_motion(acc, record_dt, 0.4, RATE, 50 * record_dt)
    expected = _newmark_explicit(case.mass, case.damping, case.stiffness, ag[::4],
                                 h)[:result.floors.shape[0]]
    np.testing.assert_allclose(result.floors, expected, rtol=0,
                               atol=1e-9 * np.max(np.abs(expected)))
    # an ideal actuator: x_m = x_d at every sample
    np.testing.assert_array_equal(result.x_m, result.x_d)
    # and it reached every target at the step's end
    np.testing.assert_array_equal(result.x_m[3::4], result.floors[1:, 0])
    # floor 1's restoring force: the numerical K_N x plus the measured k_e x_1
    total = (case.stiffness @ result.floors.T)[0]
    np.testing.assert_allclose(result.restoring_force, total, rtol=0,
                               atol=1e-9 * np.max(np.abs(total)))


@pytest.mark.parametrize('interpolation', ['linear', 'cubic'])
def test_ideal_plant_converges_at_the_order_of_the_scheme(interpolation: str) -> None:
    """J4 and the floors' NRMS error against the exact reference fall as Δt_int² (±)."""
    case = benchmark_case(1)
    acc, record_dt = _record()
    t, ag = prepare_ground_motion(acc, record_dt, 0.4, RATE, 50 * record_dt)
    reference = reference_response(case, t, ag)
    errors = []
    for divisor in (256, 512, 1024):
        result = run_native_loop(_file(1.0 / divisor, interpolation=interpolation))
        steps = round(RATE / divisor)
        ref = reference[::steps][:result.floors.shape[0]]
        errors.append([float(np.std(result.floors[:, j] - ref[:, j]) / np.std(ref[:, j]))
                       for j in range(3)])
    errors_array = np.array(errors)
    ratios = errors_array[:-1] / errors_array[1:]
    orders = np.log2(ratios)
    assert np.all(orders > 1.7), orders
    assert np.all(errors_array[-1] < 1e-3)  # J6, J7 < 0.1 % at 1/1024 s


def test_continuous_site_answers_like_a_specimen_and_refuses_what_it_cannot_do() -> None:
    config = continuous_from_config({'plant': {'model': 'ideal'}, 'capacity': 2.0e4},
                                    'test.yaml: sites.lab1.transfer_system')
    server = ContinuousSiteServer(config, 1.0 / 1024.0)
    rest = server.handle('t', 0, [0.0])
    assert rest is not None and rest.status is FeedbackStatus.OK
    assert rest.measured_displacement == (0.0,) and server.actuator.completed_steps == 0
    first = server.handle('t', 1, [1e-4])
    assert first is not None and first.status is FeedbackStatus.OK
    assert first.measured_displacement == (pytest.approx(1e-4, rel=0, abs=1e-18),)
    k_e = BENCHMARK_SPECIMEN.stiffness
    assert first.restoring_force[0] == pytest.approx(
        k_e * 1e-4 + BENCHMARK_SPECIMEN.damping * 1e-4 / 4 * 4096, rel=1e-12)
    assert server.handle('t', 1, [5.0]) is first          # a repeat: no motion
    assert server.repeated == 1 and server.actuator.completed_steps == 1
    assert server.handle('t', 0, [0.0]) is None            # an older one: ignored
    iteration = server.handle('t', 2, [1e-4], iteration=1)
    assert iteration is not None and iteration.status is FeedbackStatus.FAULT
    assert 'one command per integration step' in iteration.message
    force = server.handle('t', 3, [1e-4], control_mode=[1])
    assert force is not None and force.status is FeedbackStatus.FAULT
    assert server.actuator.completed_steps == 1            # neither moved
    # the start of a step from rest: m_e ẍ of the first sample is 12.2 kN (below 20 kN) …
    assert server.peak_force == pytest.approx(
        29.13 * 0.25e-4 * 4096 ** 2 + BENCHMARK_SPECIMEN.damping * 0.25e-4 * 4096
        + k_e * 0.25e-4, rel=1e-9)
    breach = server.handle('t', 4, [1e-3])                 # … ten times more is above it
    assert breach is not None and breach.status is FeedbackStatus.FAULT
    assert 'capacity' in breach.message and not server.valid


def test_a_run_that_reaches_the_capacity_holds_with_the_reason() -> None:
    result = run_native_loop(_file(1.0 / 1024.0, capacity=50.0))
    assert not result.completed and result.capacity_reached
    assert 'holding' in result.state and 'capacity' in result.state
    assert result.floors.shape[0] < 3000  # it stopped at the first breach


def test_bad_transfer_system_sections_name_the_key() -> None:
    raw = _file(1.0 / 1024.0)
    raw['sites']['lab1']['transfer_system']['compensator'] = {'name': 'nope'}
    with pytest.raises(ConfigError, match=r'sites\.lab1\.transfer_system\.compensator'):
        run_native_loop(raw)
    raw = _file(1.0 / 1000.0)
    with pytest.raises(ConfigError, match='whole multiple of the controller period'):
        run_native_loop(raw)
    raw = _file(1.0 / 1024.0)
    raw['sites']['lab1']['transfer_system']['plant'] = {'model': 'servo'}
    with pytest.raises(ConfigError, match=r'transfer_system\.plant\.model'):
        run_native_loop(raw)


def test_linear_element_and_a_damping_matrix_with_elements() -> None:
    raw = _file(1.0 / 1024.0)
    definition = from_dict(raw)
    assert definition.model is not None
    case = benchmark_case(1)
    k_total = definition.model.initial_stiffness()
    np.testing.assert_allclose(k_total, case.stiffness, rtol=1e-14)
    assert definition.damping is not None
    c_e = 2 * 0.0097 * math.sqrt(1.19e6 * 29.13)
    np.testing.assert_allclose(definition.damping[0, 0] + c_e, case.damping[0, 0], rtol=1e-14)
    asymmetric = _file(1.0 / 1024.0)
    matrix = asymmetric['structure']['elements'][0]['stiffness']
    matrix[0][1] += 1.0
    with pytest.raises(ConfigError, match=r'elements\.0\.stiffness: must be symmetric'):
        from_dict(asymmetric)
    twice = _file(1.0 / 1024.0)
    twice['structure']['elements'][0]['dofs'] = ['x1', 'x1', 'x3']
    with pytest.raises(ConfigError, match='must name each DOF once'):
        from_dict(twice)


def test_a_perturbed_plant_reads_the_force_of_its_own_specimen() -> None:
    """The numerical substructure removes the drawn k_e; the load cell must read that same
    specimen, so that with an ideal-like plant the hybrid total is the reference structure."""
    config = continuous_from_config({'plant': {'model': 'benchmark', 'perturbed': True,
                                               'seed': 0, 'index': 3}}, 'transfer_system')
    actuator = ContinuousActuator(config, 1.0 / 1024.0)
    drawn = perturbed_plants(0, 4)[3]
    assert isinstance(actuator.plant, BenchmarkPlant)
    assert actuator.plant.params == drawn
    assert actuator.specimen == drawn.specimen
    assert actuator.specimen.stiffness != BENCHMARK_SPECIMEN.stiffness
