"""The test definition schema: the default test file, overrides, errors and the resolved form."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest
import yaml

from pd_core.errors import ConfigError
from pd_core.run.test_file import from_dict, from_json, load_test_file
from support.paths import DEFAULT_TEST, REPO

if TYPE_CHECKING:
    from pd_core.run.definition import TestDefinition

ELCENTRO = Path('/work/main/src/pd_integrator/data/ground_motions/elcentro_1940_ns_chopra.csv')
if not ELCENTRO.is_file():  # a checkout somewhere else
    ELCENTRO = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / ELCENTRO.name

M = 2543.4
K = 312559.0
ZETA = 0.05
G = 9.81


def elcentro_record_g() -> np.ndarray:
    """The El Centro record in g, read here independently of the code under test."""
    values = []
    for line in ELCENTRO.read_text(encoding='utf-8').splitlines():
        line = line.strip()
        if not line or line.startswith('#'):
            continue
        _, accel = line.split(',')
        values.append(float(accel))
    return np.array(values)


def base_raw() -> dict[str, Any]:
    """The default test file, with the record path made absolute."""
    raw = yaml.safe_load(DEFAULT_TEST.read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(ELCENTRO)
    return raw


def write_yaml(tmp_path: Path, raw: dict[str, Any], name: str = 'case.yaml') -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    return path


def assert_config_error(path: Path, pattern: str) -> str:
    """Loading ``path`` raises a one-line ConfigError matching ``pattern``; returns it."""
    with pytest.raises(ConfigError, match=pattern) as info:
        load_test_file(path)
    message = str(info.value)
    assert '\n' not in message
    return message


# -- the default test file -------------------------------------------------------------------
@pytest.fixture(scope='module')
def default() -> TestDefinition:
    return load_test_file(DEFAULT_TEST)


def test_default_scalars(default: TestDefinition) -> None:
    assert default.dt == 0.01
    assert default.scheme == 'newmark_explicit'
    assert default.test_id == 'thesis-5.1-elcentro'
    assert default.dof_names == ('top',)
    assert default.mass.shape == (1, 1)
    assert default.mass[0, 0] == M
    assert default.initial_stiffness is not None
    assert default.initial_stiffness.shape == (1, 1)
    assert default.initial_stiffness[0, 0] == K
    assert not default.needs_probe
    assert np.array_equal(default.influence, [1.0])


def test_default_damping_is_two_zeta_sqrt_km(default: TestDefinition) -> None:
    c = 2.0 * ZETA * math.sqrt(K * M)
    assert default.damping is not None
    assert default.damping.shape == (1, 1)
    assert default.damping[0, 0] == pytest.approx(c, rel=1e-12)
    assert default.damping[0, 0] == pytest.approx(2819.508, abs=1e-3)


def test_default_length(default: TestDefinition) -> None:
    record = elcentro_record_g()
    assert record.size == 1560
    # 1560 samples at 0.02 s last 31.18 s: 3118 steps of 0.01 s.
    assert default.n_steps == 3118
    assert default.duration == pytest.approx(31.18, abs=1e-9)
    assert default.ground_acceleration.shape == (3119,)


def test_default_ground_acceleration_even_and_odd_steps(default: TestDefinition) -> None:
    record = elcentro_record_g() * 9.81
    ag = default.ground_acceleration
    # Even steps fall on the record's samples: the record converted with g = 9.81.
    assert np.array_equal(ag[0::2], record)
    # Odd steps are the midpoints (thesis Appendix A, lines 48-56).
    midpoints = (record[:-1] + record[1:]) * 0.5
    assert np.array_equal(ag[1::2], midpoints)
    # A hand-checked sample: record[1] = 6.3e-3 g.
    assert ag[2] == 6.3e-3 * 9.81
    assert ag[1] == (0.0 + 6.3e-3 * 9.81) * 0.5


def test_default_load_is_minus_m_ag(default: TestDefinition) -> None:
    ag = default.ground_acceleration
    for step in (0, 1, 2, 777, 3118):
        assert default.load(step)[0] == pytest.approx(-M * ag[step], rel=1e-15)


# -- overrides --------------------------------------------------------------------------------
def test_overrides_change_exactly_those_things(default: TestDefinition) -> None:
    overrides = {'dt': 0.005, 'scale_factor': 2.0, 'direction': -1, 'damping_ratio': 0.02,
                 'initial_stiffness': 'probe'}
    changed = load_test_file(DEFAULT_TEST, overrides=overrides)
    # The overridden things.
    assert changed.dt == 0.005
    assert changed.n_steps == 6236  # 31.18 s / 0.005 s
    assert changed.initial_stiffness is None
    assert changed.needs_probe
    assert changed.damping_ratio == 0.02
    assert changed.damping is None  # follows from the probed stiffness later
    record = elcentro_record_g() * 9.81
    assert np.array_equal(changed.ground_motion.acceleration, record * -2.0)
    ag = changed.ground_acceleration
    assert ag.shape == (6237,)
    assert np.array_equal(ag[0::4], record * -2.0)
    t = np.arange(6237) * 0.005
    expected = np.interp(t, np.arange(record.size) * 0.02, record * -2.0)
    np.testing.assert_allclose(ag, expected, rtol=0.0, atol=1e-12)
    # Everything else is as in the file.
    assert changed.test_id == default.test_id
    assert changed.scheme == default.scheme
    assert changed.dof_names == default.dof_names
    assert np.array_equal(changed.mass, default.mass)
    assert np.array_equal(changed.influence, default.influence)
    assert changed.protocol == default.protocol
    assert changed.probe == default.probe
    assert changed.specimen == default.specimen
    assert changed.ground_motion.dt == default.ground_motion.dt
    # ... and the file itself was not changed by the overrides.
    again = load_test_file(DEFAULT_TEST)
    assert again.dt == 0.01
    assert again.initial_stiffness is not None


def test_override_none_keeps_the_file_value() -> None:
    definition = load_test_file(DEFAULT_TEST, overrides={'dt': None, 'mass': None})
    assert definition.dt == 0.01
    assert definition.mass[0, 0] == M


def test_unknown_override_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match=r"default_test\.yaml: parameter 'dtt'"):
        load_test_file(DEFAULT_TEST, overrides={'dtt': 0.01})


def test_duration_override_adds_free_vibration() -> None:
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': 40.0})
    assert definition.n_steps == 4000
    assert np.all(definition.ground_acceleration[3119:] == 0.0)
    assert definition.ground_acceleration[3118] == elcentro_record_g()[-1] * 9.81


# -- errors -----------------------------------------------------------------------------------
def test_unknown_section(tmp_path: Path) -> None:
    raw = base_raw()
    raw['tests'] = {'dt': 0.01}
    assert_config_error(write_yaml(tmp_path, raw), r'^case\.yaml: tests: unknown section')


def test_unknown_key_in_a_section(tmp_path: Path) -> None:
    raw = base_raw()
    raw['test']['dtt'] = 0.02
    assert_config_error(write_yaml(tmp_path, raw), r'^case\.yaml: test\.dtt: unknown key')
    raw = base_raw()
    raw['protocol']['retries'] = 4
    assert_config_error(write_yaml(tmp_path, raw),
                        r'^case\.yaml: protocol\.retries: unknown key')


@pytest.mark.parametrize(('value', 'pattern'), [
    (-0.01, r'^case\.yaml: test\.dt: must be > 0, got -0\.01'),
    (0.0, r'^case\.yaml: test\.dt: must be > 0, got 0\.0'),
    (float('nan'), r'^case\.yaml: test\.dt: must be a finite number, got nan'),
    (float('inf'), r'^case\.yaml: test\.dt: must be a finite number, got inf'),
    ('0.01s', r"^case\.yaml: test\.dt: must be a number, got '0\.01s'"),
    (True, r'^case\.yaml: test\.dt: must be a number'),
])
def test_bad_dt(tmp_path: Path, value: Any, pattern: str) -> None:
    raw = base_raw()
    raw['test']['dt'] = value
    assert_config_error(write_yaml(tmp_path, raw), pattern)


def test_missing_dt(tmp_path: Path) -> None:
    raw = base_raw()
    del raw['test']['dt']
    assert_config_error(write_yaml(tmp_path, raw), r'^case\.yaml: test\.dt: is required')


def test_missing_ground_motion(tmp_path: Path) -> None:
    raw = base_raw()
    del raw['ground_motion']
    assert_config_error(write_yaml(tmp_path, raw), r'^case\.yaml: ground_motion: .*required')


def test_direction_must_be_plus_or_minus_one(tmp_path: Path) -> None:
    raw = base_raw()
    raw['ground_motion']['direction'] = 2
    assert_config_error(write_yaml(tmp_path, raw),
                        r'^case\.yaml: ground_motion\.direction: must be 1 or -1')


@pytest.mark.parametrize('mass', [float('inf'), [[float('nan')]], float('-inf')])
def test_non_finite_mass(tmp_path: Path, mass: Any) -> None:
    raw = base_raw()
    raw['structure']['mass'] = mass
    assert_config_error(write_yaml(tmp_path, raw), r'^case\.yaml: structure\.mass: .*finite')


def test_damping_ratio_and_coefficient_together(tmp_path: Path) -> None:
    raw = base_raw()
    raw['structure']['damping'] = {'ratio': 0.05, 'coefficient': 2819.5}
    assert_config_error(write_yaml(tmp_path, raw),
                        r'^case\.yaml: structure\.damping: give exactly one of ratio, '
                        r'coefficient, rayleigh or modal, got ratio, coefficient')


@pytest.mark.parametrize('test_id', ['has space', 'a:probe', '', 'x' * 65, 'ünï'])
def test_bad_test_id(tmp_path: Path, test_id: str) -> None:
    raw = base_raw()
    raw['test']['id'] = test_id
    assert_config_error(write_yaml(tmp_path, raw), r'^case\.yaml: test\.id: must be 1-64')


def test_test_id_must_be_a_string(tmp_path: Path) -> None:
    raw = base_raw()
    raw['test']['id'] = 12
    assert_config_error(write_yaml(tmp_path, raw), r'^case\.yaml: test\.id: must be a string')


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / 'missing.yaml'
    message = assert_config_error(path, r'cannot read the test file')
    assert str(path) in message
    assert 'No such file' in message


def test_unreadable_file(tmp_path: Path) -> None:
    folder = tmp_path / 'folder.yaml'
    folder.mkdir()
    message = assert_config_error(folder, r'cannot read the test file')
    assert str(folder) in message


def test_invalid_yaml_names_the_line(tmp_path: Path) -> None:
    path = tmp_path / 'broken.yaml'
    path.write_text('test:\n  dt: 0.01\n\tid: x\n', encoding='utf-8')
    assert_config_error(path, r'^broken\.yaml: line 3: ')


def test_yaml_that_is_not_a_mapping(tmp_path: Path) -> None:
    path = tmp_path / 'list.yaml'
    path.write_text('- 1\n- 2\n', encoding='utf-8')
    assert_config_error(path, r'^list\.yaml: a test file must be a mapping')


def test_missing_ground_motion_file_is_a_config_error(tmp_path: Path) -> None:
    raw = base_raw()
    raw['ground_motion']['file'] = str(tmp_path / 'nowhere.csv')
    message = assert_config_error(write_yaml(tmp_path, raw), r'^case\.yaml: ground_motion: ')
    assert 'nowhere.csv' in message


def test_bad_ground_motion_file_is_a_config_error(tmp_path: Path) -> None:
    record = tmp_path / 'bad.csv'
    record.write_text('0.00,0.1\n0.02,abc\n0.04,0.2\n', encoding='utf-8')
    raw = base_raw()
    raw['ground_motion']['file'] = 'bad.csv'  # relative: resolved against the test file
    message = assert_config_error(write_yaml(tmp_path, raw), r'^case\.yaml: ground_motion: ')
    assert 'bad.csv' in message
    assert 'line 2' in message


# -- the resolved form ------------------------------------------------------------------------
def assert_same_resolved(a: TestDefinition, b: TestDefinition) -> None:
    assert b.n_steps == a.n_steps
    assert b.dt == a.dt
    assert b.test_id == a.test_id
    assert b.dof_names == a.dof_names
    assert b.ground_acceleration.tobytes() == a.ground_acceleration.tobytes()
    assert b.mass.tobytes() == a.mass.tobytes()
    assert b.influence.tobytes() == a.influence.tobytes()
    if a.damping is None:
        assert b.damping is None
        assert b.damping_ratio == a.damping_ratio
    else:
        assert b.damping is not None
        assert b.damping.tobytes() == a.damping.tobytes()
    if a.initial_stiffness is None:
        assert b.initial_stiffness is None
    else:
        assert b.initial_stiffness is not None
        assert b.initial_stiffness.tobytes() == a.initial_stiffness.tobytes()
    assert b.protocol == a.protocol
    assert b.probe == a.probe
    assert b.specimen == a.specimen


def test_resolved_round_trip(default: TestDefinition) -> None:
    again = from_json(default.to_json())
    assert_same_resolved(default, again)
    assert again.initial_stiffness is not None
    assert again.initial_stiffness[0, 0] == K


@pytest.mark.parametrize('overrides', [
    {'dt': 0.005, 'scale_factor': 1.7, 'direction': -1},
    {'duration': 35.0, 'damping_coefficient': 1234.5},
    {'dt': 0.04},
])
def test_resolved_round_trip_variants(overrides: dict[str, Any]) -> None:
    definition = load_test_file(DEFAULT_TEST, overrides=overrides)
    assert_same_resolved(definition, from_json(definition.to_json()))


def test_resolved_round_trip_of_a_probe_definition() -> None:
    definition = load_test_file(DEFAULT_TEST, overrides={'initial_stiffness': 'probe'})
    assert definition.initial_stiffness is None
    again = from_json(definition.to_json())
    assert again.needs_probe
    assert again.damping_ratio == ZETA
    assert_same_resolved(definition, again)
    # The measured stiffness gives the same damping in both.
    k = np.array([[K]])
    assert (again.with_initial_stiffness(k).damping.tobytes()
            == definition.with_initial_stiffness(k).damping.tobytes())


def test_resolved_round_trip_of_a_measured_stiffness() -> None:
    probe = load_test_file(DEFAULT_TEST, overrides={'initial_stiffness': 'probe'})
    measured = probe.with_initial_stiffness(np.array([[312001.25]]))
    again = from_json(measured.to_json())
    assert_same_resolved(measured, again)
    assert again.initial_stiffness[0, 0] == 312001.25


def test_from_json_rejects_bad_json() -> None:
    with pytest.raises(ConfigError, match=r'^bag: test definition is not valid JSON'):
        from_json('{"test": ')


def test_raw_file_is_not_modified_by_loading(tmp_path: Path) -> None:
    raw = base_raw()
    path = write_yaml(tmp_path, raw)
    before = path.read_bytes()
    load_test_file(path, overrides={'dt': 0.005})
    assert path.read_bytes() == before


# -- the MDOF initial stiffness and the specimen's ---------------------------------------------
STORIES = (2.0e8, 1.5e8, 1.0e8)  # N/m, the 3-story shear building of the issue
FLOOR_MASS = 1.0e5  # kg per floor: with STORIES the periods of the issue (0.3509/0.1405/0.0919 s)


def shear_matrix(stories: tuple[float, ...]) -> np.ndarray:
    """K_ii = k_i + k_(i+1), K_i,i+1 = K_i+1,i = -k_(i+1): written out for three stories."""
    k1, k2, k3 = stories
    return np.array([[k1 + k2, -k2, 0.0], [-k2, k2 + k3, -k3], [0.0, -k3, k3]])


def three_story_raw(initial_stiffness: Any, specimen: Any = None) -> dict[str, Any]:
    raw = base_raw()
    raw['test']['dt'] = 0.005
    raw['structure'] = {'dof_names': ['f1', 'f2', 'f3'], 'mass': [FLOOR_MASS] * 3,
                        'damping': {'ratio': 0.05}, 'initial_stiffness': initial_stiffness,
                        'influence': [1.0, 1.0, 1.0]}
    raw['specimen'] = specimen if specimen is not None else {
        'topology': 'shear_building',
        'elements': [{'model': 'elastic', 'stiffness': k} for k in STORIES]}
    return raw


def test_the_shear_building_matrix_is_taken_as_given(tmp_path: Path) -> None:
    expected = shear_matrix(STORIES)
    definition = load_test_file(write_yaml(tmp_path, three_story_raw(expected.tolist())))
    assert definition.initial_stiffness is not None
    assert np.array_equal(definition.initial_stiffness, expected)
    assert definition.warnings == ()
    # Its periods, from K/m (M = m I): those of the issue; the diagonal reading of the story
    # list gave other ones (the trap that a list is now refused for).
    periods = 2 * np.pi / np.sqrt(np.linalg.eigvalsh(definition.initial_stiffness) / FLOOR_MASS)
    np.testing.assert_allclose(np.sort(periods)[::-1], [0.3509, 0.1405, 0.0919], atol=5e-5)
    diagonal = 2 * np.pi / np.sqrt(np.array(STORIES) / FLOOR_MASS)
    assert not np.allclose(np.sort(diagonal)[::-1], np.sort(periods)[::-1], rtol=0.05)


def test_the_story_list_is_refused(tmp_path: Path) -> None:
    assert_config_error(write_yaml(tmp_path, three_story_raw(list(STORIES))),
                        r'^case\.yaml: structure\.initial_stiffness: a list of 3 values is '
                        r"ambiguous for 3 DOFs .*give the 3x3 matrix \(one row per DOF\) or "
                        r"'probe'")


def test_a_stiffness_unlike_the_specimens_is_a_warning(tmp_path: Path) -> None:
    given = np.diag(STORIES)  # the diagonal reading of the story stiffnesses
    definition = load_test_file(write_yaml(tmp_path, three_story_raw(given.tolist())))
    assert definition.initial_stiffness is not None
    assert np.array_equal(definition.initial_stiffness, given)  # not refused: a warning
    own = shear_matrix(STORIES)
    percent = 100.0 * np.linalg.norm(given - own) / np.linalg.norm(own)
    assert percent == pytest.approx(61.2, abs=0.1)
    assert len(definition.warnings) == 1
    warning = definition.warnings[0]
    assert '\n' not in warning
    assert warning.startswith(
        "case.yaml: structure.initial_stiffness differs from the specimen's initial stiffness "
        f'by {percent:.3g} % (relative Frobenius norm): ')
    assert '[[2e+08, 0, 0], [0, 1.5e+08, 0], [0, 0, 1e+08]] N/m in the structure' in warning
    assert ('[[3.5e+08, -1.5e+08, 0], [-1.5e+08, 2.5e+08, -1e+08], [0, -1e+08, 1e+08]] N/m '
            'from the specimen') in warning
    # The warning is the user's, not the test's: the resolved form does not carry it.
    assert 'warning' not in definition.to_json()
    assert definition.with_initial_stiffness(given).warnings == definition.warnings


@pytest.mark.parametrize(('factor', 'warned'), [(1.0, False), (1.005, False), (0.995, False),
                                                (1.1, True), (0.9, True)])
def test_the_sdof_warning_threshold_is_one_percent(tmp_path: Path, factor: float,
                                                   warned: bool) -> None:
    raw = base_raw()
    raw['structure']['initial_stiffness'] = K * factor
    definition = load_test_file(write_yaml(tmp_path, raw))
    assert bool(definition.warnings) is warned
    if warned:
        assert f'by {100 * abs(factor - 1):.3g} % ' in definition.warnings[0]
        assert f'{K * factor:.6g} N/m in the structure, {K:.6g} N/m from the specimen' in (
            definition.warnings[0])


def test_a_specimen_that_cannot_be_built_is_not_this_checks_business(tmp_path: Path) -> None:
    # (three distinct mappings: yaml.safe_dump writes one shared object as an alias, refused)
    specimen = {'topology': 'shear_building',
                'elements': [{'model': 'no-such-model'} for _ in range(3)]}
    raw = three_story_raw(np.diag(STORIES).tolist(), specimen)
    definition = from_dict(raw, source='test.yaml', base_dir=tmp_path)
    assert definition.warnings == ()
    # (the typed schema, after these checks at the edge, refuses the file: one line)
    with pytest.raises(ConfigError, match=r': specimen\.elements\.0\.model: must be one of '
                                          r"'elastic', .*, got 'no-such-model'$"):
        load_test_file(write_yaml(tmp_path, raw))


def test_no_warning_without_a_specimen_or_with_a_probe(tmp_path: Path) -> None:
    raw = base_raw()
    raw['structure']['initial_stiffness'] = 2 * K
    del raw['specimen']
    assert load_test_file(write_yaml(tmp_path, raw)).warnings == ()
    probe = load_test_file(DEFAULT_TEST, overrides={'initial_stiffness': 'probe'})
    assert probe.warnings == ()
    assert probe.with_initial_stiffness(np.array([[2 * K]])).warnings == ()
