"""Substructured tests without ROS: structure model, sites, setups, multi-component motions.

The references are closed forms and independent computations: exact modal superposition for
the linear 3-story building, the same building with a story moved to a simulated site, two
uncoupled directions against two one-directional runs, and the rigid-link geometry.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pd_common.protocol import Command, Feedback, FeedbackStatus
from pd_common.protocol import TestState as State
from pd_core.errors import ConfigError
from pd_core.model.setups import OneToOneSetup, RigidLinkTwoActuators, setup_from_config
from pd_core.model.substructure import NonlinearSpring
from pd_core.run.loop.coordinator import SiteCoordinator
from pd_core.run.loop.dispatch import StepDispatcher
from pd_core.run.loop.protocol import Verdict
from pd_core.run.loop.session import TestSession as Session  # not a test class
from pd_core.run.runner import replay_bag, run_offline
from pd_core.run.test_file import from_dict, from_json, load_test_file
from pd_core.schemes import linalg as scheme_linalg
from pd_core.verification import modal_superposition

MASSES = [2.0e4, 2.0e4, 1.5e4]
STORIES = [4.0e7, 3.5e7, 3.0e7]


def smooth_record(duration: float = 4.0, dt: float = 0.001) -> dict:
    """A smooth inline ground acceleration [m/s²] (two sines under a ramp envelope)."""
    t = np.arange(0.0, duration + dt / 2, dt)
    envelope = np.minimum(t / 0.5, 1.0)
    values = envelope * (2.0 * np.sin(2 * np.pi * 1.3 * t) + 1.2 * np.sin(2 * np.pi * 4.1 * t))
    return {'inline': {'dt': dt, 'acceleration': values.tolist()}, 'units': 'm/s2'}


def building(*, experimental: tuple[int, ...] = (), dt: float = 0.005, scheme: str =
             'newmark_explicit', story_model: dict | None = None,
             damping: dict | None = None) -> dict:
    """A 3-story shear building; stories in ``experimental`` are at sites ``lab<i>``."""
    names = ['u1', 'u2', 'u3']
    elements = []
    sites = {}
    for i, k in enumerate(STORIES):
        dofs = [names[i]] if i == 0 else [names[i - 1], names[i]]
        model = story_model if story_model is not None and i == 0 else None
        if i in experimental:
            element = {'type': 'experimental', 'name': f'story{i + 1}', 'site': f'lab{i + 1}',
                       'dofs': [names[i]], 'initial_stiffness': k}
            if i > 0:
                element['relative_to'] = [names[i - 1]]
            elements.append(element)
            spec = model if model is not None else {'model': 'elastic', 'stiffness': k}
            sites[f'lab{i + 1}'] = {'specimen': {'elements': [spec]}}
        elif model is not None:
            elements.append({'type': 'nonlinear_spring', 'dofs': dofs, 'model': model})
        else:
            elements.append({'type': 'story', 'dofs': dofs, 'stiffness': k})
    raw = {
        'test': {'id': 'three-story', 'scheme': scheme, 'dt': dt},
        'structure': {'dof_names': names, 'mass': MASSES, 'elements': elements,
                      'damping': damping or {'rayleigh': {'modes': [1, 3],
                                                          'ratios': [0.05, 0.05]}}},
        'ground_motion': smooth_record(),
    }
    if sites:
        raw['sites'] = sites
    return raw


def shear_matrix() -> np.ndarray:
    k1, k2, k3 = STORIES
    return np.array([[k1 + k2, -k2, 0.0], [-k2, k2 + k3, -k3], [0.0, -k3, k3]])


def run(raw: dict, tmp_path: Path, name: str):
    definition = from_dict(copy.deepcopy(raw), source=f'{name}.yaml', base_dir=tmp_path)
    return run_offline(definition, tmp_path / name, figures=False)


def test_model_matrices_are_the_shear_building(tmp_path: Path) -> None:
    definition = from_dict(building(experimental=(0,)), source='b.yaml', base_dir=tmp_path)
    np.testing.assert_array_equal(definition.initial_stiffness, shear_matrix())
    np.testing.assert_array_equal(definition.mass, np.diag(MASSES))
    assert definition.site_names == ('lab1',)
    assert definition.model is not None
    assert definition.model.actuator_names('lab1') == ('u1',)


def test_fully_numerical_building_converges_to_modal_superposition(tmp_path: Path) -> None:
    errors = []
    for dt in (0.004, 0.002, 0.001):
        result = run(building(dt=dt), tmp_path, f'numerical-{dt}')
        definition = result.session.definition
        assert result.session.state is State.FINISHED
        exact_x, _, _ = modal_superposition(definition.mass, shear_matrix(), dt=dt,
                                            load=definition.loads(),
                                            damping_matrix=definition.structure().damping)
        x = result.session.history.displacement
        errors.append(float(np.max(np.abs(x - exact_x)) / np.max(np.abs(exact_x))))
    # Newmark explicit (central difference) is second order: halving dt quarters the error.
    assert errors[0] / errors[1] == pytest.approx(4.0, rel=0.1)
    assert errors[1] / errors[2] == pytest.approx(4.0, rel=0.1)
    assert errors[2] < 2e-4


@pytest.mark.parametrize('story_model', [
    None,
    {'model': 'epp', 'stiffness': 4.0e7, 'yield_force': 2.0e4},
    # softening models: the same spring at the site and in the computer
    {'model': 'bilinear', 'stiffness': 4.0e7, 'yield_force': 2.0e4, 'hardening_ratio': -0.05,
     'residual_force': 1.0e4},
    {'model': 'pushover', 'memory': 'kinematic',
     'backbone': {'bilinear': {'stiffness': 4.0e7, 'yield_force': 2.0e4,
                               'hardening_ratio': -0.05, 'residual_force': 1.0e4}}},
    {'model': 'bouc_wen', 'stiffness': 4.0e7, 'post_yield_ratio': 0.05, 'exponent': 1.0,
     'beta': 1000.0, 'gamma': 1000.0, 'delta_nu': 2.0e-3, 'delta_eta': 2.0e-3},
], ids=['elastic', 'epp', 'bilinear-softening', 'pushover-kinematic', 'bouc-wen'])
def test_first_story_at_a_site_equals_the_numerical_run(tmp_path: Path,
                                                        story_model: dict | None) -> None:
    numerical = run(building(story_model=story_model), tmp_path, 'numerical')
    hybrid = run(building(experimental=(0,), story_model=story_model), tmp_path, 'hybrid')
    x_num = numerical.session.history.displacement
    x_hyb = hybrid.session.history.displacement
    assert hybrid.session.state is State.FINISHED
    scale = float(np.max(np.abs(x_num)))
    assert scale > 1e-3
    # The same model, evaluated at the site instead of the computer: equal up to round-off.
    np.testing.assert_allclose(x_hyb, x_num, rtol=0.0, atol=1e-10 * scale)
    np.testing.assert_allclose(hybrid.session.history.restoring_force,
                               numerical.session.history.restoring_force, rtol=0.0,
                               atol=1e-9 * float(np.max(np.abs(
                                   numerical.session.history.restoring_force))))
    if story_model is not None:  # the story really yielded: its elastic force is far above
        story_force = STORIES[0] * x_num[:, 0]
        assert np.max(np.abs(story_force)) > 1.5 * 2.0e4


@pytest.mark.parametrize('scheme', ['newmark_explicit', 'alpha_os', 'linear_acceleration'])
def test_two_sites_equal_the_numerical_run_and_replay_from_the_bag(tmp_path: Path,
                                                                   scheme: str) -> None:
    # (linear_acceleration iterates: every site and numerical element sees (step, iteration))
    numerical = run(building(scheme=scheme), tmp_path, 'numerical')
    two_sites = run(building(experimental=(0, 2), scheme=scheme), tmp_path, 'two-sites')
    assert two_sites.session.state is State.FINISHED
    scale = float(np.max(np.abs(numerical.session.history.displacement)))
    np.testing.assert_allclose(two_sites.session.history.displacement,
                               numerical.session.history.displacement, rtol=0.0,
                               atol=1e-10 * scale)
    replayed = replay_bag(two_sites.bag_path)
    assert replayed.state is State.FINISHED
    np.testing.assert_array_equal(replayed.history.displacement,
                                  two_sites.session.history.displacement)


def test_bi_directional_motion_equals_two_one_directional_runs(tmp_path: Path) -> None:
    record_x = smooth_record()
    record_y = smooth_record()
    record_y['inline']['acceleration'] = (
        0.7 * np.roll(np.array(record_y['inline']['acceleration']), 300)).tolist()

    def structure() -> dict:
        return {'dof_names': ['x', 'y'], 'mass': [1.0e4, 1.0e4],
                'damping': {'modal': [0.02, 0.05]},
                'elements': [{'type': 'spring', 'dofs': ['x'], 'stiffness': 2.0e6},
                             {'type': 'spring', 'dofs': ['y'], 'stiffness': 5.0e6}]}

    both = {'test': {'id': 'bi', 'dt': 0.005}, 'structure': structure(),
            'ground_motion': [{**record_x, 'name': 'H1', 'influence': [1, 0]},
                              {**record_y, 'name': 'H2', 'influence': [0, 1]}]}
    result = run(both, tmp_path, 'both')
    x_both = result.session.history.displacement
    for j, (record, influence) in enumerate(((record_x, [1, 0]), (record_y, [0, 1]))):
        single = {'test': {'id': f'one{j}', 'dt': 0.005},
                  'structure': {**structure(), 'influence': influence},
                  'ground_motion': record}
        alone = run(single, tmp_path, f'one{j}').session.history.displacement
        # (the modal damping matrix is diagonal here: the DOFs are uncoupled)
        np.testing.assert_allclose(x_both[:, j], alone[:, j], rtol=0.0,
                                   atol=1e-12 * np.max(np.abs(alone[:, j])))
        assert np.max(np.abs(alone[:, j])) > 1e-3
    summary = result.summary
    assert [item['name'] for item in summary['ground_motion']] == ['H1', 'H2']


def test_frame_with_beam_columns_has_the_closed_form_lateral_stiffness(tmp_path: Path) -> None:
    # A fixed-base portal: two columns (h, I_c) and a beam (L, I_b); joint rotations and
    # vertical DOFs are massless and condensed; the beam is axially rigid (one sway DOF).
    E, A, h, span, Ic, Ib = 2.0e11, 10.0, 3.0, 6.0, 1.0e-4, 2.0e-4  # (A: axially ~rigid)
    raw = {
        'test': {'id': 'portal', 'dt': 0.001, 'duration': 0.5},
        'structure': {
            'dof_names': ['u', 'v1', 'r1', 'v2', 'r2'],
            'mass': [1.0e4, 0.0, 0.0, 0.0, 0.0],
            'influence': [1, 0, 0, 0, 0],
            'damping': {'ratio': 0.02},
            'elements': [
                {'type': 'beam_column', 'dofs': [None, None, None, 'u', 'v1', 'r1'],
                 'coordinates': [[0, 0], [0, h]], 'E': E, 'A': A, 'I': Ic},
                {'type': 'beam_column', 'dofs': [None, None, None, 'u', 'v2', 'r2'],
                 'coordinates': [[span, 0], [span, h]], 'E': E, 'A': A, 'I': Ic},
                {'type': 'beam_column', 'dofs': ['u', 'v1', 'r1', 'u', 'v2', 'r2'],
                 'coordinates': [[0, h], [span, h]], 'E': E, 'A': A, 'I': Ib}]},
        'ground_motion': smooth_record(duration=0.5),
    }
    definition = from_dict(raw, source='portal.yaml', base_dir=tmp_path)
    assert definition.dof_names == ('u',)
    kc, kb = Ic / h, Ib / span
    # Slope-deflection, columns axially rigid: K = 12 E I_c / h³ · (k_c + 6 k_b)/(2 k_c + 3 k_b)
    closed = 12 * E * Ic / h**3 * (kc + 6 * kb) / (2 * kc + 3 * kb)
    assert definition.initial_stiffness[0, 0] == pytest.approx(closed, rel=1e-5)


def test_rigid_link_setup_geometry() -> None:
    linear = RigidLinkTwoActuators([-0.5, 0.7])
    basic = np.array([0.01, 0.002])
    np.testing.assert_allclose(linear.actuator_targets(basic), [0.01 - 0.001, 0.01 + 0.0014])
    np.testing.assert_allclose(linear.basic_displacement(linear.actuator_targets(basic)), basic)
    # Forces: the translation sees f1 + f2, the rotation a1 f1 + a2 f2 (virtual work).
    np.testing.assert_allclose(linear.basic_force(np.array([3.0, 5.0]), basic),
                               [8.0, -1.5 + 3.5])
    exact = RigidLinkTwoActuators([-0.5, 0.7], geometry='nonlinear', actuator_length=2.0)
    basic = np.array([0.03, 0.05])
    strokes = exact.actuator_targets(basic)
    # Independent geometry: the pin at (-L, a) and the attachment point after the motion.
    for a, stroke in zip((-0.5, 0.7), strokes):
        point = np.array([basic[0] + a * math.sin(basic[1]), a * math.cos(basic[1])])
        assert stroke == pytest.approx(np.linalg.norm(point - np.array([-2.0, a])) - 2.0,
                                       abs=1e-15)
    np.testing.assert_allclose(exact.basic_displacement(strokes), basic, atol=1e-13)
    step = 1e-7
    numeric = np.column_stack([(exact.actuator_targets(basic + step * e)
                                - exact.actuator_targets(basic - step * e)) / (2 * step)
                               for e in np.eye(2)])
    np.testing.assert_allclose(exact.jacobian(basic), numeric, rtol=1e-7, atol=1e-9)
    # Small motions: the exact geometry tends to the linear one.
    tiny = np.array([1e-6, 1e-6])
    np.testing.assert_allclose(exact.actuator_targets(tiny), linear.actuator_targets(tiny),
                               rtol=1e-5)


def test_rigid_link_site_equals_the_numerical_springs(tmp_path: Path) -> None:
    # Two equal actuator springs k at ±a: translation stiffness 2k, rotation 2 k a², no coupling.
    k, a = 2.0e6, 0.4

    def raw(experimental: bool) -> dict:
        if experimental:
            elements = [{'type': 'experimental', 'name': 'column', 'site': 'lab',
                         'dofs': ['u', 'theta'], 'setup': {'type': 'rigid_link_2',
                                                           'offsets': [-a, a]},
                         'initial_stiffness': [[2 * k, 0.0], [0.0, 2 * k * a * a]]}]
        else:
            elements = [{'type': 'spring', 'dofs': ['u'], 'stiffness': 2 * k},
                        {'type': 'spring', 'dofs': ['theta'], 'stiffness': 2 * k * a * a}]
        data = {'test': {'id': 'link', 'dt': 0.002},
                'structure': {'dof_names': ['u', 'theta'], 'mass': [5.0e3, 60.0],
                              'damping': {'ratio': 0.02},
                              'elements': elements},
                'ground_motion': [{**smooth_record(), 'influence': [1, 0]},
                                  {**smooth_record(), 'influence': [0, 0.3]}]}
        if experimental:
            data['sites'] = {'lab': {'specimen': {'elements': [
                {'model': 'elastic', 'stiffness': k}, {'model': 'elastic', 'stiffness': k}]}}}
        return data

    numerical = run(raw(False), tmp_path, 'springs').session.history
    hybrid = run(raw(True), tmp_path, 'link').session.history
    scale = np.max(np.abs(numerical.displacement), axis=0)
    assert np.all(scale > 1e-5)
    np.testing.assert_allclose(hybrid.displacement, numerical.displacement, rtol=0.0,
                               atol=1e-9 * float(np.max(scale)))


def test_setup_config_errors() -> None:
    assert isinstance(setup_from_config(None, 3, 'x'), OneToOneSetup)
    with pytest.raises(ConfigError, match=r'^t\.yaml: e\.setup\.type: must be one of'):
        setup_from_config({'type': 'three_actuators'}, 2, 't.yaml: e.setup')
    with pytest.raises(ConfigError, match=r'needs an element with 2 DOFs'):
        setup_from_config({'type': 'rigid_link_2', 'offsets': [0, 1]}, 3, 't.yaml: e.setup')
    with pytest.raises(ConfigError, match=r'offsets must be two distinct'):
        setup_from_config({'type': 'rigid_link_2', 'offsets': [1, 1]}, 2, 't.yaml: e.setup')
    with pytest.raises(ConfigError, match=r'needs a positive actuator_length'):
        setup_from_config({'type': 'rigid_link_2', 'offsets': [0, 1], 'geometry': 'nonlinear'},
                          2, 't.yaml: e.setup')


@pytest.mark.parametrize(('change', 'pattern'), [
    (lambda raw: raw['structure']['elements'][0].update(type='truss'),
     r"elements\.0\.type: must be one of"),
    (lambda raw: raw['structure']['elements'][0].update(site='lab-1'),
     r'elements\.0\.site: must be a name of letters'),
    (lambda raw: raw['structure']['elements'][0].pop('initial_stiffness'),
     r'elements\.0\.initial_stiffness: is required'),
    (lambda raw: raw['structure']['elements'][1].update(dofs=['u1', 'u9']),
     r"elements\.1\.dofs: 'u9' is not a DOF name"),
    (lambda raw: raw['structure'].update(mass=[0.0, 2.0e4, 1.5e4]),
     r'structure\.mass: DOF u1 is massless but connected'),
    (lambda raw: raw['structure'].update(initial_stiffness=1.0e6),
     r'structure\.initial_stiffness: must not be given with elements'),
    (lambda raw: raw['structure'].update(damping={'rayleigh': {'modes': [1, 4],
                                                               'ratios': [0.05, 0.05]}}),
     r'structure\.damping: modes: \[1, 4\] asked, the structure has 3 modes'),
    (lambda raw: raw.update(ground_motion=[smooth_record()]),
     r'ground_motion\.0\.influence: is required'),
    (lambda raw: raw['sites'].update(lab_1={}),
     r'sites\.lab_1: no experimental element is at this site \(sites: lab1\)'),
])
def test_model_config_errors_are_one_line(tmp_path: Path, change, pattern: str) -> None:
    raw = building(experimental=(0,))
    raw['structure']['elements'][1]['name'] = 'story2'
    change(raw)
    with pytest.raises(ConfigError, match=r'^b\.yaml: .*' + pattern) as info:
        from_dict(raw, source='b.yaml', base_dir=tmp_path)
    assert '\n' not in str(info.value)


def test_site_without_specimen_is_refused_for_a_simulated_run(tmp_path: Path) -> None:
    raw = building(experimental=(0,))
    raw['sites']['lab1'] = {}
    definition = from_dict(raw, source='b.yaml', base_dir=tmp_path)
    with pytest.raises(ConfigError, match=r'^b\.yaml: sites\.lab1\.specimen: section is '):
        run_offline(definition, tmp_path / 'run', figures=False)
    assert not (tmp_path / 'run').exists()


# -- the coordinator's protocol, site by site ---------------------------------------------------
def coordinator() -> tuple[SiteCoordinator, Command]:
    definition = from_dict(building(experimental=(0, 2)), source='b.yaml', base_dir=Path('.'))
    command = Command(test_id='t', step=5, test_time=0.025, dof_names=('u1', 'u2', 'u3'),
                      target_displacement=(0.001, 0.002, 0.004))
    return SiteCoordinator(definition.model), command


def answer(command: Command, force: tuple[float, ...], *, status=FeedbackStatus.OK,
           step: int | None = None) -> Feedback:
    return Feedback(test_id=command.test_id, step=command.step if step is None else step,
                    measured_displacement=command.target_displacement, restoring_force=force,
                    status=status, message='' if status is FeedbackStatus.OK else 'stroke')


def test_coordinator_advances_only_when_every_site_answered() -> None:
    sites, command = coordinator()
    sent = dict(sites.dispatch(command))
    assert set(sent) == {'lab1', 'lab3'}
    assert sent['lab1'].target_displacement == (0.001,)
    assert sent['lab3'].target_displacement == pytest.approx((0.002,))  # drift u3 - u2
    verdict, done = sites.on_feedback('lab1', answer(sent['lab1'], (40.0e3,)))
    assert verdict is Verdict.ACCEPTED and done is None
    verdict, done = sites.on_feedback('lab1', answer(sent['lab1'], (40.0e3,)))
    assert verdict is Verdict.DUPLICATE and done is None
    verdict, done = sites.on_feedback('lab3', answer(sent['lab3'], (1.0,), step=4))
    assert verdict is Verdict.STALE and done is None
    assert [site for site, _ in sites.resend(command)] == ['lab3']
    verdict, done = sites.on_feedback('lab3', answer(sent['lab3'], (60.0e3,)))
    assert verdict is Verdict.ACCEPTED and done is not None
    # numerical story 2 (k2 (u2 - u1) = 35 kN) + measured stories 1 and 3
    expected = np.array([40.0e3 - 35.0e3, 35.0e3 - 60.0e3, 60.0e3])
    np.testing.assert_allclose(done.restoring_force, expected)
    assert sites.ignored_total == 2


def test_coordinator_passes_a_site_limit_on_and_resends_to_that_site_only() -> None:
    sites, command = coordinator()
    sent = dict(sites.dispatch(command))
    sites.on_feedback('lab1', answer(sent['lab1'], (40.0e3,)))
    verdict, refused = sites.on_feedback('lab3', answer(sent['lab3'], (0.0,),
                                                        status=FeedbackStatus.LIMIT))
    assert verdict is Verdict.REFUSED
    assert refused is not None and refused.status is FeedbackStatus.LIMIT
    assert refused.message == 'site lab3: stroke'
    assert [site for site, _ in sites.resend(command)] == ['lab3']


def test_shipped_two_site_example_runs_and_yields(tmp_path: Path) -> None:
    example = (Path(__file__).resolve().parents[2] / 'src' / 'pd_integrator' / 'config'
               / 'three_story_two_sites.yaml')
    definition = load_test_file(example, {'duration': 3.0})
    assert definition.site_names == ('lab1', 'lab3')
    result = run_offline(definition, tmp_path / 'run', figures=False)
    assert result.session.state is State.FINISHED
    history = result.session.history
    # story 1 yields (bilinear, F_y = 150 kN): its force stays near the backbone
    story1 = history.restoring_force[:, 0] + history.restoring_force[:, 1] + \
        history.restoring_force[:, 2]
    assert np.max(np.abs(story1)) < 1.6e5
    assert np.max(np.abs(4.0e7 * history.displacement[:, 0])) > 1.6e5


def test_replay_of_a_pushover_spring_model_needs_only_the_bag(tmp_path: Path,
                                                              monkeypatch) -> None:
    # A numerical spring whose backbone is a CSV next to the test file: the bag's definition
    # names it by an absolute path, so the replay works from any folder.
    (tmp_path / 'curve.csv').write_text('d,f\n0,0\n0.01,4.0e5\n0.05,4.5e5\n', encoding='utf-8')
    raw = building(story_model={'model': 'pushover', 'backbone': {'csv': 'curve.csv'}})
    result = run(raw, tmp_path, 'pushover')
    assert result.session.state is State.FINISHED
    monkeypatch.chdir(tmp_path.parent)
    replayed = replay_bag(result.bag_path)
    np.testing.assert_array_equal(replayed.history.displacement,
                                  result.session.history.displacement)


def write_at2(path: Path, values: np.ndarray, dt: float) -> Path:
    """A PEER-format record (4 header lines, NPTS/DT on line 4, values in g, 5 per line)."""
    lines = ['PEER NGA STRONG MOTION DATABASE RECORD', 'SYNTHETIC TEST RECORD, COMPONENT',
             'ACCELERATION TIME SERIES IN UNITS OF G',
             f'NPTS= {values.size:7d}, DT= {dt:.4f} SEC']
    for start in range(0, values.size, 5):
        lines.append('  '.join(f'{v: .7E}' for v in values[start:start + 5]))
    path.write_text('\n'.join(lines) + '\n', encoding='utf-8')
    return path


def test_two_horizontal_at2_components_load_with_their_influence(tmp_path: Path) -> None:
    t = np.arange(0.0, 2.0, 0.01)
    h1 = 0.1 * np.sin(2 * np.pi * 1.5 * t)
    h2 = 0.05 * np.cos(2 * np.pi * 2.5 * t) * np.minimum(t, 1.0)
    write_at2(tmp_path / 'STATION_H1.AT2', h1, 0.01)
    write_at2(tmp_path / 'STATION_H2.AT2', h2, 0.01)
    raw = {'test': {'id': 'two-at2', 'dt': 0.01},
           'structure': {'dof_names': ['x', 'y', 'r'], 'mass': [1.0e4, 1.0e4, 2.0e3],
                         'damping': {'ratio': 0.02},
                         'elements': [{'type': 'spring', 'dofs': ['x'], 'stiffness': 2.0e6},
                                      {'type': 'spring', 'dofs': ['y'], 'stiffness': 3.0e6},
                                      {'type': 'spring', 'dofs': ['r'], 'stiffness': 5.0e5}]},
           'ground_motion': [
               {'name': 'H1', 'file': 'STATION_H1.AT2', 'influence': [1, 0, 0]},
               {'name': 'H2', 'file': 'STATION_H2.AT2', 'influence': [0, 1, 0]}]}
    definition = from_dict(raw, source='two.yaml', base_dir=tmp_path)
    loads = definition.loads()
    g = 9.81
    # (the files hold 8 significant digits)
    np.testing.assert_allclose(loads[:200, 0], -1.0e4 * h1 * g, rtol=1e-7, atol=1e-6)
    np.testing.assert_allclose(loads[:200, 1], -1.0e4 * h2 * g, rtol=1e-7, atol=1e-6)
    assert not loads[:, 2].any()
    report = definition.modal_report()
    assert 'H1' in report and 'H2' in report
    # Resolved (bag) form reads back to the same loads.
    again = from_json(definition.to_json())
    np.testing.assert_array_equal(again.loads(), loads)


def two_site_dispatcher(tmp_path: Path) -> tuple[Any, Any, list[tuple[str, Command]]]:
    """A started session of the two-site building, its dispatcher and the commands it sent."""
    definition = from_dict(building(experimental=(0, 2)), source='b.yaml', base_dir=tmp_path)
    session = Session(definition)
    sent: list[tuple[str, Command]] = []
    dispatcher = StepDispatcher(session, lambda site, command: sent.append((site, command)))
    dispatcher.start()
    return session, dispatcher, sent


def test_an_emergency_hold_ignores_late_feedback_and_resume_resends_to_the_sites(
        tmp_path: Path) -> None:
    session, dispatcher, sent = two_site_dispatcher(tmp_path)
    assert [site for site, _ in sent] == ['lab1', 'lab3']
    session.hold('emergency stop: test')
    assert session.state is State.HOLDING
    for site, command in sent:
        force = (0.0,) * len(command.target_displacement)
        dispatcher.on_feedback(site, answer(command, force))
    assert session.state is State.HOLDING and session.committed_step == -1
    sent.clear()
    dispatcher.resume()
    # Both sites answered while the test held: not taken; on resume step 0 goes to both
    # sites again (they answer a repeated step with the same answer, without moving).
    assert sorted(site for site, _ in sent) == ['lab1', 'lab3']
    assert all(command.step == 0 for _, command in sent)
    resent = list(sent)
    sent.clear()
    for site, command in resent:
        dispatcher.on_feedback(site, answer(command, (0.0,) * len(command.target_displacement)))
    assert session.state is State.RUNNING and session.committed_step == 0
    assert {command.step for _, command in sent} == {1}


def test_a_site_limit_holds_and_resume_resends_to_the_sites_still_owing(
        tmp_path: Path) -> None:
    session, dispatcher, sent = two_site_dispatcher(tmp_path)
    step0 = dict(sent)
    sent.clear()
    dispatcher.on_feedback('lab1', answer(step0['lab1'], (0.0,), status=FeedbackStatus.LIMIT))
    assert session.state is State.HOLDING
    assert session.message.endswith('site lab1: stroke')
    dispatcher.on_feedback('lab3', answer(step0['lab3'], (0.0,)))  # arrives while holding
    assert sent == []
    dispatcher.resume()
    assert sorted(site for site, _ in sent) == ['lab1', 'lab3']
    for site, command in list(sent):
        dispatcher.on_feedback(site, answer(command, (0.0,)))
    assert session.committed_step == 0 and session.state is State.RUNNING


@pytest.mark.parametrize('scheme', ['newmark_explicit', 'alpha_os', 'generalized_alpha_os',
                                    'cr', 'kr_alpha', 'linear_acceleration'])
def test_sparse_path_of_a_large_model_equals_the_dense_path(tmp_path: Path, monkeypatch,
                                                            scheme: str) -> None:
    """An 80-story building (sparse matrices) gives the dense computation's response."""
    n = 80
    names = [f'u{i + 1}' for i in range(n)]
    elements = [{'type': 'experimental', 'site': 'lab', 'dofs': ['u1'],
                 'initial_stiffness': 2.0e8}]
    elements += [{'type': 'story', 'dofs': [names[i - 1], names[i]], 'stiffness': 2.0e8}
                 for i in range(1, n)]
    raw = {'test': {'id': 'tall', 'scheme': scheme, 'dt': 0.002, 'duration': 0.6},
           'structure': {'dof_names': names, 'mass': [1.0e4] * n, 'elements': elements,
                         'damping': {'rayleigh': {'modes': [1, 5], 'ratios': [0.05, 0.05]}}},
           'ground_motion': smooth_record(duration=0.6),
           'sites': {'lab': {'specimen': {'elements': [
               {'model': 'bilinear', 'stiffness': 2.0e8, 'yield_force': 2.0e4,
                'hardening_ratio': 0.05}]}}}}
    assert n >= scheme_linalg.SPARSE_MIN_DOF
    sparse = run(raw, tmp_path, 'sparse').session.history.displacement
    monkeypatch.setattr(scheme_linalg, 'SPARSE_MIN_DOF', 10**6)
    dense = run(raw, tmp_path, 'dense').session.history.displacement
    scale = float(np.max(np.abs(dense)))
    assert scale > 1e-4
    np.testing.assert_allclose(sparse, dense, rtol=0.0, atol=1e-9 * scale)


def test_numerical_springs_trial_from_the_committed_state_and_commit_with_the_step() -> None:
    """An iterating scheme's trials do not accumulate plastic deformation in a numerical
    spring: each trial starts from the committed state (as an OpenSees element does), and
    only the committed step's last trial is kept."""
    raw = {
        'test': {'id': 'spring', 'scheme': 'average_acceleration', 'dt': 0.01},
        'structure': {'dof_names': ['u1'], 'mass': 1.0, 'damping': {'ratio': 0.0},
                      'elements': [{'type': 'nonlinear_spring', 'dofs': ['u1'],
                                    'model': {'model': 'epp', 'stiffness': 1.0,
                                              'yield_force': 1.0}}]},
        'ground_motion': {'inline': {'dt': 0.01, 'acceleration': [0.0, 0.0]}, 'units': 'm/s2'},
    }
    definition = from_dict(raw, source='spring.yaml', base_dir=Path('.'))
    sites = SiteCoordinator(definition.model)

    def force(step: int, iteration: int, x: float) -> float:
        command = Command(test_id='t', step=step, test_time=0.0, dof_names=('u1',),
                          target_displacement=(x,), iteration=iteration)
        assert sites.dispatch(command) == []  # no site: fully numerical
        return float(sites.complete().restoring_force[0])

    assert force(0, 0, 0.0) == 0.0
    sites.commit()
    assert force(1, 0, 3.0) == 1.0  # a trial beyond yield
    # The next iteration starts again from the committed (virgin) state: elastic, 0.5.
    # (Committing every trial would have left 2.0 of plastic deformation: force -1.0.)
    assert force(1, 1, 0.5) == 0.5
    sites.commit()  # the integrator committed step 1 at its last trial, 0.5
    assert force(2, 0, 0.25) == 0.25
    assert force(2, 1, 2.5) == 1.0
    sites.commit()  # committed at 2.5: 1.5 of plastic deformation
    assert force(3, 0, 1.5) == 0.0


@pytest.mark.parametrize(('dofs', 'relative'), [
    ([0, 2], [-1, 1]),  # one grounded basic DOF, one relative to DOF 1
    ([1], [-1]),  # grounded
    ([2, 2, 0], [1, 1, -1]),  # a DOF twice: each force added, as np.add.at adds it
    ([0, 1], [3, 3]),  # two basic DOFs relative to the same DOF
])
def test_an_elements_ends_gather_and_scatter_as_the_index_arithmetic_says(
        dofs: list[int], relative: list[int]) -> None:
    """``basic = x[dofs] - x[relative]`` (0 for the ground); the forces go back with signs."""
    spring = NonlinearSpring(dofs=np.array(dofs), relative=np.array(relative))
    x = np.array([0.1, -0.7, 2.3, 0.45])
    expected = [x[d] - (x[r] if r >= 0 else 0.0) for d, r in zip(dofs, relative, strict=True)]
    assert spring.basic(x).tolist() == expected
    force = np.array([3.0, -5.5, 7.25])[:len(dofs)]
    into = np.array([1.0, 2.0, 4.0, 8.0])
    spring.scatter(force, into)
    reference = np.array([1.0, 2.0, 4.0, 8.0])
    for f, d in zip(force, dofs, strict=True):
        reference[d] += f
    for f, r in zip(force, relative, strict=True):
        if r >= 0:
            reference[r] -= f
    assert into.tolist() == reference.tolist()
