"""Tests of pd_common.config.loader: the one YAML loader of the project (aliases refused)."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
import yaml

from pd_common.config.loader import YAMLAliasError, YAMLError, load_yaml, read_yaml_file
from pd_common.errors import SpecimenError
from pd_common.specimen import load_specimen_section

LEVELS = 'abcdefghi'


def alias_bomb(tail: str) -> str:
    """A "billion laughs": nine levels of nine aliases each (9**9 values), then ``tail``."""
    lines = ['a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1]']
    for before, name in zip(LEVELS, LEVELS[1:]):
        lines.append(f'{name}: &{name} [' + ', '.join([f'*{before}'] * 9) + ']')
    return '\n'.join(lines) + '\n' + tail


def test_the_alias_bomb_is_refused_at_once() -> None:
    text = alias_bomb('structure:\n  dof_names: *i\n')
    start = time.perf_counter()
    with pytest.raises(YAMLAliasError) as info:
        load_yaml(text)
    elapsed = time.perf_counter() - start
    assert elapsed < 1.0
    # The first alias, on line 2 (b's first item), is named with its line.
    assert str(info.value) == ('line 2: b[0]: YAML aliases (*a) are not allowed in test files; '
                               'write the value out')
    assert isinstance(info.value, yaml.YAMLError)
    assert info.value.alias == 'a'
    assert info.value.problem_mark is not None
    assert info.value.problem_mark.line + 1 == 2


@pytest.mark.parametrize(('text', 'message'), [
    ('structure:\n  mass: &m 1000.0\n  other: *m\n',
     ('line 3: structure.other: YAML aliases (*m) are not allowed in test files; '
      'write the value out')),
    ('x: [1, 2, *u]\n', 'line 1: x[2]: YAML aliases (*u) are not allowed'),
    ('- *top\n', 'line 1: [0]: YAML aliases (*top) are not allowed'),
    ('base: &b {k: 1}\nderived:\n  <<: *b\n', 'line 3: derived.<<: YAML aliases (*b)'),
    ('*key : 1\n', 'line 1: YAML aliases (*key) are not allowed'),
])
def test_every_alias_is_refused_with_its_line_and_key(text: str, message: str) -> None:
    with pytest.raises(YAMLAliasError) as info:
        load_yaml(text)
    assert str(info.value).startswith(message)
    assert '\n' not in str(info.value)


def test_an_undefined_alias_is_refused_as_an_alias() -> None:
    with pytest.raises(YAMLAliasError, match=r'\(\*nowhere\)'):
        load_yaml('a: *nowhere\n')


def test_anchors_without_aliases_are_harmless() -> None:
    assert load_yaml('a: &a [1, 2]\nb: &b {c: &c 3}\n') == {'a': [1, 2], 'b': {'c': 3}}


def test_exponent_floats_are_still_numbers() -> None:
    assert load_yaml('k: 3.5e7\nm: 1e5\ns: 1e5x\n') == {'k': 3.5e7, 'm': 1e5, 's': '1e5x'}


def test_alias_error_is_the_projects_yaml_error() -> None:
    assert issubclass(YAMLAliasError, YAMLError)


def test_read_yaml_file_refuses_the_bomb(tmp_path: Path) -> None:
    path = tmp_path / 'bomb.yaml'
    path.write_text(alias_bomb('structure:\n  mass: *i\n'), encoding='utf-8')
    start = time.perf_counter()
    with pytest.raises(YAMLAliasError, match=r'^line 2: '):
        read_yaml_file(path)
    assert time.perf_counter() - start < 1.0


def test_the_specimen_section_reader_reports_the_bomb_on_one_line(tmp_path: Path) -> None:
    path = tmp_path / 'bomb.yaml'
    path.write_text(alias_bomb('structure:\n  dof_names: *i\nspecimen: {elements: []}\n'),
                    encoding='utf-8')
    start = time.perf_counter()
    with pytest.raises(SpecimenError) as info:
        load_specimen_section(path)
    assert time.perf_counter() - start < 1.0
    message = str(info.value)
    assert '\n' not in message
    assert str(path) in message
    assert 'line 2: b[0]: YAML aliases (*a) are not allowed in test files' in message
