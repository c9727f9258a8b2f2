"""Reading test and configuration files: one YAML loader for every package.

PyYAML's safe loader, with YAML 1.2's reading of exponent floats such as ``1e5`` and
``3.5e7`` (YAML 1.1 reads them as strings), that refuses aliases (``*name``): a test file has
no use for them, and a few lines of nested aliases (a "billion laughs") expand to billions of
values. Anchors (``&name``) alone are harmless and allowed.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml
from yaml.error import Mark
from yaml.nodes import Node, ScalarNode

__all__ = ['YAMLAliasError', 'YAMLError', 'load_yaml', 'read_yaml_file']

YAMLError = yaml.YAMLError


class YAMLAliasError(yaml.MarkedYAMLError):
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

    def __str__(self) -> str:
        where = '' if self.problem_mark is None else f'line {self.problem_mark.line + 1}: '
        return f'{where}{self.problem}'


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader, reading ``1e5`` as a number (YAML 1.2) and refusing aliases."""

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
        self._where.append(index)
        try:
            return super().compose_node(parent, index)
        finally:
            self._where.pop()

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


def load_yaml(text: str) -> Any:
    """Parse a test file's YAML text (safe; exponent floats without a dot or sign allowed).

    Raises:
        YAMLAliasError: the text holds an alias (``*name``); a :class:`yaml.YAMLError`.
        yaml.YAMLError: the text is not YAML.
    """
    return yaml.load(text, Loader=_Loader)


def read_yaml_file(path: str | Path) -> Any:
    """Read and parse a YAML file with :func:`load_yaml`.

    Raises:
        OSError: the file cannot be read.
        YAMLAliasError: the file holds an alias (``*name``); a :class:`yaml.YAMLError`.
        yaml.YAMLError: the text is not YAML.
    """
    return load_yaml(Path(path).read_text(encoding='utf-8'))
