"""SpecimenServer with mixed (force/displacement) control, a site's setup and a force ramp.

References: closed forms (v = −P/k_a, ceil(P/inc) sub-steps of equal size), independent
constructions (a server fed the ramp's sub-steps one command at a time; a spy counting the
specimen's commits) and the unchanged plain path (a server without setup or modes).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from pd_common.config import read_test_file
from pd_common.errors import SpecimenConfigError, SpecimenError
from pd_common.experimental import ColumnSetup, ErrorModel, OneToOneSetup
from pd_common.experimental.force_ramp import force_ramp
from pd_common.protocol import Feedback, FeedbackStatus
from pd_common.specimen import (
    BilinearKinematic,
    ColumnSpecimen,
    Elastic,
    ElasticPerfectlyPlastic,
    SiteGeometry,
    Specimen,
    SpecimenServer,
    load_site_server,
    server_from_config,
    site_geometry,
)
from support.sections import INLINE_GROUND_MOTION

K, KA, L = 1.0e6, 1.0e9, 3.0
P = 24950.0                  # the thesis's gravity load [N]
INCREMENT = 2500.0           # max_force_increment [N]
FORCE, DISPLACEMENT = 1, 0
MODES = (DISPLACEMENT, FORCE)


class CountingColumn(ColumnSpecimen):
    """A column that counts its commits and remembers each committed (u, v)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.commits: list[tuple[float, float]] = []

    def commit(self) -> None:
        super().commit()
        self.commits.append(self.committed_displacement())


def column(lateral: Any = None, axial: float = KA) -> CountingColumn:
    return CountingColumn(BilinearKinematic(K, 3.0e4, -0.02) if lateral is None else lateral,
                          L, axial)


def same(a: Feedback | None, b: Feedback | None) -> None:
    assert a is not None and b is not None
    assert a.status is b.status
    assert a.measured_displacement == b.measured_displacement  # bit for bit
    assert a.restoring_force == b.restoring_force


# -- force ramp --------------------------------------------------------------------------------
@pytest.mark.parametrize('setup', [None, ColumnSetup(1.5, 2.0)], ids=['one_to_one', 'column'])
def test_a_force_change_goes_through_ceil_p_over_inc_committed_states(setup: Any) -> None:
    load = P if setup is not None else -P          # one_to_one: −P pushes the top down
    ramped = SpecimenServer(column(), setup=setup, max_force_increment=INCREMENT)
    answer = ramped.handle('t', 1, (0.002, 0.0), control_mode=MODES, target_force=(0.0, load))
    assert answer is not None and answer.status is FeedbackStatus.OK, answer
    count = math.ceil(P / INCREMENT)
    assert count == 10
    assert len(ramped.specimen.commits) == count
    assert ramped.ramp_substeps == count
    assert ramped.steps_served == 1
    assert ramped.held == (0.0, load)
    assert answer.restoring_force[1] == pytest.approx(load, rel=1e-10)
    # each sub-step a committed state: the vertical displacement follows the force in equal
    # steps (one_to_one: v_k = k·(−P/n)/k_a exactly to the solver's tolerance)
    if setup is None:
        vs = [v for _, v in ramped.specimen.commits]
        np.testing.assert_allclose(vs, [-(k + 1) * P / count / KA for k in range(count)],
                                   rtol=1e-10)
    # the same specimen fed the sub-steps one command at a time: the same states, bit for bit
    stepped = SpecimenServer(column(), setup=setup, max_force_increment=INCREMENT)
    last = None
    for step, force in enumerate(force_ramp(0.0, load, INCREMENT), start=1):
        last = stepped.handle('t', step, (0.002, 0.0), control_mode=MODES,
                              target_force=(0.0, force))
    same(answer, last)
    assert stepped.specimen.commits == ramped.specimen.commits
    assert stepped.basic == ramped.basic
    # ... and without a ramp of its own (each sub-step is within the increment anyway)
    plain = SpecimenServer(column(), setup=setup)
    for step, force in enumerate(force_ramp(0.0, load, INCREMENT), start=1):
        last = plain.handle('t', step, (0.002, 0.0), control_mode=MODES,
                            target_force=(0.0, force))
    same(answer, last)
    # an unchanged force: one state; back to zero: the ramp again (from the held force)
    ramped.handle('t', 2, (0.003, 0.0), control_mode=MODES, target_force=(0.0, load))
    assert len(ramped.specimen.commits) == count + 1
    down = ramped.handle('t', 3, (0.003, 0.0), control_mode=MODES, target_force=(0.0, 0.0))
    assert down is not None and down.status is FeedbackStatus.OK
    assert len(ramped.specimen.commits) == 2 * count + 1
    assert ramped.held == (0.0, 0.0)


def test_an_uneven_ramp_and_two_force_controlled_actuators() -> None:
    """Each actuator follows its own ramp; the shorter one holds its target when done."""
    server = SpecimenServer(column(Elastic(K)), max_force_increment=3000.0)
    answer = server.handle('t', 1, (0.0, 0.0), control_mode=(FORCE, FORCE),
                           target_force=(4000.0, -P))
    assert answer is not None and answer.status is FeedbackStatus.OK, answer
    assert len(server.specimen.commits) == math.ceil(P / 3000.0) == 9
    u, v = server.basic
    assert v == pytest.approx(-P / KA, rel=1e-10)
    assert u * (K + KA * v / L) == pytest.approx(4000.0, rel=1e-10)
    # the lateral force reached 4000 N in ceil(4000/3000) = 2 sub-steps, then held it, while
    # the axial one rose by P/9 per sub-step
    lateral = [u_k * (K + KA * v_k / L) for u_k, v_k in server.specimen.commits]
    np.testing.assert_allclose(lateral, [2000.0] + [4000.0] * 8, rtol=1e-9)
    axial = [KA * v_k for _, v_k in server.specimen.commits]
    np.testing.assert_allclose(axial, [-P * k / 9 for k in range(1, 10)], rtol=1e-9)


# -- a runaway and faithful reporting ----------------------------------------------------------
def test_a_soft_column_under_force_control_runs_away_and_the_server_says_so() -> None:
    """A tiny axial stiffness: the vertical stroke is whatever P makes it (−P/k_a), reported
    as measured; holding it is the bridge's job (its stroke limit)."""
    soft = 10.0  # N/m
    server = SpecimenServer(column(Elastic(K), axial=soft))
    answer = server.handle('t', 1, (0.0, 0.0), control_mode=MODES, target_force=(0.0, -P))
    assert answer is not None and answer.status is FeedbackStatus.OK, answer
    assert answer.measured_displacement[1] == pytest.approx(-P / soft, rel=1e-10)  # −2495 m
    assert answer.restoring_force[1] == pytest.approx(-P, rel=1e-10)
    # through the column setup: the top sinks by a large v (the horizontal actuator, held
    # at its stroke, swings it sideways); the server reports the geometric strokes of that
    # state and the vertical actuator still holds P
    setup = ColumnSetup(1.5, 2.0)
    soft = P / 0.5
    server = SpecimenServer(column(Elastic(K), axial=soft), setup=setup)
    answer = server.handle('t', 1, (0.0, 0.0), control_mode=MODES, target_force=(0.0, P))
    assert answer is not None and answer.status is FeedbackStatus.OK, answer
    u, v = server.basic
    assert v < -0.3
    top = np.array([u, v])
    pin_h, pin_v = np.array([-1.5, 0.0]), np.array([0.0, 2.0])
    assert math.hypot(*(top - pin_h)) - 1.5 == pytest.approx(0.0, abs=1e-12)
    assert answer.measured_displacement[1] == pytest.approx(math.hypot(*(top - pin_v)) - 2.0,
                                                            rel=1e-12)
    assert answer.measured_displacement[1] > 0.3
    f_h, f_v = answer.restoring_force
    assert f_v == pytest.approx(P, rel=1e-10)
    basic = (f_h * (top - pin_h) / math.hypot(*(top - pin_h))
             + f_v * (top - pin_v) / math.hypot(*(top - pin_v)))
    assert basic[1] == pytest.approx(soft * v, rel=1e-9)                 # N = k_a v
    assert basic[0] == pytest.approx(K * u + soft * v * u / L, rel=1e-9)   # with P-Δ


def test_no_solution_is_a_fault_and_nothing_is_committed() -> None:
    """An elastic-perfectly-plastic column asked to hold more than its yield force laterally
    (without axial load: under P the P-Δ term would give it a leaning equilibrium)."""
    server = SpecimenServer(column(ElasticPerfectlyPlastic(K, 3.0e4)))
    first = server.handle('t', 1, (0.01, 0.0), control_mode=MODES, target_force=(0.0, -P))
    assert first is not None and first.status is FeedbackStatus.OK
    before = (server.position, server.force, server.basic, server.held,
              list(server.specimen.commits))
    answer = server.handle('t', 2, (0.0, 0.0), control_mode=(FORCE, FORCE),
                           target_force=(4.0e4, 0.0))
    assert answer is not None and answer.status is FeedbackStatus.FAULT
    assert 'no specimen state found' in answer.message and '\n' not in answer.message
    assert (server.position, server.force, server.basic, server.held,
            server.specimen.commits) == before
    np.testing.assert_array_equal(server.specimen.committed_restoring_force(),
                                  first.restoring_force)
    assert server.steps_served == 1 and server.faults == 1


@pytest.mark.parametrize(('modes', 'forces', 'target', 'expected'), [
    ((0,), (0.0, 1.0), (0.0, 0.0), 'invalid control: 1 control modes and 2 target forces'),
    ((0, 1), (0.0,), (0.0, 0.0), 'invalid control: 2 control modes and 1 target forces'),
    ((), (0.0, 1.0), (0.0, 0.0), 'invalid control: 2 target forces without control modes'),
    ((0, 7), (0.0, 1.0), (0.0, 0.0), 'invalid control: DOF 1: unknown control mode 7'),
    ((0, 1), (0.0, math.inf), (0.0, 0.0), 'invalid control: DOF 1: target force inf'),
    ((0, 1), (0.0, 1.0), (0.0, math.nan), 'invalid target displacement'),
    ((0, 1), (0.0, 1.0), (0.0,), 'invalid target displacement'),
])
def test_bad_modes_or_forces_are_one_line_faults_and_nothing_moves(
        modes: tuple[int, ...], forces: tuple[float, ...], target: tuple[float, ...],
        expected: str) -> None:
    server = SpecimenServer(column(), setup=ColumnSetup(1.5, 2.0), max_force_increment=1.0e3)
    server.handle('t', 1, (0.001, 0.0), control_mode=MODES, target_force=(0.0, 5000.0))
    before = (server.position, server.force, server.basic, server.held,
              list(server.specimen.commits), server.steps_served)
    answer = server.handle('t', 2, target, control_mode=modes, target_force=forces)
    assert answer is not None and answer.status is FeedbackStatus.FAULT
    assert answer.message.startswith(expected), answer.message
    assert '\n' not in answer.message
    assert (server.position, server.force, server.basic, server.held,
            server.specimen.commits, server.steps_served) == before
    assert answer.measured_displacement == before[0]


# -- the plain path is unchanged ---------------------------------------------------------------
def test_plain_commands_are_served_as_before_bit_for_bit() -> None:
    def build(**kwargs: Any) -> SpecimenServer:
        return SpecimenServer(Specimen([BilinearKinematic(K, 3.0e4, 0.02),
                                        ElasticPerfectlyPlastic(2 * K, 1.0e4)],
                                       topology='shear_building'), **kwargs)

    reference = build()
    others = [build(setup=OneToOneSetup(2)), build(max_force_increment=INCREMENT),
              build(setup=OneToOneSetup(2), max_force_increment=INCREMENT)]
    for step in range(1, 120):
        target = (0.05 * math.sin(step / 7.0), 0.08 * math.sin(step / 5.0))
        expected = reference.handle('t', step, target)
        for index, other in enumerate(others):
            kwargs: dict[str, Any] = ({} if index == 0 else
                                      {'control_mode': (0, 0), 'target_force': (0.0, 0.0)})
            same(expected, other.handle('t', step, target, **kwargs))


def test_force_control_of_a_shear_building_specimen_uses_its_tangent() -> None:
    """Hold the top story's force: r_2 = k_2 (x_2 − x_1) = F with x_1 imposed."""
    specimen = Specimen([Elastic(K), BilinearKinematic(2 * K, 1.0e4, 0.1)],
                        topology='shear_building')
    server = SpecimenServer(specimen)
    answer = server.handle('t', 1, (0.002, 0.0), control_mode=(0, 1),
                           target_force=(0.0, 1.2e4))
    assert answer is not None and answer.status is FeedbackStatus.OK, answer
    drift = answer.measured_displacement[1] - 0.002
    # past yield (5 mm drift): 1e4 + 0.1 · 2e6 · (drift − 0.005) = 1.2e4 → drift = 0.015
    assert drift == pytest.approx(0.015, rel=1e-9)
    assert answer.restoring_force[1] == pytest.approx(1.2e4, rel=1e-10)


def test_mixed_control_and_errors_or_per_step_are_refused() -> None:
    errors = ErrorModel(systematic=-0.05, seed=1)
    server = SpecimenServer(column(), errors=errors)
    answer = server.handle('t', 1, (0.0, 0.0), control_mode=MODES, target_force=(0.0, -P))
    assert answer is not None and answer.status is FeedbackStatus.FAULT
    assert answer.message == ('force control cannot be combined with injected errors '
                              '(specimen.errors)')
    assert server.handle('t', 2, (0.001, 0.0)) is not None  # plain commands still served
    with pytest.raises(SpecimenError, match=r'^errors: injected errors cannot be combined'):
        SpecimenServer(column(), errors=errors, setup=ColumnSetup(1.5, 2.0))
    with pytest.raises(SpecimenError, match=r'^commit: per_step cannot be combined with a '
                                            r'force ramp'):
        SpecimenServer(column(), commit='per_step', max_force_increment=1.0)
    with pytest.raises(SpecimenError, match=r'^max_force_increment: must be a number >= 0'):
        SpecimenServer(column(), max_force_increment=-1.0)


def test_per_step_mixed_iterations_are_trials_from_the_steps_start() -> None:
    def server(commit: str) -> SpecimenServer:
        return SpecimenServer(column(ElasticPerfectlyPlastic(K, 3.0e4)), commit=commit)

    per_step, per_command = server('per_step'), server('per_command')
    for s in (per_step, per_command):
        s.handle('t', 1, (0.05, 0.0), iteration=0, control_mode=MODES,
                 target_force=(0.0, -P))               # yields: plastic 0.02 m
    back_step = per_step.handle('t', 1, (0.01, 0.0), iteration=1, control_mode=MODES,
                                target_force=(0.0, -P))
    back_command = per_command.handle('t', 1, (0.01, 0.0), iteration=1, control_mode=MODES,
                                      target_force=(0.0, -P))
    assert back_step is not None and back_command is not None
    pd = -P * 0.01 / L
    assert back_step.restoring_force[0] == pytest.approx(K * 0.01 + pd, rel=1e-9)
    assert back_command.restoring_force[0] == pytest.approx(K * (0.01 - 0.02) + pd, rel=1e-9)
    assert per_step.specimen.commits == []


# -- the site's geometry from the test file ----------------------------------------------------
def column_test_file(folder: Path, **changes: Any) -> Path:
    element = {'type': 'experimental', 'name': 'column', 'site': 'lab', 'dofs': ['u', None],
               'setup': {'type': 'column', 'horizontal_length': 1.5, 'vertical_length': 2.0},
               'actuators': ['horizontal', 'vertical'],
               'initial_stiffness': [[K, 0.0], [0.0, KA]]}
    element.update(changes.pop('element', {}))
    raw = {'test': {'id': 'column', 'dt': 0.01},
           'structure': {'dof_names': ['u'], 'mass': [2543.4], 'elements': [element]},
           'sites': {'lab': {
               'specimen': {'column': {'height': L, 'axial_stiffness': KA, 'lateral': {
                   'model': 'elastic', 'stiffness': K}}},
               'bridge': {'max_force': 6.0e4, 'max_force_increment': INCREMENT,
                          **changes.pop('bridge', {})}}},
           'ground_motion': INLINE_GROUND_MOTION}
    path = folder / 'column.yaml'
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    return path


def test_load_site_server_takes_the_setup_and_ramp_of_the_site(tmp_path: Path) -> None:
    server, section, names = load_site_server(column_test_file(tmp_path), 'lab')
    assert names == ['horizontal', 'vertical']
    assert isinstance(server.setup, ColumnSetup)
    assert server.max_force_increment == INCREMENT
    assert 'column' in section
    reference = SpecimenServer(ColumnSpecimen(Elastic(K), L, KA), setup=ColumnSetup(1.5, 2.0),
                               max_force_increment=INCREMENT)
    for step in range(1, 4):
        same(reference.handle('t', step, (0.001 * step, 0.0), control_mode=MODES,
                              target_force=(0.0, P)),
             server.handle('t', step, (0.001 * step, 0.0), control_mode=MODES,
                           target_force=(0.0, P)))
    assert server.geometry is not None and server.geometry['max_force_increment'] == INCREMENT
    # without actuator names, a1, a2 (as for any site)
    _, _, default = load_site_server(column_test_file(tmp_path, element={'actuators': None}),
                                     'lab')
    assert default == ['a1', 'a2']


def test_site_geometry_reads_the_typed_test_file(tmp_path: Path) -> None:
    model = read_test_file(column_test_file(tmp_path)).model
    assert model.sites is not None
    lab = model.sites['lab']
    geometry = site_geometry(model.structure.elements, lab, 'lab', 'column.yaml')
    assert isinstance(geometry.setup, ColumnSetup)
    assert (geometry.setup.n_basic, geometry.setup.n_actuators) == (2, 2)
    assert geometry.max_force_increment == INCREMENT
    assert geometry.actuators == ('horizontal', 'vertical')
    # the test's own specimen: no setup, no ramp; a site without settings: no ramp
    assert site_geometry(model.structure.elements, None, '', 'column.yaml') == SiteGeometry()
    bare = site_geometry(model.structure.elements, None, 'lab', 'column.yaml')
    assert bare.setup is None and bare.max_force_increment == 0.0  # (no column specimen)


@pytest.mark.parametrize(('changes', 'message'), [
    ({'element': {'setup': {'type': 'column', 'horizontal_length': -1.0,
                            'vertical_length': 2.0}}},
     'column.yaml: structure.elements.0.setup.horizontal_length: must be > 0, got -1.0'),
    ({'element': {'dofs': ['u']}},
     'column.yaml: structure.elements[0].setup: a column setup needs an element with 2 DOFs'),
    ({'bridge': {'max_force_increment': -5.0}},
     'column.yaml: sites.lab.bridge.max_force_increment: must be >= 0, got -5.0'),
    ({'element': {'dofs': ['u', None, None], 'actuators': ['w', 'e', 'h'], 'setup': {
        'type': 'planar_3', 'offset': 0.5, 'vertical_length': 2.0, 'horizontal_length': 1.5}}},
     'column.yaml: sites.lab.specimen: the setup has 3 basic DOFs but the specimen 2'),
])
def test_bad_site_geometry_is_one_line(tmp_path: Path, changes: dict[str, Any], message: str
                                       ) -> None:
    path = column_test_file(tmp_path, **changes)
    with pytest.raises(SpecimenError) as error:
        load_site_server(path, 'lab')
    assert str(error.value).startswith(message), str(error.value)
    assert '\n' not in str(error.value)


def test_server_from_config_checks_the_served_dofs() -> None:
    section = {'column': {'height': L, 'axial_stiffness': KA,
                          'lateral': {'model': 'elastic', 'stiffness': K}}}
    with pytest.raises(SpecimenConfigError, match=r"^t\.yaml: specimen: 2 actuators but 1 DOF "
                                                  r"names \['u'\]"):
        server_from_config(section, base_dir=Path('.'), source='t.yaml', dof_names=['u'])
    server = server_from_config(section, base_dir=Path('.'), source='t.yaml',
                                dof_names=['u', 'v'], max_force_increment=INCREMENT)
    assert server.max_force_increment == INCREMENT and server.setup is None
