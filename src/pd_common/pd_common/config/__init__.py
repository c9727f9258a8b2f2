"""Configuration files: their loader, the files a user names, and the typed schemas.

Reading configuration files (one YAML loader for every package), the files a user names
(regular files only, bounded, UTF-8), and the typed schema of the test file and the bridge's
parameter file (:mod:`.schema`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

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

if TYPE_CHECKING:
    from .bridge_file import read_bridge_parameter_file, read_driver_config
    from .schema import (
        BridgeParameterFile,
        DriverConfigFile,
        TestFileModel,
        json_schema,
        validate_bridge_parameters,
        validate_elements,
        validate_model,
        validate_section,
        validate_test_file,
    )
    from .schema_base import SchemaError
    from .test_file import TestFile, read_test_data, read_test_file

__all__ = [
    'MAX_DEPTH',
    'MAX_TEXT_BYTES',
    'BridgeParameterFile',
    'DriverConfigFile',
    'InputFileError',
    'SchemaError',
    'TestFile',
    'TestFileModel',
    'YAMLAliasError',
    'YAMLDepthError',
    'YAMLDuplicateKeyError',
    'YAMLError',
    'default_bridge_parameter_file',
    'describe_size',
    'existing_path',
    'json_schema',
    'load_yaml',
    'open_regular_file',
    'read_bridge_parameter_file',
    'read_bytes',
    'read_driver_config',
    'read_test_data',
    'read_test_file',
    'read_text',
    'read_yaml_file',
    'validate_bridge_parameters',
    'validate_elements',
    'validate_model',
    'validate_section',
    'validate_test_file',
    'yaml_problem',
]

#: The names of the typed schema (:mod:`.schema`), imported on first use: building its models
#: takes a third of a second, which a process that reads no test file need not pay.
_SCHEMA_NAMES = ('BridgeParameterFile', 'DriverConfigFile', 'SchemaError', 'TestFileModel',
                 'json_schema', 'validate_bridge_parameters', 'validate_elements',
                 'validate_model', 'validate_section', 'validate_test_file')
#: The names of :mod:`.test_file` (reading a test file once per process), imported likewise.
_TEST_FILE_NAMES = ('TestFile', 'read_test_data', 'read_test_file')
#: The names of :mod:`.bridge_file` (the bridge's files), imported likewise.
_BRIDGE_FILE_NAMES = ('default_bridge_parameter_file', 'read_bridge_parameter_file',
                      'read_driver_config')


def __getattr__(name: str) -> Any:
    """The names of :mod:`.schema`, imported when first asked for."""
    if name in _SCHEMA_NAMES:
        from . import schema  # noqa: PLC0415 (on first use: see _SCHEMA_NAMES)

        return getattr(schema, name)
    if name in _TEST_FILE_NAMES:
        from . import test_file  # noqa: PLC0415 (on first use: see _SCHEMA_NAMES)

        return getattr(test_file, name)
    if name in _BRIDGE_FILE_NAMES:
        from . import bridge_file  # noqa: PLC0415 (on first use: see _SCHEMA_NAMES)

        return getattr(bridge_file, name)
    msg = f'module {__name__!r} has no attribute {name!r}'
    raise AttributeError(msg)
