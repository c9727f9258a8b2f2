"""One typed schema for the test file, the bridge's parameter file and its driver's settings.

:func:`validate_test_file` and :func:`validate_bridge_parameters` check parsed YAML against
the models (:class:`~.schema_test_file.TestFileModel`,
:class:`~.schema_bridge.BridgeParameterFile`) and return them typed, or raise a
:class:`~.schema_base.SchemaError` of one line naming the file and the dotted path::

    test.yaml: specimen.elements.0.yield_force: must be > 0, got -1

The JSON Schema of both files is generated from the models (:func:`json_schema`) and shipped
in ``src/pd_common/schema/`` (installed in ``share/pd_common/schema/``), so that YAML editors
validate and complete test files (``# yaml-language-server: $schema=<path>``); the reference
page ``docs/reference/test-file.md`` is generated from it (:mod:`.schema_markdown`).

Command line: ``./pd schema`` (:mod:`.schema_cli`).
"""

from __future__ import annotations

import json
from collections.abc import Collection, Mapping
from typing import Annotated, Any, TypeVar

from pydantic import BaseModel, Field, TypeAdapter, ValidationError

from .schema_base import SchemaError, one_line
from .schema_bridge import BridgeParameterFile, BridgeParameters, SiteBridgeParameters
from .schema_driver import DriverConfigFile
from .schema_specimen import SpecimenSection
from .schema_test_file import (
    CollapseSection,
    DampingSection,
    Element,
    ProbeSection,
    ProtocolSection,
    SiteSettings,
    TestFileModel,
    TestSection,
)

__all__ = ['BRIDGE_SCHEMA_FILE', 'DRIVER_CONFIG_SCHEMA_FILE', 'JSON_SCHEMA_DIALECT',
           'TEST_FILE_SCHEMA_FILE', 'BridgeParameterFile', 'BridgeParameters',
           'DriverConfigFile', 'SchemaError', 'SiteBridgeParameters', 'SiteSettings',
           'SpecimenSection', 'TestFileModel', 'json_schema', 'json_schema_text',
           'validate_bridge_parameters', 'validate_elements', 'validate_model',
           'validate_section', 'validate_test_file']

#: The JSON Schema dialect of the generated schemas.
JSON_SCHEMA_DIALECT = 'https://json-schema.org/draft/2020-12/schema'
#: The file names of the shipped schemas (in ``src/pd_common/schema/``).
TEST_FILE_SCHEMA_FILE = 'test_file.schema.json'
BRIDGE_SCHEMA_FILE = 'bridge_parameters.schema.json'
DRIVER_CONFIG_SCHEMA_FILE = 'driver_config.schema.json'

#: The titles of the test file's and the bridge parameter file's schemas.
_TITLES = {False: 'Pseudo-dynamic test file', True: 'Actuator bridge parameter file'}
#: The title of the driver settings' schema.
_DRIVER_TITLE = 'Actuator driver settings file'

_Model = TypeVar('_Model', bound=BaseModel)


def validate_test_file(data: Any, source: str, *,
                       hysteresis_models: Collection[str] | None = None,
                       broken_models: Mapping[str, str] | None = None) -> TestFileModel:
    """The test file ``data`` (parsed YAML) as a typed :class:`TestFileModel`.

    Args:
        data: the parsed file (``None``, an empty file, is an empty mapping).
        source: the file's name for the message.
        hysteresis_models: the registered hysteresis models, built-ins and plug-ins
            (``pd_common.specimen.HYSTERESIS_MODELS``): a specimen's ``model`` must be one of
            them (``None``: any registry name is taken; the specimen's builder checks it).
        broken_models: plug-in models that did not load, with the reason (in the message).

    Raises:
        SchemaError: one line, ``<source>: <dotted.path>: <what is wrong>, got <value>``.

    """
    data = {} if data is None else data
    if not isinstance(data, dict):
        msg = f'a test file must be a mapping of sections, got {type(data).__name__}'
        raise SchemaError(source, '', msg)
    context = None if hysteresis_models is None else {
        'hysteresis_models': tuple(hysteresis_models),
        'hysteresis_broken': dict(broken_models or {})}
    try:
        return TestFileModel.model_validate(data, context=context)
    except ValidationError as err:
        raise one_line(err, data, source) from None


#: The parts of a test file a reader may validate alone (:func:`validate_section`), by path.
_SECTIONS: dict[str, TypeAdapter[Any]] = {
    'structure.elements': TypeAdapter(Annotated[list[Element], Field(min_length=1)]),
    'test': TypeAdapter(TestSection),
    'protocol': TypeAdapter(ProtocolSection),
    'probe': TypeAdapter(ProbeSection),
    'collapse': TypeAdapter(CollapseSection),
    'structure.damping': TypeAdapter(DampingSection),
    'ground_motion': TypeAdapter(TestFileModel.model_fields['ground_motion'].rebuild_annotation()),
    'sites': TypeAdapter(TestFileModel.model_fields['sites'].rebuild_annotation()),
}


def validate_section(path: str, data: Any, source: str) -> Any:
    """One part of a test file (parsed YAML), at the dotted ``path``, as its typed model.

    For the readers that build a part before the whole file is validated: the sections
    ``test``, ``protocol``, ``probe``, ``collapse``, ``ground_motion``, ``structure.damping``
    (a mapping), ``sites`` and ``structure.elements`` (whose hysteresis models, and those of
    the sites' specimens, are any registry name here: their builder checks it).

    Raises:
        SchemaError: one line, ``<source>: <path>.<key>: <what is wrong>, got <value>``.

    """
    try:
        return _SECTIONS[path].validate_python(data, strict=True)
    except ValidationError as err:
        refusal = one_line(err, data, source)
        where = f'{path}.{refusal.path}' if refusal.path else path
        raise SchemaError(source, where, refusal.problem) from None


def validate_elements(data: Any, source: str) -> list[Element]:
    """A test file's ``structure.elements`` as typed elements (:func:`validate_section`)."""
    elements: list[Element] = validate_section('structure.elements', data, source)
    return elements


def validate_model(model: type[_Model], data: Any, source: str, path: str = '') -> _Model:
    """``data`` (parsed YAML, or a mapping of values) as the typed ``model``.

    Args:
        model: a model of the schema (:class:`~.schema_driver.EmulatorSection`, ...).
        data: its values.
        source: the file's name (or the object's) for the message.
        path: the dotted path of ``data`` in its file (``'emulator'``), prefixed to the path of
            a refused value (``''``: the whole file).

    Raises:
        SchemaError: one line, ``<source>: <path>.<key>: <what is wrong>, got <value>``.

    """
    try:
        return model.model_validate(data)
    except ValidationError as err:
        refusal = one_line(err, data, source)
        where = '.'.join(part for part in (path, refusal.path) if part)
        raise SchemaError(source, where, refusal.problem) from None


def validate_bridge_parameters(data: Any, source: str) -> BridgeParameterFile:
    """A bridge's ROS parameter file ``data`` (parsed YAML) as a :class:`BridgeParameterFile`.

    Raises:
        SchemaError: one line naming ``source`` and the dotted path
            (``bridge.yaml: /**.ros__parameters.max_force: must be > 0, got -1``).

    """
    data = {} if data is None else data
    try:
        return BridgeParameterFile.model_validate(data)
    except ValidationError as err:
        raise one_line(err, data, source) from None


def json_schema(*, bridge: bool = False, driver: bool = False) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of a test file.

    Or of the bridge's parameter file (``bridge``), or of a driver's settings file
    (``driver``: the bridge's ``driver_config``).
    """
    model: type[BaseModel] = (DriverConfigFile if driver else BridgeParameterFile if bridge
                              else TestFileModel)
    schema = model.model_json_schema(mode='validation')
    schema['title'] = _DRIVER_TITLE if driver else _TITLES[bridge]
    return {'$schema': JSON_SCHEMA_DIALECT, **_markdown_code(schema)}


def _markdown_code(schema: Any) -> Any:
    """``schema`` as editors read it: Markdown code, closed mappings.

    The docstrings' reStructuredText code (````x````) is written as Markdown's (```x```), as
    editors show descriptions, and the mappings whose keys follow a pattern are closed to other
    keys (as the models are).
    """
    if isinstance(schema, dict):
        done = {key: value.replace('``', '`') if key == 'description' and isinstance(value, str)
                else _markdown_code(value) for key, value in schema.items()}
        if 'patternProperties' in done and 'additionalProperties' not in done:
            done['additionalProperties'] = False
        return done
    if isinstance(schema, list):
        return [_markdown_code(item) for item in schema]
    return schema


def json_schema_text(*, bridge: bool = False, driver: bool = False) -> str:
    """:func:`json_schema` as the shipped file's text (indented, ending with a newline)."""
    text = json.dumps(json_schema(bridge=bridge, driver=driver), indent=2, ensure_ascii=False)
    return text + '\n'
