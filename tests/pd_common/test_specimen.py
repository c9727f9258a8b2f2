"""Tests of pd_specimen_sim.core.specimen and pd_specimen_sim.core.config."""

from __future__ import annotations

import copy
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pd_common.specimen import (
    BilinearKinematic,
    Elastic,
    ElasticPerfectlyPlastic,
    HysteresisError,
    PushoverHysteresis,
    Specimen,
    SpecimenConfigError,
    SpecimenError,
    SpecimenServer,
    bilinear_backbone,
    server_from_config,
    specimen_from_config,
)

# --- Specimen ---------------------------------------------------------------------------------


def test_independent_forces_and_stiffness() -> None:
    spec = Specimen([Elastic(1.0e5), ElasticPerfectlyPlastic(2.0e5, 1000.0)],
                    dof_names=['x', 'y'])
    np.testing.assert_allclose(spec.restoring_force(np.array([0.01, 0.002])), [1000.0, 400.0])
    # Second element yields at 0.005 m.
    np.testing.assert_allclose(spec.restoring_force([0.01, 0.01]), [1000.0, 1000.0])
    np.testing.assert_allclose(spec.initial_stiffness_matrix(), [[1.0e5, 0.0], [0.0, 2.0e5]])
    assert spec.n_dof == 2 and spec.dof_names == ('x', 'y')


def test_shear_building_forces_and_stiffness() -> None:
    spec = Specimen([Elastic(3.0e5), Elastic(2.0e5), Elastic(1.0e5)], topology='shear_building')
    x = np.array([0.01, 0.03, 0.06])
    # Drifts 0.01, 0.02, 0.03 -> story forces 3000, 4000, 3000.
    np.testing.assert_allclose(spec.restoring_force(x), [-1000.0, 1000.0, 3000.0])
    k = np.array([[5.0e5, -2.0e5, 0.0], [-2.0e5, 3.0e5, -1.0e5], [0.0, -1.0e5, 1.0e5]])
    np.testing.assert_allclose(spec.initial_stiffness_matrix(), k)
    np.testing.assert_allclose(k @ x, [-1000.0, 1000.0, 3000.0])
    assert spec.dof_names == ('dof0', 'dof1', 'dof2')


def test_shear_building_with_yielding_story() -> None:
    spec = Specimen([ElasticPerfectlyPlastic(1.0e5, 500.0), Elastic(1.0e5)],
                    topology='shear_building')
    # Story 0 drift 0.01 -> capped at 500; story 1 drift 0.005 -> 500.
    np.testing.assert_allclose(spec.restoring_force([0.01, 0.015]), [0.0, 500.0], atol=1e-9)


def test_commit_revert_reset() -> None:
    spec = Specimen([ElasticPerfectlyPlastic(1.0e5, 500.0)])
    np.testing.assert_allclose(spec.restoring_force([0.02]), [500.0])
    spec.commit()
    np.testing.assert_allclose(spec.restoring_force([0.0]), [-500.0])
    spec.revert_to_last_commit()
    np.testing.assert_allclose(spec.committed_restoring_force(), [500.0])
    # Unloading from the committed (0.02, 500): plastic displacement 0.015.
    np.testing.assert_allclose(spec.restoring_force([0.016]), [100.0])
    spec.commit()
    spec.reset()
    np.testing.assert_allclose(spec.committed_restoring_force(), [0.0])
    np.testing.assert_allclose(spec.restoring_force([0.001]), [100.0])


def test_sdof_returns_array() -> None:
    out = Specimen([Elastic(2.0)]).restoring_force(np.array([3.0]))
    assert isinstance(out, np.ndarray) and out.shape == (1,) and out[0] == 6.0


@pytest.mark.parametrize('x', [[0.1], [0.1, 0.2, 0.3], [[0.1, 0.2]], [0.1, float('nan')],
                               [float('inf'), 0.0], ['a', 0.0]])
def test_restoring_force_validation(x: Any) -> None:
    spec = Specimen([Elastic(1.0), Elastic(1.0)])
    with pytest.raises(SpecimenError, match='specimen: displacement'):
        spec.restoring_force(x)


def test_element_errors_propagate_as_specimen_errors() -> None:
    spec = Specimen([PushoverHysteresis(bilinear_backbone(1.0, 1.0, 0.0, 2.0), beyond='error')])
    with pytest.raises(HysteresisError):
        spec.restoring_force([3.0])


@pytest.mark.parametrize(('kwargs', 'message'), [
    ({'elements': []}, 'at least one element'),
    ({'elements': [Elastic(1.0)], 'topology': 'frame'}, 'topology must be one of'),
    ({'elements': [Elastic(1.0)], 'dof_names': ['a', 'b']}, '1 elements but 2 DOF names'),
    ({'elements': [Elastic(1.0), Elastic(1.0)], 'dof_names': ['a', 'a']}, 'unique'),
    ({'elements': [1.0]}, r'elements\[0\] must be a HysteresisModel'),
])
def test_specimen_validation(kwargs: dict[str, Any], message: str) -> None:
    with pytest.raises(SpecimenError, match=message):
        Specimen(**kwargs)


def test_shared_element_is_rejected() -> None:
    element = Elastic(1.0)
    with pytest.raises(SpecimenError, match='more than once'):
        Specimen([element, element])


# --- config -----------------------------------------------------------------------------------

SECTION: dict[str, Any] = {
    'topology': 'independent',
    'elements': [
        {'model': 'pushover',
         'backbone': {'bilinear': {'stiffness': 312559.0, 'yield_force': 12000.0,
                                   'hardening_ratio': 0.01, 'max_displacement': 1.0}},
         'unloading_stiffness': None,
         'beyond_last_point': 'extrapolate'},
        {'model': 'elastic', 'stiffness': 1.0e5},
        {'model': 'epp', 'stiffness': 1.0e5, 'yield_force': 2.0e3},
        {'model': 'bilinear', 'stiffness': 1.0e5, 'yield_force': 2.0e3, 'hardening_ratio': 0.02},
    ],
}
DOFS = ['a', 'b', 'c', 'd']


def build(section: Any, tmp_path: Path, dofs: list[str] = DOFS) -> Specimen:
    return specimen_from_config(section, base_dir=tmp_path, source='test.yaml', dof_names=dofs)


def test_config_builds_every_model(tmp_path: Path) -> None:
    spec = build(SECTION, tmp_path)
    kinds = [type(el) for el in spec.elements]
    assert kinds == [PushoverHysteresis, Elastic, ElasticPerfectlyPlastic, BilinearKinematic]
    assert spec.topology == 'independent' and spec.dof_names == tuple(DOFS)
    np.testing.assert_allclose(np.diag(spec.initial_stiffness_matrix()),
                               [312559.0, 1.0e5, 1.0e5, 1.0e5])
    # x = 0.1: pushover 12000 + 0.01 * (312559 * 0.1 - 12000) = 12192.559;
    # elastic 1e4; EPP 2000; bilinear 2000 + 0.02e5 * (0.1 - 0.02) = 2160.
    np.testing.assert_allclose(spec.restoring_force([0.1] * 4),
                               [12192.559, 1.0e4, 2000.0, 2160.0])


def test_config_pushover_csv_and_opensees_relative_paths(tmp_path: Path) -> None:
    (tmp_path / 'curves').mkdir()
    (tmp_path / 'curves' / 'c.csv').write_text('d,f\n0.01,1000\n0.03,1500\n')
    (tmp_path / 'DFree.txt').write_text('0 -0.001\n1 0.01\n2 0.02\n')
    (tmp_path / 'RBase.txt').write_text('0 9\n1 -50000\n2 -60000\n')
    section = {
        'topology': 'shear_building',
        'elements': [
            {'model': 'pushover', 'backbone': {'csv': 'curves/c.csv'},
             'unloading_stiffness': 2.0e5, 'beyond_last_point': 'plateau'},
            {'model': 'pushover',
             'backbone': {'opensees': {'displacement_file': 'DFree.txt',
                                       'reaction_file': str(tmp_path / 'RBase.txt'),
                                       'skip_rows': 1, 'force_scale': 0.02}}},
        ],
    }
    spec = build(section, tmp_path, ['s1', 's2'])
    first, second = spec.elements
    assert isinstance(first, PushoverHysteresis) and isinstance(second, PushoverHysteresis)
    assert first.unloading_stiffness == 2.0e5 and first.beyond == 'plateau'
    np.testing.assert_allclose(second.backbone.force, [0.0, 1000.0, 1200.0])
    np.testing.assert_allclose(spec.initial_stiffness_matrix(),
                               [[2.0e5, -1.0e5], [-1.0e5, 1.0e5]])


DELETE = object()


def _mutate(path: str, value: Any) -> dict[str, Any]:
    """Deep copy of SECTION with ``path`` (dot/int keys) set, or deleted if value is DELETE."""
    section = copy.deepcopy(SECTION)
    keys: list[Any] = [int(k) if k.isdigit() else k for k in path.split('.')]
    node: Any = section
    for key in keys[:-1]:
        node = node[key]
    if value is DELETE:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return section


@pytest.mark.parametrize(('path', 'value', 'message'), [
    ('elements.2.yield_force', -3,
     (r'^test\.yaml: specimen\.elements\[2\]\.yield_force: must be a positive finite number, '
      r'got -3$')),
    ('elements.1.stiffness', float('nan'), r'elements\[1\].stiffness: must be a positive'),
    ('elements.1.stiffness', '1e5', r"stiffness: must be .*got '1e5' \(a string"),
    ('elements.1.stiffness', True, r'elements\[1\].stiffness: must be a positive'),
    ('elements.1.stifness', 1.0, r"specimen.elements\[1\]: unknown key 'stifness'"),
    ('elements.2.yield_force', DELETE, r"specimen.elements\[2\]: missing key 'yield_force'"),
    ('elements.3.hardening_ratio', 1.5, r'elements\[3\].hardening_ratio: must be in \(-1, 1\)'),
    ('elements.3.residual_force', 10.0,
     r'elements\[3\]: BilinearKinematic: residual_force needs a negative hardening_ratio'),
    ('elements.0.memory', 'isotropic', r'elements\[0\].memory: must be one of none, kinematic'),
    ('elements.1.model', 'spring', r'elements\[1\].model: must be one of'),
    ('elements.1.model', DELETE, r"elements\[1\]: missing key 'model'"),
    ('elements.1', 'elastic', r'elements\[1\]: must be a mapping'),
    ('elements.0.beyond_last_point', 'clamp', r'elements\[0\].beyond_last_point: must be one'),
    ('elements.0.unloading_stiffness', 0.0, r'elements\[0\].unloading_stiffness: must be a pos'),
    ('elements.0.backbone.csv', 'x.csv', r'elements\[0\].backbone: needs exactly one of'),
    ('elements.0.backbone.spline', 'x', r"elements\[0\].backbone: unknown key 'spline'"),
    ('elements.0.backbone.bilinear.yield_force', 0, r'backbone.bilinear.yield_force: must be'),
    ('elements.0.backbone.bilinear.max_displacement', 0.01,
     r'backbone.bilinear: bilinear backbone: max_displacement .* must exceed'),
    ('elements', {'a': 1}, 'specimen.elements: must be a list'),
    ('topology', 'frame', 'specimen.topology: must be one of'),
    ('colour', 'red', "specimen: unknown key 'colour'"),
    ('elements', [{'model': 'elastic', 'stiffness': 1.0}], r'specimen.elements: 1 elements but 4'),
])
def test_config_errors_name_the_parameter(tmp_path: Path, path: str, value: Any,
                                          message: str) -> None:
    with pytest.raises(SpecimenConfigError, match=message) as info:
        build(_mutate(path, value), tmp_path)
    text = str(info.value)
    assert text.startswith('test.yaml: specimen') and '\n' not in text


def test_config_backbone_file_errors(tmp_path: Path) -> None:
    section = {'elements': [{'model': 'pushover', 'backbone': {'csv': 'missing.csv'}}]}
    with pytest.raises(SpecimenConfigError,
                       match=r'specimen.elements\[0\].backbone.csv: backbone .*missing.csv'):
        build(section, tmp_path, ['a'])
    (tmp_path / 'd.txt').write_text('0 0.0\n1 0.01\n')
    (tmp_path / 'r.txt').write_text('0 0.0\n')
    section = {'elements': [{'model': 'pushover', 'backbone': {'opensees': {
        'displacement_file': 'd.txt', 'reaction_file': 'r.txt', 'skip_rows': 0}}}]}
    with pytest.raises(SpecimenConfigError, match=r'backbone.opensees: .*has 2 rows but'):
        build(section, tmp_path, ['a'])
    section['elements'][0]['backbone']['opensees']['skip_rows'] = -1
    with pytest.raises(SpecimenConfigError, match=r'opensees.skip_rows: must be an integer'):
        build(section, tmp_path, ['a'])


def test_config_section_must_be_mapping(tmp_path: Path) -> None:
    with pytest.raises(SpecimenConfigError,
                       match=re.escape('test.yaml: specimen: must be a mapping')):
        build(None, tmp_path)


def test_server_keys_commands_by_step_and_iteration() -> None:
    server = SpecimenServer(Specimen([Elastic(1000.0)], dof_names=['u']))
    first = server.handle('t', 3, (0.01,), iteration=0)
    second = server.handle('t', 3, (0.02,), iteration=1)
    assert first is not None and second is not None
    assert first.restoring_force == (10.0,)
    assert second.restoring_force == (20.0,)
    assert second.iteration == 1
    # The same (step, iteration) again: the same answer, no motion.
    assert server.handle('t', 3, (0.5,), iteration=1) is second
    assert server.repeated == 1
    # An older iteration of the same step is stale: ignored, the specimen does not move.
    assert server.handle('t', 3, (0.3,), iteration=0) is None
    assert server.position == (0.02,)


def test_server_per_step_commit_takes_a_steps_iterations_as_trials() -> None:
    """``commit: per_step``: iterations of a step start from the step's state (no unloading)."""
    def server(commit: str) -> SpecimenServer:
        section = {'commit': commit, 'elements': [
            {'model': 'epp', 'stiffness': 1.0e5, 'yield_force': 2.0e3}]}
        return server_from_config(section, base_dir=Path('.'), source='t.yaml',
                                  dof_names=['x'])

    per_step, per_command = server('per_step'), server('per_command')
    for s in (per_step, per_command):
        s.handle('t', 1, [0.03], iteration=0)        # overshoot: yields to x_p = 0.01
    # coming back within the same step: per_step evaluates from the step's start (elastic
    # 1e5 * 0.015), per_command has yielded and unloads from (0.03, 2000)
    back_step = per_step.handle('t', 1, [0.015], iteration=1)
    back_command = per_command.handle('t', 1, [0.015], iteration=1)
    assert back_step is not None and back_command is not None
    assert back_step.restoring_force == pytest.approx((1500.0,))
    assert back_command.restoring_force == pytest.approx((500.0,))
    # the next step commits the last trial (x = 0.015, elastic): back to 0 gives zero force
    zero = per_step.handle('t', 2, [0.0], iteration=0)
    assert zero is not None and zero.restoring_force == pytest.approx((0.0,))


@pytest.mark.parametrize(('section', 'message'), [
    ({'commit': 'sometimes'}, r'specimen\.commit: must be one of per_command, per_step'),
    ({'commit': 'per_step', 'errors': {'force_noise': 1.0, 'seed': 1}},
     r'specimen\.commit: per_step cannot be combined with errors'),
])
def test_server_commit_mode_errors(section: dict, message: str) -> None:
    full = {**section, 'elements': [{'model': 'elastic', 'stiffness': 1.0e5}]}
    with pytest.raises(SpecimenConfigError, match=message):
        server_from_config(full, base_dir=Path('.'), source='t.yaml', dof_names=['x'])
