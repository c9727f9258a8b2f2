"""Tests of pd_common.config.loader: the one YAML loader of the project (aliases, deep
nesting and repeated keys refused), and of pd_common.config.files (regular files only,
bounded, UTF-8)."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import pytest
import yaml

from pd_common.config import (
    InputFileError,
    YAMLDepthError,
    YAMLDuplicateKeyError,
    existing_path,
    read_text,
)
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
    assert elapsed < 10.0  # (expanded: 9**9 items, minutes)
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
    assert time.perf_counter() - start < 10.0  # (expanded or read: minutes, or never)


def test_the_specimen_section_reader_reports_the_bomb_on_one_line(tmp_path: Path) -> None:
    path = tmp_path / 'bomb.yaml'
    path.write_text(alias_bomb('structure:\n  dof_names: *i\nspecimen: {elements: []}\n'),
                    encoding='utf-8')
    start = time.perf_counter()
    with pytest.raises(SpecimenError) as info:
        load_specimen_section(path)
    assert time.perf_counter() - start < 10.0  # (expanded or read: minutes, or never)
    message = str(info.value)
    assert '\n' not in message
    assert message.startswith('bomb.yaml: line 2: b[0]: YAML aliases (*a) are not allowed in '
                              'test files')  # (as the integrator says it: one reader)


# -- nesting ------------------------------------------------------------------------------------
def nested(levels: int) -> str:
    """A mapping holding ``levels - 1`` nested lists: ``levels`` collections deep."""
    return 'a: ' + '[' * (levels - 1) + '1' + ']' * (levels - 1) + '\n'


def test_sixty_four_levels_are_read_and_sixty_five_are_not() -> None:
    value = load_yaml(nested(64))
    for _ in range(63):
        value = value['a'] if isinstance(value, dict) else value[0]
    assert value == [1]
    with pytest.raises(YAMLDepthError) as info:
        load_yaml(nested(65))
    assert str(info.value) == 'line 1: nesting deeper than 64 levels'
    assert isinstance(info.value, yaml.YAMLError)


@pytest.mark.parametrize('text', [
    'a: ' + '[' * 100_000 + ']' * 100_000,
    'a: ' + '{b: ' * 100_000 + '1' + '}' * 100_000,
    ''.join(f'{" " * level}k:\n' for level in range(70)) + ' ' * 70 + 'v: 1',
], ids=['lists', 'flow-mappings', 'block-mappings'])
def test_thousands_of_levels_are_refused_at_once_without_recursion(text: str) -> None:
    # With a recursion limit far below the depth, a loader that recursed per level would
    # raise RecursionError: the refusal comes from counting, before any deep structure.
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(400)
    try:
        with pytest.raises(YAMLDepthError, match=r'^line \d+: nesting deeper than 64 levels$'):
            load_yaml(text)
    finally:
        sys.setrecursionlimit(limit)


# -- keys given twice ----------------------------------------------------------------------------
@pytest.mark.parametrize(('text', 'message'), [
    ('a: 1\na: 2\n', 'line 2: a: given twice (first on line 1)'),
    ('structure:\n  mass: 1\n  dt: 2\n  mass: 3\n',
     'line 4: structure.mass: given twice (first on line 2)'),
    ('e:\n  - {k: 1, "k": 2}\n', 'line 2: e[0].k: given twice (first on line 2)'),
])
def test_a_key_given_twice_is_refused_with_its_line_and_path(text: str, message: str) -> None:
    with pytest.raises(YAMLDuplicateKeyError) as info:
        load_yaml(text)
    assert str(info.value) == message


def test_the_same_key_in_different_mappings_is_fine() -> None:
    assert load_yaml('a: {k: 1}\nb: {k: 2}\nc: [{k: 3}, {k: 4}]\n') == {
        'a': {'k': 1}, 'b': {'k': 2}, 'c': [{'k': 3}, {'k': 4}]}
    assert load_yaml('a: {<<: {k: 1}, k: 2}\n') == {'a': {'k': 2}}  # a merge: overridden


# -- files that are no test files -------------------------------------------------------------
def test_a_fifo_a_device_and_a_folder_are_refused_before_they_are_read(tmp_path: Path) -> None:
    fifo = tmp_path / 'pipe.yaml'
    os.mkfifo(fifo)
    for path, kind in ((fifo, 'a FIFO'), (Path('/dev/zero'), 'a character device'),
                       (tmp_path, 'a directory')):
        start = time.perf_counter()
        with pytest.raises(InputFileError) as info:
            read_yaml_file(path)
        assert time.perf_counter() - start < 10.0  # (expanded or read: minutes, or never)
        assert str(info.value) == f'{path}: not a regular file but {kind}'
        assert isinstance(info.value, OSError)


def test_a_file_too_large_is_refused_before_it_is_read(tmp_path: Path) -> None:
    path = tmp_path / 'big.yaml'
    with path.open('wb') as file:
        file.truncate(2**40)  # sparse
    with pytest.raises(InputFileError, match=r'big\.yaml: 1\.02e\+03 GiB, more than the 4 MiB '
                                             r'a test file may have$'):
        read_yaml_file(path, what='a test file')
    path.write_bytes(b'x' * 11)
    assert read_text(path, limit=11) == 'x' * 11
    path.write_bytes(b'x' * 12)
    with pytest.raises(InputFileError, match=r'12 bytes, more than the 11 bytes a file may have'):
        read_text(path, limit=11)


def test_text_that_is_not_utf8_names_the_line_and_the_byte(tmp_path: Path) -> None:
    path = tmp_path / 'latin.yaml'
    path.write_bytes('a: 1\nb: caf\xe9\n'.encode('latin-1'))
    with pytest.raises(InputFileError) as info:
        read_yaml_file(path)
    assert str(info.value) == f'{path}: line 2: not UTF-8 text, byte 0xe9 at offset 11'
    assert info.value.strerror == 'line 2: not UTF-8 text, byte 0xe9 at offset 11'


def test_a_symbolic_link_loop_is_named(tmp_path: Path) -> None:
    (tmp_path / 'a').symlink_to('b')
    (tmp_path / 'b').symlink_to('a')
    with pytest.raises(InputFileError, match=r'/a: a symbolic link loop$'):
        existing_path(tmp_path / 'a')
    with pytest.raises(FileNotFoundError):
        existing_path(tmp_path / 'missing')
    assert existing_path(tmp_path) == tmp_path.resolve()
