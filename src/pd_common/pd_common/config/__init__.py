"""Reading configuration files (one YAML loader for every package)."""

from __future__ import annotations

from .loader import YAMLAliasError, YAMLError, load_yaml, read_yaml_file

__all__ = ['YAMLAliasError', 'YAMLError', 'load_yaml', 'read_yaml_file']
