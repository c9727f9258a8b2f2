"""Tests of pd_common.experimental.setups: the planar setups with exact actuator geometry.

The references are built independently of the module: the attachment points with explicit
trigonometry, the Jacobian by central finite differences, the basic forces from the
equilibrium of the actuator force vectors (resultant and moment about the reference point).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from pd_common.errors import SetupError
from pd_common.experimental import (
    SETUP_TYPES,
    ColumnSetup,
    ExperimentalSetup,
    PlanarActuators,
    PlanarThreeActuators,
    setup_from_config,
)
from pd_core.errors import ConfigError
from pd_core.model import setups as adapter

LH, LV, OFFSET = 1.5, 2.5, 0.6
WHERE = 't.yaml: structure.elements[0].setup'


def column_points(b: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(attachment point, pin) of the column's horizontal and vertical actuators, by hand."""
    top = np.array([b[0], b[1]])
    return [(top, np.array([-LH, 0.0])), (top, np.array([0.0, LV]))]


def beam_points(b: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(attachment point, pin) of planar_3's actuators, with explicit trigonometry."""
    u, v, theta = b
    left = np.array([u - OFFSET * math.cos(theta), v - OFFSET * math.sin(theta)])
    right = np.array([u + OFFSET * math.cos(theta), v + OFFSET * math.sin(theta)])
    return [(left, np.array([-OFFSET, LV])), (right, np.array([OFFSET, LV])),
            (np.array([u, v]), np.array([-LH, 0.0]))]


def hand_strokes(points: list[tuple[np.ndarray, np.ndarray]],
                 rest: list[float]) -> np.ndarray:
    return np.array([math.dist(p, pin) - length for (p, pin), length in zip(points, rest)])


def equilibrium(points: list[tuple[np.ndarray, np.ndarray]], forces: np.ndarray,
                reference: np.ndarray, rotation: bool) -> np.ndarray:
    """Resultant (and moment about the reference point) of the pushes f_i along pin → point."""
    total = np.zeros(2)
    moment = 0.0
    for (p, pin), f in zip(points, forces):
        push = f * (p - pin) / math.dist(p, pin)
        total += push
        arm = p - reference
        moment += arm[0] * push[1] - arm[1] * push[0]
    return np.array([*total, moment]) if rotation else total


def finite_differences(setup: ExperimentalSetup, b: np.ndarray) -> np.ndarray:
    step = 1e-6
    return np.column_stack([(setup.actuator_targets(b + step * e)
                             - setup.actuator_targets(b - step * e)) / (2 * step)
                            for e in np.eye(len(b))])


COLUMN_STATES = [np.array(b) for b in ([0.0, 0.0], [0.03, -0.004], [-0.12, 0.02],
                                       [0.4, -0.3])]
BEAM_STATES = [np.array(b) for b in ([0.0, 0.0, 0.0], [0.02, -0.003, 0.01],
                                     [-0.1, 0.04, -0.08], [0.3, -0.2, 0.35])]


@pytest.mark.parametrize('b', COLUMN_STATES)
def test_column_strokes_jacobian_inverse_and_forces(b: np.ndarray) -> None:
    setup = ColumnSetup(LH, LV)
    assert (setup.n_basic, setup.n_actuators) == (2, 2)
    points = column_points(b)
    strokes = setup.actuator_targets(b)
    np.testing.assert_allclose(strokes, hand_strokes(points, [LH, LV]), rtol=0, atol=1e-15)
    # Explicit formulas: sqrt((L_h + u)² + v²) − L_h and sqrt(u² + (L_v − v)²) − L_v.
    assert strokes[0] == pytest.approx(math.hypot(LH + b[0], b[1]) - LH, abs=1e-15)
    assert strokes[1] == pytest.approx(math.hypot(b[0], LV - b[1]) - LV, abs=1e-15)
    np.testing.assert_allclose(setup.jacobian(b), finite_differences(setup, b),
                               rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(setup.basic_displacement(strokes), b, rtol=0, atol=1e-12)
    forces = np.array([3.0e4, -7.5e5])
    np.testing.assert_allclose(setup.basic_force(forces, b),
                               equilibrium(points, forces, b, rotation=False),
                               rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize('b', BEAM_STATES)
def test_planar_3_strokes_jacobian_inverse_and_forces(b: np.ndarray) -> None:
    setup = PlanarThreeActuators(OFFSET, LV, LH)
    assert (setup.n_basic, setup.n_actuators) == (3, 3)
    points = beam_points(b)
    strokes = setup.actuator_targets(b)
    np.testing.assert_allclose(strokes, hand_strokes(points, [LV, LV, LH]), rtol=0, atol=1e-15)
    np.testing.assert_allclose(setup.jacobian(b), finite_differences(setup, b),
                               rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(setup.basic_displacement(strokes), b, rtol=0, atol=1e-12)
    forces = np.array([-4.0e5, -2.5e5, 6.0e4])
    np.testing.assert_allclose(setup.basic_force(forces, b),
                               equilibrium(points, forces, b[:2], rotation=True),
                               rtol=1e-12, atol=1e-8)


def test_planar_3_signs_at_small_motions() -> None:
    setup = PlanarThreeActuators(OFFSET, LV, LH)
    # A counter-clockwise rotation lowers the left attachment (its actuator extends) and
    # raises the right one; moving down extends both vertical actuators; +u extends the
    # horizontal one.
    rotated = setup.actuator_targets(np.array([0.0, 0.0, 1e-4]))
    assert rotated[0] > 0 > rotated[1]
    assert abs(rotated[2]) < 1e-8
    lowered = setup.actuator_targets(np.array([0.0, -1e-3, 0.0]))
    np.testing.assert_allclose(lowered, [1e-3, 1e-3, math.hypot(LH, 1e-3) - LH], atol=1e-15)
    pushed = setup.actuator_targets(np.array([1e-3, 0.0, 0.0]))
    np.testing.assert_allclose(pushed, [math.hypot(1e-3, LV) - LV] * 2 + [1e-3], atol=1e-15)


@pytest.mark.parametrize(('u', 'v'), [(0.02, 0.0), (-0.05, -0.01), (0.25, 0.03)])
def test_column_lateral_force_includes_the_tilted_axial_load(u: float, v: float) -> None:
    setup = ColumnSetup(LH, LV)
    f_h, load = 1.2e4, 8.0e5          # lateral actuator force, compressive axial load P
    basic = setup.basic_force(np.array([f_h, load]), np.array([u, v]))
    e_hx = (LH + u) / math.hypot(LH + u, v)
    tilted = math.hypot(u, LV - v)     # |p − pin| of the vertical actuator
    assert basic[0] == pytest.approx(f_h * e_hx + load * u / tilted, rel=1e-13)
    assert basic[1] == pytest.approx(f_h * v / math.hypot(LH + u, v)
                                     - load * (LV - v) / tilted, rel=1e-13)
    # The P-Δ correction: about P u / L_v for small drifts, pushing the top further out.
    if abs(u) < 0.1 and v == 0.0:
        assert basic[0] - f_h * e_hx == pytest.approx(load * u / LV, rel=1e-3)


def test_linear_geometry_is_the_jacobian_at_rest() -> None:
    column_rest = np.array([[1.0, 0.0], [0.0, -1.0]])
    beam_rest = np.array([[0.0, -1.0, OFFSET], [0.0, -1.0, -OFFSET], [1.0, 0.0, 0.0]])
    cases = [(ColumnSetup(LH, LV, 'linear'), ColumnSetup(LH, LV), column_rest,
              COLUMN_STATES[2]),
             (PlanarThreeActuators(OFFSET, LV, LH, 'linear'), PlanarThreeActuators(
                 OFFSET, LV, LH), beam_rest, BEAM_STATES[2])]
    for linear, exact, rest, b in cases:
        np.testing.assert_allclose(exact.jacobian(np.zeros(len(b))), rest, atol=1e-15)
        np.testing.assert_allclose(linear.jacobian(b), rest, atol=1e-15)
        np.testing.assert_allclose(linear.actuator_targets(b), rest @ b, atol=1e-15)
        np.testing.assert_allclose(linear.basic_displacement(rest @ b), b, atol=1e-15)
        forces = np.arange(1.0, len(b) + 1.0)
        np.testing.assert_allclose(linear.basic_force(forces, b), rest.T @ forces, atol=1e-15)
        # The exact geometry differs at these (large) displacements.
        assert np.max(np.abs(exact.actuator_targets(b) - rest @ b)) > 1e-4


def test_general_planar_inclined_actuators() -> None:
    # Three inclined actuators on a triangle: nothing parallel to an axis.
    pins = [(-1.0, 1.8), (1.4, 1.2), (-2.0, -0.5)]
    attach = [(-0.3, 0.2), (0.5, 0.1), (0.1, -0.4)]
    setup = PlanarActuators(pins, attach, 3)
    b = np.array([0.07, -0.05, 0.12])
    c, s = math.cos(b[2]), math.sin(b[2])
    points = [(np.array([b[0] + c * x - s * y, b[1] + s * x + c * y]), np.array(pin))
              for (x, y), pin in zip(attach, pins)]
    rest = [math.dist(a, pin) for a, pin in zip(attach, pins)]
    strokes = setup.actuator_targets(b)
    np.testing.assert_allclose(strokes, hand_strokes(points, rest), atol=1e-15)
    np.testing.assert_allclose(setup.jacobian(b), finite_differences(setup, b),
                               rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(setup.basic_displacement(strokes), b, atol=1e-12)
    forces = np.array([2.0e3, -5.0e3, 7.0e3])
    np.testing.assert_allclose(setup.basic_force(forces, b),
                               equilibrium(points, forces, b[:2], rotation=True), rtol=1e-12)


def test_config_builds_the_named_and_general_types() -> None:
    assert {'one_to_one', 'rigid_link_2', 'planar', 'column', 'planar_3'} <= set(SETUP_TYPES)
    column = setup_from_config({'type': 'column', 'horizontal_length': LH,
                                'vertical_length': LV}, 2, WHERE)
    assert isinstance(column, ColumnSetup)
    assert column.geometry == 'nonlinear'
    general = setup_from_config({'type': 'planar', 'basic': ['u', 'v'], 'actuators': [
        {'pin': [-LH, 0], 'attach': [0, 0]}, {'pin': [0, LV], 'attach': [0, 0]}]}, 2, WHERE)
    beam = setup_from_config({'type': 'planar_3', 'offset': OFFSET, 'vertical_length': LV,
                              'horizontal_length': LH, 'geometry': 'linear'}, 3, WHERE)
    assert isinstance(beam, PlanarThreeActuators)
    assert beam.geometry == 'linear'
    b = COLUMN_STATES[3]
    np.testing.assert_allclose(general.actuator_targets(b), hand_strokes(column_points(b),
                                                                         [LH, LV]), atol=1e-15)


def config(kind: str, **changes: object) -> dict[str, object]:
    base: dict[str, dict[str, object]] = {
        'column': {'type': 'column', 'horizontal_length': LH, 'vertical_length': LV},
        'planar_3': {'type': 'planar_3', 'offset': OFFSET, 'vertical_length': LV,
                     'horizontal_length': LH},
        'planar': {'type': 'planar', 'basic': ['u', 'v'],
                   'actuators': [{'pin': [-1, 0], 'attach': [0, 0]},
                                 {'pin': [0, 1], 'attach': [0, 0]}]},
    }
    raw = dict(base[kind])
    raw.update(changes)
    return {key: value for key, value in raw.items() if value is not None}


W = r't\.yaml: structure\.elements\[0\]\.setup'


@pytest.mark.parametrize(('make', 'n_basic', 'pattern'), [
    (lambda: config('column', stroke=1.0), 2, W + r'\.stroke: unknown parameter'),
    (lambda: config('column', vertical_length=None), 2, W + r'\.vertical_length: must be a pos'),
    (lambda: config('column', horizontal_length=-1.0), 2, W + r'\.horizontal_length: must be'),
    (lambda: config('column', vertical_length=True), 2, W + r'\.vertical_length: must be'),
    (lambda: config('column', geometry='exact'), 2, W + r"\.geometry: must be 'linear' or"),
    (lambda: config('column'), 3, W + r': a column setup needs an element with 2 DOFs'),
    (lambda: config('planar_3'), 2, W + r': a planar_3 setup needs an element with 3 DOFs'),
    (lambda: config('planar_3', offset=0.0), 3, W + r'\.offset: must be a positive number'),
    (lambda: config('planar', basic=['x', 'y']), 2, W + r'\.basic: must be \[u, v\]'),
    (lambda: config('planar', basic=['u', 'v', 'theta']), 2, W + r': a planar setup needs'),
    (lambda: config('planar', actuators=[{'pin': [-1, 0], 'attach': [0, 0]}]), 2,
     W + r'\.actuators: must be a list of 2 actuators'),
    (lambda: config('planar', actuators=[{'pin': [-1, 0], 'attach': [0, 0], 'k': 1},
                                         {'pin': [0, 1], 'attach': [0, 0]}]), 2,
     W + r'\.actuators\[0\]\.k: unknown key'),
    (lambda: config('planar', actuators=[{'pin': [-1, 0], 'attach': [0, 0]},
                                         {'pin': [0, 1, 2], 'attach': [0, 0]}]), 2,
     W + r'\.actuators\[1\]\.pin: must be a point'),
    (lambda: config('planar', actuators=[{'pin': [-1, 0], 'attach': [0, 0]},
                                         {'pin': [-2, 0], 'attach': [0, 0]}]), 2,
     W + r': the actuators cannot impose the 2 basic DOFs \(Jacobian at rest singular'),
    (lambda: config('planar', actuators=[{'pin': [-1, 0], 'attach': [0, 0]},
                                         {'pin': [0, 0], 'attach': [0, 0]}]), 2,
     W + r': actuator 2 has its pin at its attachment point'),
])
def test_config_errors_are_one_line_naming_the_key(
        make: Callable[[], dict[str, object]], n_basic: int, pattern: str) -> None:
    with pytest.raises(SetupError, match='^' + pattern) as caught:
        setup_from_config(make(), n_basic, WHERE)
    assert '\n' not in str(caught.value)


def test_direct_construction_errors_name_the_setup() -> None:
    with pytest.raises(SetupError, match=r'^planar setup: the actuators cannot impose'):
        PlanarActuators([(-1.0, 0.0), (-1.0, 0.5)], [(0.0, 0.0), (0.0, 0.5)], 2)
    with pytest.raises(SetupError, match=r'^planar setup: needs as many actuators as basic'):
        PlanarActuators([(-1.0, 0.0), (0.0, 1.0)], [(0.0, 0.0), (0.0, 0.0)], 3)
    with pytest.raises(SetupError, match=r'^column setup: vertical_length must be a positive'):
        ColumnSetup(1.0, 0.0)
    with pytest.raises(SetupError, match=r"^planar_3 setup: geometry must be 'linear'"):
        PlanarThreeActuators(0.5, 1.0, 1.0, 'small')


def test_unreachable_strokes_raise_one_line() -> None:
    setup = ColumnSetup(LH, LV)
    # The horizontal actuator cannot be shorter than zero: stroke −3 L_h has no solution.
    with pytest.raises(SetupError, match=r'^column setup: no basic displacement found') as err:
        setup.basic_displacement(np.array([-3 * LH, 0.0]))
    assert '\n' not in str(err.value)


def test_integrator_adapter_raises_its_config_error() -> None:
    assert adapter.ColumnSetup is ColumnSetup
    with pytest.raises(ConfigError, match='^' + W + r'\.offset: must be a positive number'):
        adapter.setup_from_config(config('planar_3', offset=-1), 3, WHERE)
