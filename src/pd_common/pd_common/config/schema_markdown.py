"""The reference page of every key of a file, generated from its JSON Schema.

Markdown: one section per mapping, one table row per key; no HTML, links only to the page's
own sections.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from typing import Any

__all__ = ['markdown_reference']

_HEADER = {
    False: ('# Test file reference',
            ('Every key of a test file, its type, default and bounds, generated from the typed '
            'schema (`pd_common.config.schema`) by `./pd schema --markdown`; do not edit by '
            'hand. Editors with the YAML language server validate and complete a test file '
            'whose first line is `# yaml-language-server: $schema=<path of '
            'src/pd_common/schema/test_file.schema.json>` (`./pd schema` prints it).')),
    True: ('# Bridge parameter file reference',
           ("Every parameter of the actuator bridge's ROS parameter file "
           '(`<node>: {ros__parameters: {...}}`), generated from the typed schema by '
           '`./pd schema --bridge --markdown`; do not edit by hand.')),
}
#: The header of the driver settings' page.
_DRIVER_HEADER = ('# Driver settings file reference',
                  ("Every key of an actuator driver's settings file (the bridge's "
                   '`driver_config`: `daqmx`, `emulator`, `ramp_hold`, `errors`), generated '
                   'from the typed schema by `./pd schema --driver --markdown`; do not edit by '
                   'hand.'))

_BOUNDS = (('exclusiveMinimum', '>'), ('minimum', '>='), ('exclusiveMaximum', '<'),
           ('maximum', '<='))


def _ref_name(ref: str) -> str:
    return ref.rsplit('/', 1)[-1]


def _anchor(name: str) -> str:
    """The anchor MkDocs (python-markdown's toc) gives a heading ``name``."""
    return re.sub(r'[-\s]+', '-', re.sub(r'[^\w\s-]', '', name).strip().lower())


def _number(value: Any) -> str:
    return f'{value:g}' if isinstance(value, float) else json.dumps(value)


def _type(schema: Mapping[str, Any]) -> str:
    """A schema's type in words: ``number > 0``, ``list of string``, ``[Element](#element)``."""
    if '$ref' in schema:
        name = _ref_name(schema['$ref'])
        return f'[{name}](#{_anchor(name)})'
    if 'const' in schema:
        return f'`{json.dumps(schema["const"])}`'
    if 'enum' in schema:
        return 'one of ' + ', '.join(f'`{json.dumps(value)}`' for value in schema['enum'])
    for key in ('anyOf', 'oneOf'):
        if key in schema:
            parts = [_type(member) for member in schema[key]]
            return ' or '.join(dict.fromkeys(parts))
    kind = schema.get('type')
    if kind == 'array':
        return _list(schema)
    if kind == 'object':
        return _mapping(schema)
    if kind is None:
        return 'any'
    return _scalar(schema, str(kind))


def _list(schema: Mapping[str, Any]) -> str:
    """An array's type: ``list of number (2 items)``."""
    text = f'list of {_grouped(schema.get("items", {}))}'
    low, high = schema.get('minItems'), schema.get('maxItems')
    if low is not None and low == high:
        return f'{text} ({low} items)'
    if high is None and low:
        return f'{text} (at least {low})'
    if high is not None:
        return f'{text} ({low or 0} to {high} items)'
    return text


def _mapping(schema: Mapping[str, Any]) -> str:
    """An object's type (not a model's): ``mapping of name to number``."""
    values = schema.get('additionalProperties')
    if isinstance(values, Mapping) and values:
        return f'mapping of name to {_grouped(values)}'
    for pattern, member in schema.get('patternProperties', {}).items():
        return f'mapping of name (matching `{pattern}`) to {_grouped(member)}'
    return 'mapping'


def _scalar(schema: Mapping[str, Any], kind: str) -> str:
    """A scalar's type with its bounds: ``number > 0, < 1``, ``string matching `...` ``."""
    text = {'boolean': 'true/false'}.get(kind, kind)
    bounds = [f'{sign} {_number(schema[key])}' for key, sign in _BOUNDS if key in schema]
    if bounds:
        text += ' ' + ', '.join(bounds)
    if 'pattern' in schema:
        text += f' matching `{schema["pattern"]}`'
    elif 'minLength' in schema:
        text += ' (not empty)'
    return text


def _grouped(schema: Mapping[str, Any]) -> str:
    """:func:`_type` in parentheses when it is a choice (``list of (number or string)``)."""
    text = _type(schema)
    return f'({text})' if ' or ' in text else text


def _cell(text: str) -> str:
    """Text for a table cell: one line, pipes escaped."""
    return ' '.join(text.split()).replace('|', '\\|')


def _default(prop: Mapping[str, Any], required: bool) -> str:
    if required:
        return 'required'
    if 'default' not in prop:
        return ''
    value = prop['default']
    if value is None:
        return '`null`'
    return f'`{json.dumps(value, ensure_ascii=False)}`'


def _refs(schema: Any, suffix: str = '') -> list[tuple[str, str]]:
    """The definitions a schema refers to, in order, each with the path to it.

    The path goes ``.N`` through a list's items, ``.<name>`` through a mapping's values.
    """
    found: list[tuple[str, str]] = []
    if isinstance(schema, Mapping):
        if '$ref' in schema:
            found.append((_ref_name(schema['$ref']), suffix))
        for key, value in schema.items():
            if key == 'items':
                found.extend(_refs(value, f'{suffix}.N'))
            elif key == 'additionalProperties':
                found.extend(_refs(value, f'{suffix}.<name>'))
            elif key == 'patternProperties' and isinstance(value, Mapping):
                for member in value.values():
                    found.extend(_refs(member, f'{suffix}.<name>'))
            else:
                found.extend(_refs(value, suffix))
    elif isinstance(schema, list):
        for item in schema:
            found.extend(_refs(item, suffix))
    return found


def _section(name: str, schema: Mapping[str, Any], where: str) -> list[str]:
    lines = [f'## {name}', '']
    if where:
        lines += [f'At `{where}`.', '']
    description = schema.get('description')
    if description:
        lines += [' '.join(str(description).split()), '']
    properties: Mapping[str, Any] = schema.get('properties', {})
    if not properties:
        values = schema.get('additionalProperties')
        if isinstance(values, Mapping):
            lines += [f'A mapping of name to {_type(values)}.', '']
        return lines
    required = set(schema.get('required', ()))
    lines += ['| Key | Type | Default | Description |', '| --- | --- | --- | --- |']
    for key, prop in properties.items():
        default = _cell(_default(prop, key in required))
        lines.append(f'| `{key}` | {_cell(_type(prop))} | {default} '
                     f'| {_cell(str(prop.get("description", "")))} |')
    return [*lines, '']


def markdown_reference(schema: Mapping[str, Any], *, bridge: bool = False,
                       driver: bool = False) -> str:
    """The reference page of the JSON Schema ``schema``.

    Of a test file, of the bridge's parameter file with ``bridge``, or of a driver's settings
    file with ``driver``: one section per mapping, first the file's own, then each definition
    in the order the file reaches it.
    """
    title, intro = _DRIVER_HEADER if driver else _HEADER[bridge]
    definitions: Mapping[str, Any] = schema.get('$defs', {})
    root_name = str(schema.get('title', 'File'))
    lines = [title, '', intro, '']
    lines += _section(root_name, schema, '')
    where: dict[str, str] = {}
    order: list[str] = []
    queue: list[tuple[str, Mapping[str, Any]]] = [('', schema)]
    while queue:
        path, current = queue.pop(0)
        for key, prop in current.get('properties', {}).items():
            for name, suffix in _refs(prop):
                if name not in where:
                    where[name] = f'{path}.{key}{suffix}' if path else f'{key}{suffix}'
                    order.append(name)
                    queue.append((where[name], definitions.get(name, {})))
        for name, suffix in _refs(current.get('additionalProperties'), '.<name>'):
            if name not in where:
                where[name] = f'{path}{suffix}'.lstrip('.')
                order.append(name)
                queue.append((where[name], definitions.get(name, {})))
    order += [name for name in definitions if name not in where]
    for name in order:
        lines += _section(name, definitions[name], where.get(name, ''))
    return '\n'.join(lines).rstrip('\n') + '\n'
