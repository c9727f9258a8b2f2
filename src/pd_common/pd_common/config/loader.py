"""Reading test and configuration files: one YAML loader for every package.

PyYAML's safe loader, with YAML 1.2's reading of exponent floats such as ``1e5`` and
``3.5e7`` (YAML 1.1 reads them as strings), that refuses what a test file has no use for and
what would make reading it blow up or lie:

* aliases (``*name``): a few lines of nested aliases (a "billion laughs") expand to billions
  of values. Anchors (``&name``) alone are harmless and allowed;
* nesting deeper than :data:`MAX_DEPTH` levels (``a: [[[[...]]]]``): the composer recurses per
  level, and thousands of levels end in a ``RecursionError``;
* a key given twice in one mapping (PyYAML keeps the last one silently);
* a file that is not a regular one or is larger than
  :data:`~pd_common.config.files.MAX_TEXT_BYTES`, or not UTF-8 (:func:`read_yaml_file`, see
  :mod:`.files`).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml
from yaml.error import Mark
from yaml.nodes import MappingNode, Node, ScalarNode

from .files import MAX_TEXT_BYTES, read_text

__all__ = ['MAX_DEPTH', 'YAMLAliasError', 'YAMLDepthError', 'YAMLDuplicateKeyError',
           'YAMLError', 'load_yaml', 'read_yaml_file', 'yaml_problem']

YAMLError = yaml.YAMLError

#: The deepest nesting of collections (mappings and lists) a YAML file may have; a test file
#: needs a handful of levels.
MAX_DEPTH = 64


class _OneLineError(yaml.MarkedYAMLError):
    """A refusal of the loader: ``str()`` is one line, ``line N: <problem>``."""

    def __str__(self) -> str:
        where = '' if self.problem_mark is None else f'line {self.problem_mark.line + 1}: '
        return f'{where}{self.problem}'


class YAMLDepthError(_OneLineError):
    """Collections nested deeper than :data:`MAX_DEPTH` levels.

    Refused before the composer recurses any deeper.

    ``str()`` is e.g. ``line 1: nesting deeper than 64 levels``.
    """

    def __init__(self, mark: Mark | None) -> None:
        super().__init__(problem=f'nesting deeper than {MAX_DEPTH} levels', problem_mark=mark)


class YAMLDuplicateKeyError(_OneLineError):
    """A key given twice in one mapping (the last one would silently win).

    ``str()`` is e.g. ``line 17: structure.mass: given twice (first on line 16)``.

    Attributes:
        key: the path of the repeated key (``structure.mass``).
    """

    def __init__(self, key: str, first: Mark | None, mark: Mark | None) -> None:
        before = f' (first on line {first.line + 1})' if first is not None else ''
        super().__init__(problem=f'{key}: given twice{before}', problem_mark=mark)
        self.key = key


class YAMLAliasError(_OneLineError):
    """A YAML alias (``*name``) in a file: refused, whatever it refers to.

    ``str()`` is one line, e.g. ``line 12: structure.dof_names: YAML aliases (*i) are not
    allowed in test files; write the value out``; :attr:`problem` is the same without the
    line, and :attr:`problem_mark` the position of the alias (as for PyYAML's own errors).

    Attributes:
        alias: the name of the alias (without ``*``).
        key: the path of the value the alias stands for (``structure.mass``, ``b[0]``), or
            ``''`` at the top of the document.
    """

    def __init__(self, alias: str, key: str, mark: Mark | None) -> None:
        where = f'{key}: ' if key else ''
        super().__init__(problem=f'{where}YAML aliases (*{alias}) are not allowed in test '
                         'files; write the value out', problem_mark=mark)
        self.alias = alias
        self.key = key


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader, reading ``1e5`` as a number (YAML 1.2) and refusing aliases.

    Deep nesting and repeated keys.
    """

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        # Where the composer is: a mapping value's key node, a sequence index, None for a key.
        self._where: list[Node | int | None] = []

    def compose_node(self, parent: Node | None, index: Any) -> Node | None:
        """Compose a node as PyYAML does, but refuse an alias before it is resolved."""
        if self.check_event(yaml.AliasEvent):
            event = self.current_event  # the alias (check_event peeked at it)
            mark = event.start_mark if isinstance(event.start_mark, Mark) else None
            raise YAMLAliasError(str(event.anchor), self._key(index), mark)
        if len(self._where) > MAX_DEPTH:  # its ancestors: the collections it is nested in
            self.check_event()  # peeks at the node's first event (its current_event)
            mark = getattr(self.current_event, 'start_mark', None)
            raise YAMLDepthError(mark if isinstance(mark, Mark) else None)
        self._where.append(index)
        try:
            node = super().compose_node(parent, index)
        finally:
            self._where.pop()
        if isinstance(node, MappingNode):
            self._check_keys(node, index)
        return node

    def _check_keys(self, node: MappingNode, index: Any) -> None:
        """Refuse a scalar key given twice in ``node`` (at ``index`` of the current node)."""
        seen: dict[tuple[str, str], Mark | None] = {}
        for key_node, _ in node.value:
            if not isinstance(key_node, ScalarNode) or key_node.tag.endswith(':merge'):
                continue
            mark = key_node.start_mark if isinstance(key_node.start_mark, Mark) else None
            name = (key_node.tag, key_node.value)
            if name in seen:
                path = self._key(index)
                key = f'{path}.{key_node.value}' if path else str(key_node.value)
                raise YAMLDuplicateKeyError(key, seen[name], mark)
            seen[name] = mark

    def _key(self, index: Any) -> str:
        """The path of the node at ``index`` of the current one: ``structure.mass``, ``b[2]``."""
        key = ''
        for step in [*self._where, index]:
            if isinstance(step, int):
                key += f'[{step}]'
            elif isinstance(step, ScalarNode):
                key += f'.{step.value}' if key else str(step.value)
            elif step is not None:  # a complex (mapping or sequence) key
                key += '.?' if key else '?'
        return key


_Loader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(r'^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$'),
    list('-+0123456789.'))


def yaml_problem(err: yaml.YAMLError) -> str:
    """A YAML error on one line.

    ``line N: <problem>`` (PyYAML's own messages span several lines, with the text around the
    mark).
    """
    mark = getattr(err, 'problem_mark', None)
    where = f'line {mark.line + 1}: ' if isinstance(mark, Mark) else ''
    return f'{where}{getattr(err, "problem", None) or "invalid YAML"}'


def load_yaml(text: str) -> Any:
    """Parse a test file's YAML text (safe; exponent floats without a dot or sign allowed).

    Raises:
        YAMLAliasError: the text holds an alias (``*name``); a :class:`yaml.YAMLError`.
        YAMLDepthError: collections nested deeper than :data:`MAX_DEPTH`; a
            :class:`yaml.YAMLError`.
        YAMLDuplicateKeyError: a mapping has a key twice; a :class:`yaml.YAMLError`.
        yaml.YAMLError: the text is not YAML.
    """
    return yaml.load(text, Loader=_Loader)


def read_yaml_file(path: str | Path, *, what: str = 'a YAML file') -> Any:
    """Read and parse a YAML file with :func:`load_yaml`.

    A regular file of at most :data:`~pd_common.config.files.MAX_TEXT_BYTES`, UTF-8 (see
    :mod:`.files`).

    Args:
        path: the file.
        what: what the file is, for the message of a file too large (``'a test file'``).

    Raises:
        OSError: the file cannot be read; an
            :class:`~pd_common.config.files.InputFileError` (one line naming it) for a file
            that is not a regular one, too large, or not UTF-8.
        YAMLAliasError, YAMLDepthError, YAMLDuplicateKeyError: see :func:`load_yaml`.
        yaml.YAMLError: the text is not YAML.
    """
    return load_yaml(read_text(Path(path), limit=MAX_TEXT_BYTES, what=what))
