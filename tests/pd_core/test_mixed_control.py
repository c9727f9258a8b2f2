"""Mixed control without ROS: an experimental column whose axial load is force-controlled.

References are closed forms and independent constructions, never this code's own output:

* parsing: one-line errors naming ``file: structure.elements[i] (name).control...``;
* commands: the column setup's strokes from its geometry (pins at ``(−L_h, 0)`` and
  ``(0, L_v)``), ``F(t)`` of a table by hand, the feedback's forces ``Jᵀ f`` from the
  actuators' unit vectors;
* a run: the lateral displacement history against the exact recursion of the Newmark
  explicit scheme on an SDOF of stiffness ``k − P/L`` (written out below), its free-vibration
  period against ``2π/ω_d`` with ``ω_d Δt = 2 arcsin(Ω/2)``, ``Ω = sqrt((k − P/L)/m) Δt``
  (the scheme's discrete period) and against ``2π sqrt(m/(k − P/L))``; the recorded axial
  force against ``P(t)``; the free DOF's measured ``v`` against ``−P/k_a``.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pd_common.protocol import Command, ControlMode, Feedback
from pd_core.errors import ConfigError
from pd_core.run.loop.coordinator import SiteCoordinator
from pd_core.run.record.outputs import read_response_csv
from pd_core.run.runner import rebuild_outputs, run_offline
from pd_core.run.test_file import from_dict

M = 2543.4           # kg
K = 312559.0         # N/m, lateral (elastic)
L = 2.0              # m, column height
K_A = 3.402e7        # N/m, axial
P = 24950.0          # N, axial load (compression)
L_H, L_V = 1.5, 2.0  # m, actuator lengths at rest
DT = 0.005
RAMP = 0.5           # s, the axial load's ramp in test time
PULSE = (1.0, 0.1)   # s, start and length of the lateral ground pulse
DURATION = 8.0


def pulse_record() -> dict[str, Any]:
    """Zero, then a half-sine ground acceleration of 1 m/s², then zero (free vibration)."""
    t = np.arange(0.0, DURATION + DT / 2, DT)
    start, length = PULSE
    values = np.where((t >= start) & (t <= start + length),
                      np.sin(np.pi * (t - start) / length), 0.0)
    return {'inline': {'dt': DT, 'acceleration': values.tolist()}, 'units': 'm/s2'}


def column_test(*, geometry: str = 'linear', force: Any = None,
                control: Any = None, dofs: Any = None) -> dict[str, Any]:
    """The column of the test (elastic lateral k, height L, axial P by force control)."""
    element: dict[str, Any] = {
        'type': 'experimental', 'name': 'column', 'site': 'lab',
        'dofs': ['u', None] if dofs is None else dofs,
        'setup': {'type': 'column', 'horizontal_length': L_H, 'vertical_length': L_V,
                  'geometry': geometry},
        'actuators': ['horizontal', 'vertical'],
        'control': ({'vertical': {'mode': 'force',
                                  'force': [[0.0, 0.0], [RAMP, P]] if force is None else force}}
                    if control is None else control),
        'initial_stiffness': [[K, 0.0], [0.0, K_A]]}
    return {
        'test': {'id': 'mixed-column', 'scheme': 'newmark_explicit', 'dt': DT},
        'structure': {'dof_names': ['u'], 'mass': [M], 'damping': {'ratio': 0.0},
                      'elements': [element]},
        'ground_motion': pulse_record(),
        'sites': {'lab': {'specimen': {'column': {
            'height': L, 'axial_stiffness': K_A,
            'lateral': {'model': 'elastic', 'stiffness': K}}},
            'bridge': {'max_force_increment': 2500.0}}},
    }


def definition_of(raw: dict[str, Any], tmp_path: Path):
    return from_dict(copy.deepcopy(raw), source='col.yaml', base_dir=tmp_path)


# -- parsing -----------------------------------------------------------------------------------
WHERE = r'^col\.yaml: structure\.elements\.0'


@pytest.mark.parametrize(('change', 'pattern'), [
    (lambda e: e.pop('control'),
     r'\.control: 0 force-controlled actuators for 1 free basic DOF \(null entries of dofs\)'),
    (lambda e: e['control'].update(horizontal={'mode': 'force', 'force': 1.0}),
     r'\.control: 2 force-controlled actuators for 1 free basic DOF \(null entries of dofs\)'),
    (lambda e: e.update(control={'vert': {'mode': 'force', 'force': 1.0}}),
     r'\.control\.vert: not an actuator of this element \(actuators: horizontal, vertical\)$'),
    (lambda e: e.update(control={'vertical': {'mode': 'torque'}}),
     r"\.control\.vertical\.mode: must be one of 'displacement', 'force', got 'torque'$"),
    (lambda e: e.update(control={'vertical': {'mode': 'force'}}),
     r'\.control\.vertical\.force: is required for force control'),
    (lambda e: e.update(control={'vertical': {'mode': 'force', 'force': 'heavy'}}),
     r'\.control\.vertical\.force: must be a force \[N\] or a table'),
    (lambda e: e.update(control={'vertical': {'mode': 'force',
                                              'force': [[0.0, 0.0], [0.0, 1.0]]}}),
     r'\.control\.vertical\.force\.1: times must increase, got 0 s after 0 s$'),
    (lambda e: e.update(control={'vertical': {'mode': 'force', 'force': [[0.0, math.inf]]}}),
     r'\.control\.vertical\.force: must be a force \[N\] or a table .*got \[\[0\.0, Infinity'),
    (lambda e: e['control'].update(horizontal={'mode': 'displacement', 'force': 1.0}),
     r'\.control\.horizontal\.force: unknown parameter for displacement control$'),
    (lambda e: e.update(control=[1, 2]),
     r'\.control: must be a mapping, got \[1, 2\]'),
    (lambda e: e.update(dofs=[None, None]),
     r'\.dofs: needs at least one structure DOF'),
    (lambda e: e.update(dofs=['w', None]),
     r"\.dofs: 'w' is not a DOF name or null \(DOFs: u\)$"),
    (lambda e: e.update(relative_to=[None, 'u']),
     r'\.relative_to: entry 2 must be null: the basic DOF is free'),
    (lambda e: e.update(initial_stiffness=[[K, 0.0], [0.0, 0.0]]),
     (r'\.initial_stiffness: its block on the free basic DOFs \(null entries of dofs\) must '
      r'be invertible')),
])
def test_control_errors_are_one_line(tmp_path: Path, change, pattern: str) -> None:
    raw = column_test()
    change(raw['structure']['elements'][0])
    with pytest.raises(ConfigError, match=WHERE + pattern) as caught:
        definition_of(raw, tmp_path)
    assert '\n' not in str(caught.value)


def test_free_dofs_are_condensed_out_of_the_initial_stiffness(tmp_path: Path) -> None:
    raw = column_test()
    coupling = 2.0e5
    raw['structure']['elements'][0]['initial_stiffness'] = [[K, coupling], [coupling, K_A]]
    definition = definition_of(raw, tmp_path)
    assert definition.initial_stiffness is not None
    # Static condensation by hand: k_uu - k_uv k_vv^-1 k_vu.
    assert definition.initial_stiffness[0, 0] == pytest.approx(K - coupling ** 2 / K_A,
                                                               rel=1e-15)


# -- commands and feedback ---------------------------------------------------------------------
def strokes_by_hand(u: float, v: float) -> tuple[float, float]:
    """The column setup's strokes: pins at (−L_h, 0) and (0, L_v), both attached at the top."""
    return (math.hypot(u + L_H, v) - L_H, math.hypot(u, v - L_V) - L_V)


def test_commands_carry_modes_forces_and_the_last_measured_free_dof(tmp_path: Path) -> None:
    table = [[0.0, 0.0], [1.0, 10.0e3], [3.0, 30.0e3]]
    definition = definition_of(column_test(geometry='nonlinear', force=table), tmp_path)
    coordinator = SiteCoordinator(definition.model)

    def structure(step: int, time: float, u: float) -> Command:
        return Command(test_id='mixed-column', step=step, test_time=time, dof_names=('u',),
                       target_displacement=(u,))

    # Step 0 at rest: the free v is 0 (nothing measured yet), the vertical stroke target 0.
    (site, first), = coordinator.dispatch(structure(0, 0.0, 0.0))
    assert site == 'lab'
    assert first.dof_names == ('horizontal', 'vertical')
    assert first.control_mode == (ControlMode.DISPLACEMENT, ControlMode.FORCE)
    assert first.target_force == (0.0, 0.0)
    assert first.target_displacement == (0.0, 0.0)
    assert first.control_error() is None
    # The site measured the top at (u, v) = (1e-4, -7e-4) with forces (f_h, f_v).
    u_m, v_m, f_h, f_v = 1.0e-4, -7.0e-4, 31.0, 24000.0
    measured = strokes_by_hand(u_m, v_m)
    _, feedback = coordinator.on_feedback('lab', Feedback(
        test_id='mixed-column', step=0, measured_displacement=measured,
        restoring_force=(f_h, f_v)))
    assert feedback is not None
    # Jᵀ f, u component, from the actuators' unit vectors (pin → top).
    e_h = np.array([u_m + L_H, v_m]) / math.hypot(u_m + L_H, v_m)
    e_v = np.array([u_m, v_m - L_V]) / math.hypot(u_m, v_m - L_V)
    assert feedback.restoring_force[0] == pytest.approx(f_h * e_h[0] + f_v * e_v[0], rel=1e-12)
    assert feedback.measured_displacement[0] == pytest.approx(u_m, rel=1e-9)
    # Step 1 at t = 2 s: F linear between (1, 10 kN) and (3, 30 kN); the horizontal stroke
    # from (u trial, v measured); the vertical target is the stroke measured last.
    u_trial = 3.0e-3
    (_, second), = coordinator.dispatch(structure(1, 2.0, u_trial))
    assert second.target_force == (0.0, pytest.approx(20.0e3, rel=1e-15))
    assert second.target_displacement[0] == pytest.approx(
        strokes_by_hand(u_trial, v_m)[0], rel=1e-12)
    assert second.target_displacement[1] == measured[1]
    # After the table's last point the force is held.
    coordinator.on_feedback('lab', Feedback(test_id='mixed-column', step=1,
                                            measured_displacement=measured,
                                            restoring_force=(f_h, f_v)))
    (_, third), = coordinator.dispatch(structure(2, 9.0, u_trial))
    assert third.target_force[1] == 30.0e3


def test_plain_sites_keep_plain_commands(tmp_path: Path) -> None:
    raw = column_test(geometry='nonlinear', dofs=['u', 'w'],
                      control={'vertical': {'mode': 'displacement'}})
    raw['structure'].update(dof_names=['u', 'w'], mass=[M, M])
    definition = definition_of(raw, tmp_path)
    (_, command), = SiteCoordinator(definition.model).dispatch(Command(
        test_id='x', step=0, test_time=0.0, dof_names=('u', 'w'),
        target_displacement=(1e-3, -2e-3)))
    assert command.control_mode == () and command.target_force == ()
    assert command.target_displacement == pytest.approx(strokes_by_hand(1e-3, -2e-3), rel=1e-9)
    # Force control with every basic DOF a structure DOF is refused.
    raw['structure']['elements'][0]['control'] = {'vertical': {'mode': 'force', 'force': P}}
    with pytest.raises(ConfigError, match=WHERE + r'\.control: 1 force-controlled actuator '
                       r'for 0 free basic DOFs'):
        definition_of(raw, tmp_path)


# -- a run -------------------------------------------------------------------------------------
def newmark_explicit_sdof(k: float, m: float, dt: float, ground: np.ndarray) -> np.ndarray:
    """The Newmark explicit recursion (β = 0, γ = 1/2) of an undamped linear SDOF, by hand."""
    x = np.zeros(ground.size)
    v = 0.0
    a = -ground[0]
    for i in range(ground.size - 1):
        x[i + 1] = x[i] + dt * v + 0.5 * dt * dt * a
        a_next = (-m * ground[i + 1] - k * x[i + 1]) / m
        v += 0.5 * dt * (a + a_next)
        a = a_next
    return x


def mean_period(time: np.ndarray, x: np.ndarray) -> float:
    """The mean period from the upward zero crossings (linear interpolation)."""
    up = np.nonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))[0]
    crossings = time[up] - x[up] * (time[up + 1] - time[up]) / (x[up + 1] - x[up])
    assert crossings.size >= 5
    return float((crossings[-1] - crossings[0]) / (crossings.size - 1))


@pytest.fixture(scope='module')
def linear_run(tmp_path_factory: pytest.TempPathFactory):
    tmp_path = tmp_path_factory.mktemp('mixed')
    definition = definition_of(column_test(), tmp_path)
    return run_offline(definition, tmp_path / 'run', figures=False)


def test_column_lateral_response_is_that_of_k_minus_p_over_l(linear_run) -> None:
    history = linear_run.session.history
    n = history.n_committed
    assert n == round(DURATION / DT) + 1
    x = history.displacement[:n, 0]
    ground = np.array(pulse_record()['inline']['acceleration'])
    k_eff = K - P / L
    reference = newmark_explicit_sdof(k_eff, M, DT, ground)
    peak = float(np.max(np.abs(reference)))
    assert peak > 1e-4
    # The same recursion on the same floats but for the route through the setup and the
    # simulated specimen (Newton-solved mixed state): measured 4.3e-15 of the peak.
    assert float(np.max(np.abs(x - reference))) < 1e-12 * peak
    # Without P-Δ the response would differ at the percent level.
    unloaded = newmark_explicit_sdof(K, M, DT, ground)
    assert float(np.max(np.abs(x - unloaded))) > 0.05 * peak
    # Period of the free vibration after the pulse.
    free = history.time[:n] > PULSE[0] + PULSE[1] + DT
    period = mean_period(history.time[:n][free], x[free])
    omega = math.sqrt(k_eff / M)
    discrete = 2.0 * math.pi * DT / (2.0 * math.asin(omega * DT / 2.0))
    assert period == pytest.approx(discrete, rel=2e-5)
    assert period == pytest.approx(2.0 * math.pi / omega, rel=5e-4)
    assert abs(period / (2.0 * math.pi * math.sqrt(M / K)) - 1.0) > 0.015  # P-Δ: +2 %


def test_axial_force_and_free_dof_are_recorded(linear_run) -> None:
    columns = read_response_csv(linear_run.directory / 'actuators.csv')
    time = columns['time']
    expected = P * np.minimum(time / RAMP, 1.0)
    np.testing.assert_allclose(columns['command_vertical'], expected, rtol=1e-15, atol=1e-9)
    np.testing.assert_allclose(columns['force_vertical'], expected, rtol=1e-12, atol=1e-6)
    after = time >= RAMP
    assert np.all(np.abs(columns['force_vertical'][after] - P) <= 1e-9 * P)
    assert np.all(columns['mode_vertical'] == 1.0) and np.all(columns['mode_horizontal'] == 0.0)
    # Linear geometry: v = -P(t)/k_a exactly as the closed form; the stroke is -v.
    np.testing.assert_allclose(columns['column.v'], -expected / K_A, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(columns['stroke_vertical'], expected / K_A, rtol=1e-12,
                               atol=1e-18)
    # The axial (basic) force is -P: compression; the horizontal actuator carries (k - P/L) u.
    np.testing.assert_allclose(columns['column.v_force'], -expected, rtol=1e-12, atol=1e-6)
    u = columns['column.u']
    np.testing.assert_allclose(columns['force_horizontal'][after], (K - P / L) * u[after],
                               rtol=0.0, atol=1e-9 * K * float(np.max(np.abs(u))))
    summary = linear_run.summary['actuators']
    assert summary['force_controlled']['vertical']['final_force'] == pytest.approx(P, rel=1e-12)
    assert summary['free_dofs']['column.v']['final'] == pytest.approx(-P / K_A, rel=1e-12)


def test_replay_rebuilds_the_actuator_outputs(linear_run, tmp_path: Path) -> None:
    rebuilt = rebuild_outputs(linear_run.bag_path, tmp_path / 'rebuilt', figures=False)
    assert (tmp_path / 'rebuilt' / 'actuators.csv').read_bytes() == (
        linear_run.directory / 'actuators.csv').read_bytes()
    assert rebuilt.summary['actuators'] == linear_run.summary['actuators']


def test_nonlinear_geometry_column_and_a_ramped_constant_load(tmp_path: Path) -> None:
    # The exact actuator geometry, the load constant from step 0 (the simulator ramps it in
    # sub-steps of at most 2500 N within step 0): the tilted vertical actuator changes the
    # vertical basic force by cos θ - 1 ~ (u / L_v)² / 2 < 1e-7 here.
    raw = column_test(geometry='nonlinear', force=P)
    result = run_offline(definition_of(raw, tmp_path), tmp_path / 'run', figures=False)
    columns = read_response_csv(result.directory / 'actuators.csv')
    assert np.all(np.abs(columns['force_vertical'] - P) <= 1e-9 * P)
    # k_a v = -P cos θ_v + (v / |horizontal|) f_h: the vertical actuator tilted by u / L_v,
    # the horizontal one by v / L_h (bounds by hand, 10 % margin).
    v, u, f_h = columns['column.v'], columns['column.u'], columns['force_horizontal']
    bound = 1.1 * (P * (u / L_V) ** 2 / 2.0 + np.abs(v) / L_H * np.abs(f_h)) + 1e-9 * P
    assert np.all(np.abs(K_A * v + P) <= bound)
    assert float(np.max(np.abs(K_A * v + P))) > 1e-3  # the geometry shows
    history = result.session.history
    n = history.n_committed
    free = history.time[:n] > PULSE[0] + PULSE[1] + DT
    period = mean_period(history.time[:n][free], history.displacement[:n, 0][free])
    assert period == pytest.approx(2.0 * math.pi * math.sqrt(M / (K - P / L)), rel=5e-4)
