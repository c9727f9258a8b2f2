"""Reading configuration files (one YAML loader for every package) and the files a user names
(regular files only, bounded, UTF-8)."""

from __future__ import annotations

from .files import (
    MAX_TEXT_BYTES,
    InputFileError,
    describe_size,
    existing_path,
    open_regular_file,
    read_bytes,
    read_text,
)
from .loader import (
    MAX_DEPTH,
    YAMLAliasError,
    YAMLDepthError,
    YAMLDuplicateKeyError,
    YAMLError,
    load_yaml,
    read_yaml_file,
    yaml_problem,
)

__all__ = ['MAX_DEPTH', 'MAX_TEXT_BYTES', 'InputFileError', 'YAMLAliasError', 'YAMLDepthError',
           'YAMLDuplicateKeyError', 'YAMLError', 'describe_size', 'existing_path',
           'load_yaml', 'open_regular_file', 'read_bytes', 'read_text', 'read_yaml_file',
           'yaml_problem']
