"""Reading test and configuration files: one YAML loader for every package.

PyYAML's safe loader, with YAML 1.2's reading of exponent floats such as ``1e5`` and
``3.5e7`` (YAML 1.1 reads them as strings).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

__all__ = ['YAMLError', 'load_yaml', 'read_yaml_file']

YAMLError = yaml.YAMLError


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader, reading ``1e5`` and ``3.5e7`` as numbers as YAML 1.2 does."""


_Loader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(r'^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$'),
    list('-+0123456789.'))


def load_yaml(text: str) -> Any:
    """Parse a test file's YAML text (safe; exponent floats without a dot or sign allowed).

    Raises:
        yaml.YAMLError: the text is not YAML.
    """
    return yaml.load(text, Loader=_Loader)


def read_yaml_file(path: str | Path) -> Any:
    """Read and parse a YAML file with :func:`load_yaml`.

    Raises:
        OSError: the file cannot be read.
        yaml.YAMLError: the text is not YAML.
    """
    return load_yaml(Path(path).read_text(encoding='utf-8'))
