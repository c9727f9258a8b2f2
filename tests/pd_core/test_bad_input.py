"""Bad input is refused fast, before anything starts, with one line naming the file and the key.

The YAML alias bomb, the ambiguous MDOF initial stiffness, non-positive masses and stiffnesses,
broken AT2 records, more steps than memory holds, records that overflow and booleans where
numbers belong, through ``load_test_file`` (as ``./pd run`` reads a test). The same through
the commands themselves: ``test_bad_input_limits.py``.
"""

from __future__ import annotations

import copy
import math
import re
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from pd_core.errors import ConfigError
from pd_core.run.test_file import from_dict, load_test_file, steps_refusal
from support.paths import DEFAULT_TEST

STORIES = (2.0e8, 1.5e8, 1.0e8)  # N/m, story stiffnesses of the 3-story shear building
LEVELS = 'abcdefghi'


def shear_matrix(stories: tuple[float, ...]) -> np.ndarray:
    """The tridiagonal stiffness matrix of a shear building, written out by hand."""
    n = len(stories)
    k = np.zeros((n, n))
    for i, story in enumerate(stories):  # story i between floor i-1 (ground) and floor i
        k[i, i] += story
        if i > 0:
            k[i - 1, i - 1] += story
            k[i - 1, i] -= story
            k[i, i - 1] -= story
    return k


def three_story(**structure: Any) -> dict[str, Any]:
    """A 3-DOF shear-building test (inline record), ``structure`` keys replaced."""
    raw: dict[str, Any] = {
        'test': {'id': 'three-story', 'dt': 0.005},
        'structure': {'dof_names': ['f1', 'f2', 'f3'], 'mass': [1.0e5, 1.0e5, 1.0e5],
                      'damping': {'ratio': 0.05},
                      'initial_stiffness': shear_matrix(STORIES).tolist(),
                      'influence': [1.0, 1.0, 1.0]},
        'ground_motion': {'inline': {'dt': 0.01, 'acceleration': [0.0, 0.5, -0.3, 0.1, 0.0]},
                          'units': 'm/s2'},
        'specimen': {'topology': 'shear_building',
                     'elements': [{'model': 'elastic', 'stiffness': k} for k in STORIES]},
    }
    raw['structure'].update(structure)
    return raw


def default_raw(**structure: Any) -> dict[str, Any]:
    """The default (SDOF) test file, record path absolute, ``structure`` keys replaced."""
    raw = yaml.safe_load(DEFAULT_TEST.read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(DEFAULT_TEST.parent / raw['ground_motion']['file'])
    raw['structure'].update(structure)
    return raw


def write(tmp_path: Path, raw: dict[str, Any], name: str = 'case.yaml') -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    return path


def refused(path: Path, pattern: str, overrides: dict[str, Any] | None = None) -> str:
    """``load_test_file`` refuses ``path`` with one line matching ``pattern``; returns it."""
    with pytest.raises(ConfigError, match=pattern) as info:
        load_test_file(path, overrides)
    message = str(info.value)
    assert '\n' not in message
    return message


# -- YAML aliases -----------------------------------------------------------------------------
def alias_bomb(key: str) -> str:
    """The default test file with a "billion laughs" (9**9 values) as ``structure.<key>``."""
    lines = ['a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1]']
    for before, name in zip(LEVELS, LEVELS[1:]):
        lines.append(f'{name}: &{name} [' + ', '.join([f'*{before}'] * 9) + ']')
    text = DEFAULT_TEST.read_text(encoding='utf-8')
    text = re.sub(rf'^  {key}: .*$', f'  {key}: *i', text, count=1, flags=re.MULTILINE)
    assert f'  {key}: *i' in text
    text = text.replace('file: ../data/', f'file: {DEFAULT_TEST.parent}/../data/')
    return '\n'.join(lines) + '\n' + text


@pytest.mark.timeout(30)
@pytest.mark.parametrize('key', ['dof_names', 'mass'])
def test_the_alias_bomb_is_refused_within_a_second(tmp_path: Path, key: str) -> None:
    path = tmp_path / 'bomb.yaml'
    path.write_text(alias_bomb(key), encoding='utf-8')
    start = time.perf_counter()
    message = refused(path, r'^bomb\.yaml: line 2: ')
    assert time.perf_counter() - start < 1.0
    assert message == ('bomb.yaml: line 2: b[0]: YAML aliases (*a) are not allowed in test '
                       'files; write the value out')


def test_a_single_alias_names_its_key_and_line(tmp_path: Path) -> None:
    path = tmp_path / 'alias.yaml'
    text = DEFAULT_TEST.read_text(encoding='utf-8')
    text = text.replace('mass: 2543.4', 'mass: &m 2543.4').replace(
        'ratio: 0.05 ', 'coefficient: *m ')
    path.write_text(text, encoding='utf-8')
    line = next(number for number, row in enumerate(text.splitlines(), start=1)
                if '*m' in row)
    refused(path, rf'^alias\.yaml: line {line}: structure\.damping\.coefficient: YAML aliases '
                  r'\(\*m\) are not allowed in test files; write the value out$')


# -- the MDOF initial stiffness ---------------------------------------------------------------
def test_a_list_of_story_stiffnesses_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path, three_story(initial_stiffness=list(STORIES)))
    message = refused(path, r'^case\.yaml: structure\.initial_stiffness: a list of 3 values is '
                            r'ambiguous for 3 DOFs')
    assert "give the 3x3 matrix (one row per DOF) or 'probe'" in message
    assert '[200000000.0, 150000000.0, 100000000.0]' in message


def test_a_scalar_stiffness_is_refused_for_an_mdof(tmp_path: Path) -> None:
    path = write(tmp_path, three_story(initial_stiffness=2.0e8))
    refused(path, r"^case\.yaml: structure\.initial_stiffness: a single value is ambiguous for 3 "
                  r"DOFs; give the 3x3 matrix \(one row per DOF\) or 'probe', got 200000000\.0$")


def test_the_override_gives_the_same_message(tmp_path: Path) -> None:
    path = write(tmp_path, three_story())
    from_file = refused(write(tmp_path, three_story(initial_stiffness=list(STORIES)), 'list.yaml'),
                        r'^list\.yaml: structure\.initial_stiffness: ')
    from_override = refused(path, r'^case\.yaml: structure\.initial_stiffness: ',
                            overrides={'initial_stiffness': list(STORIES)})
    assert from_override.removeprefix('case.yaml') == from_file.removeprefix('list.yaml')
    refused(path, r'^case\.yaml: structure\.initial_stiffness: a single value is ambiguous',
            overrides={'initial_stiffness': 2.0e8})


@pytest.mark.parametrize(('value', 'what'), [
    ([2.0e8, 1.5e8], r"give the 3x3 matrix .* or 'probe', got a list of 2 values$"),
    ([[2.0e8, 0.0], [0.0, 1.0e8]], r'give the 3x3 matrix .*, got shape \(2, 2\)$'),
    ([[2.0e8, -1.0e8, 0.0], [-1.1e8, 2.0e8, 0.0], [0.0, 0.0, 1.0e8]],
     r'must be a symmetric matrix$'),
    ([[-2.0e8, 0.0, 0.0], [0.0, 1.0e8, 0.0], [0.0, 0.0, 1.0e8]],
     r'must be positive semi-definite, it has a negative eigenvalue \(-2e\+08\)$'),
])
def test_a_bad_stiffness_matrix_names_the_key(tmp_path: Path, value: Any, what: str) -> None:
    refused(write(tmp_path, three_story(initial_stiffness=value)),
            r'^case\.yaml: structure\.initial_stiffness: ' + what)


def test_an_sdof_scalar_stiffness_is_fine_and_a_negative_one_is_not(tmp_path: Path) -> None:
    definition = load_test_file(write(tmp_path, default_raw(initial_stiffness=312559.0)))
    assert definition.initial_stiffness is not None
    assert definition.initial_stiffness.tolist() == [[312559.0]]
    refused(write(tmp_path, default_raw(initial_stiffness=-312559.0)),
            r'^case\.yaml: structure\.initial_stiffness: must not be negative, got -312559\.0$')


def test_a_measured_stiffness_that_is_not_positive_names_the_key() -> None:
    probe = load_test_file(DEFAULT_TEST, overrides={'initial_stiffness': 'probe'})
    with pytest.raises(ConfigError, match=r'^default_test\.yaml: structure\.initial_stiffness: '
                                          r'must not be negative$'):
        probe.with_initial_stiffness(np.array([[-1.0]]))


# -- the mass ---------------------------------------------------------------------------------
@pytest.mark.parametrize(('structure', 'what'), [
    ({'mass': -2543.4}, r'must be positive, got -2543\.4$'),
    ({'mass': 0.0}, r'must be positive, got 0\.0$'),
    ({'mass': -2543.4, 'initial_stiffness': 'probe'}, r'must be positive, got -2543\.4$'),
    ({'mass': -2543.4, 'damping': {'coefficient': 2819.5}}, r'must be positive, got -2543\.4$'),
])
def test_a_non_positive_sdof_mass_is_reported_under_structure_mass(
        tmp_path: Path, structure: dict[str, Any], what: str) -> None:
    refused(write(tmp_path, default_raw(**structure)), r'^case\.yaml: structure\.mass: ' + what)


@pytest.mark.parametrize(('structure', 'what'), [
    ({'mass': [1.0e5, -1.0e5, 1.0e5]}, r"must be positive, got -100000\.0 for DOF 'f2'$"),
    ({'mass': [1.0e5, 1.0e5, 0.0]}, r"must be positive, got 0\.0 for DOF 'f3'$"),
    ({'mass': [1.0e5, -1.0e5, 1.0e5], 'damping': {'coefficient': 0.0}},
     r"must be positive, got -100000\.0 for DOF 'f2'$"),
    ({'mass': [1.0e5, -1.0e5, 1.0e5], 'damping': {'rayleigh': {'ratios': [0.05, 0.05]}}},
     r"must be positive, got -100000\.0 for DOF 'f2'$"),
    ({'mass': [[1.0e5, 1.0, 0.0], [0.0, 1.0e5, 0.0], [0.0, 0.0, 1.0e5]]},
     r'must be a symmetric matrix$'),
    ({'mass': [[1.0e5, 2.0e5, 0.0], [2.0e5, 1.0e5, 0.0], [0.0, 0.0, 1.0e5]]},
     r'must be positive definite$'),
])
def test_a_bad_mdof_mass_is_reported_under_structure_mass(
        tmp_path: Path, structure: dict[str, Any], what: str) -> None:
    refused(write(tmp_path, three_story(**structure)), r'^case\.yaml: structure\.mass: ' + what)


def test_a_negative_mass_override_is_reported_under_structure_mass() -> None:
    with pytest.raises(ConfigError, match=r'^default_test\.yaml: structure\.mass: must be '
                                          r'positive, got -2543\.4$'):
        load_test_file(DEFAULT_TEST, overrides={'mass': -2543.4})


def test_a_negative_mass_of_a_substructured_test_is_reported_under_structure_mass() -> None:
    path = DEFAULT_TEST.parent / 'three_story_two_sites.yaml'
    with pytest.raises(ConfigError, match=r"^three_story_two_sites\.yaml: structure\.mass: must "
                                          r"be positive, got -20000\.0 for DOF 'u2'$"):
        load_test_file(path, overrides={'mass': [2.0e4, -2.0e4, 1.5e4]})


def test_a_negative_mass_from_a_bag_is_reported_under_structure_mass() -> None:
    resolved = load_test_file(DEFAULT_TEST).to_resolved_dict()
    resolved['structure']['mass'] = [[-2543.4]]
    with pytest.raises(ConfigError, match=r'^bag: structure\.mass: must be positive'):
        from_dict(copy.deepcopy(resolved), source='bag')


# -- the ground motion record -----------------------------------------------------------------
AT2_HEADER = ('PEER NGA STRONG MOTION DATABASE RECORD\nSYNTHETIC, COMPONENT 000\n'
              'ACCELERATION TIME SERIES IN UNITS OF G\n')


@pytest.mark.parametrize(('line4', 'body', 'what'), [
    ('NPTS=  3, DT=   .0050 SEC', '  .1000000E-02  .2000000E-02 -.1790158E-0\n',
     r"line 5: malformed value '-\.1790158E-0'"),
    ('NPTS=  3, DT=   .0050 SEC', '  .1000000E-02  .2000000E-02 -.1790158E\n',
     r"line 5: non-numeric value '-\.1790158E'"),
    ('NPTS=  3, DT=   10 USEC', '  .1000000E-02  .2000000E-02 -.1790158E-02\n',
     r"line 4: unknown DT unit 'USEC'"),
    ('NPTS=  3.5, DT=   .0050 SEC', '  .1000000E-02  .2000000E-02 -.1790158E-02\n',
     r"line 4: NPTS must be a non-negative integer, got '3\.5'"),
])
def test_a_bad_at2_record_is_one_line_naming_the_test_file_and_the_record(
        tmp_path: Path, line4: str, body: str, what: str) -> None:
    (tmp_path / 'rec.AT2').write_text(AT2_HEADER + line4 + '\n' + body, encoding='utf-8')
    raw = default_raw()
    raw['ground_motion'] = {'file': 'rec.AT2', 'units': 'g'}
    message = refused(write(tmp_path, raw), r'^case\.yaml: ground_motion: ground motion ')
    assert str(tmp_path / 'rec.AT2') in message
    assert re.search(what, message)


# -- bounds: steps, overflow, booleans (the CLI side: test_bad_input_limits.py) ---------------
def test_the_steps_a_history_needs_are_bounded_by_count_and_memory() -> None:
    assert steps_refusal(3118, 1) is None
    assert steps_refusal(1e11, 1) == '1e+11 steps; at most 5e+07'
    assert steps_refusal(math.inf, 1) == 'inf steps; at most 5e+07'
    # 4e7 steps of 1000 DOFs: 1.9 TB of history, beyond this machine whatever it is.
    refusal = steps_refusal(4e7, 1000)
    assert refusal is not None
    assert re.match(r"^4e\+07 steps of 1000 DOF\(s\): the history needs 1\.79e\+03 GiB, more "
                    r"than 50% of this machine's [\d.]+ [KMGT]iB$", refusal)


def test_a_duration_that_overflows_the_step_count_is_refused(tmp_path: Path) -> None:
    raw = default_raw()
    raw['test'].update(duration=1e308, dt=1e-300)
    refused(write(tmp_path, raw), r'^case\.yaml: test\.duration: 1e\+308 s at dt 1e-300 s is inf '
                                  r'steps; at most 5e\+07$')


@pytest.mark.filterwarnings('error')  # a numpy RuntimeWarning (overflow) fails the test
@pytest.mark.parametrize(('ground', 'message'), [
    ({'scale': 1e308}, (r"ground_motion\.scale: 1e\+308 × the record's peak 3\.128 m/s2 is "
                        r'beyond the largest number$')),
    ({'inline': {'dt': 0.01, 'acceleration': [0.0, 1e300, -1e300]}, 'units': 'g', 'g': 1e10},
     r"ground_motion: ground motion 'inline': non-finite acceleration"),
    ({'inline': {'dt': 0.01, 'acceleration': [0.0, 2.0]}, 'units': 'm/s2', 'scale': 1e308},
     r"ground_motion\.scale: 1e\+308 × the record's peak 2 m/s2 is beyond the largest number$"),
], ids=['file-scale', 'inline-g', 'inline-scale'])
def test_an_overflowing_record_is_one_line_without_warnings(
        tmp_path: Path, ground: dict[str, Any], message: str) -> None:
    raw = default_raw()
    if 'inline' in ground:
        raw['ground_motion'] = ground
    else:
        raw['ground_motion'].update(ground)
    refused(write(tmp_path, raw), r'^case\.yaml: ' + message)


@pytest.mark.parametrize(('structure', 'key'), [
    ({'mass': True}, 'structure.mass'),
    ({'mass': [[True]]}, 'structure.mass'),
    ({'initial_stiffness': False}, 'structure.initial_stiffness'),
    ({'damping': {'coefficient': True}}, 'structure.damping.coefficient'),
    ({'influence': [True]}, 'structure.influence'),
])
def test_a_boolean_is_no_number(tmp_path: Path, structure: dict[str, Any], key: str) -> None:
    refused(write(tmp_path, default_raw(**structure)), rf'^case\.yaml: {re.escape(key)}: ')


def test_a_boolean_in_an_inline_record_is_no_number(tmp_path: Path) -> None:
    raw = default_raw()
    raw['ground_motion'] = {'inline': {'dt': 0.01, 'acceleration': [0.0, True, 0.1]},
                            'units': 'm/s2'}
    refused(write(tmp_path, raw), r'^case\.yaml: ground_motion\.inline\.acceleration\.1: must be '
                                  r'a number, got true$')


def test_an_error_of_a_record_key_is_not_wrapped_twice(tmp_path: Path) -> None:
    raw = default_raw()
    raw['ground_motion'] = {'inline': {'dt': 0.01, 'acceleration': [0.0, 0.1]}, 'units': 'ft'}
    refused(write(tmp_path, raw), r"^case\.yaml: ground_motion\.units: must be one of 'g', "
                                  r"'m/s2', 'm/s\^2', got 'ft'$")
