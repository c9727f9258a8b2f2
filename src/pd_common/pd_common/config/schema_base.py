"""The building blocks of the typed schemas (pydantic v2).

A strict base model, the number types of a test file, and the one-line message of a refusal.

Every model refuses unknown keys (``extra='forbid'``) and reads strictly: a number is a YAML
number (an integer or a float, never ``true`` or ``'1e5'``), finite (no ``.inf``, ``.nan``),
a string is a string. Errors become one line, ``<file>: <dotted.path>: <what is wrong>, got
<value>`` (:func:`one_line`), e.g. ``test.yaml: specimen.elements.0.yield_force: must be > 0,
got -1``.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from typing import Annotated, Any, NoReturn

from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    ValidationError,
    WrapValidator,
)
from pydantic.functional_validators import AfterValidator
from pydantic_core import ErrorDetails, PydanticCustomError

__all__ = ['ConfigModel', 'Finite', 'FloatMatrix', 'NonNegative', 'NonPositive', 'Positive',
           'SchemaError', 'by_shape', 'check', 'either', 'error_path', 'one_line', 'refuse_at',
           'show_value']


class SchemaError(ValueError):
    """A configuration file refused by its schema.

    ``str()`` is one line, ``<file>: <dotted.path>: <what is wrong>, got <value>``.

    Attributes:
        source: the file (as named in the message).
        path: the dotted path of the refused value (``''``: the whole file).
        problem: what is wrong, with the value (``must be > 0, got -1``).

    """

    def __init__(self, source: str, path: str, problem: str) -> None:
        """Name the file, the path and the problem."""
        where = f'{path}: ' if path else ''
        super().__init__(f'{source}: {where}{problem}')
        self.source = source
        self.path = path
        self.problem = problem


class ConfigModel(BaseModel):
    """A section of a configuration file: strict types, finite numbers, no unknown key."""

    model_config = ConfigDict(extra='forbid', strict=True, allow_inf_nan=False, frozen=True,
                              use_attribute_docstrings=True)


#: A finite number (an integer or a float; not a boolean).
Finite = Annotated[float, Field(allow_inf_nan=False)]
#: A finite number > 0.
Positive = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]
#: A finite number >= 0.
NonNegative = Annotated[float, Field(ge=0.0, allow_inf_nan=False)]
#: A finite number <= 0.
NonPositive = Annotated[float, Field(le=0.0, allow_inf_nan=False)]


def either(what: str) -> WrapValidator:
    """A validator for a union of shapes (a number, a list, a matrix): one refusal for all.

    A value fitting none of them is refused with one message, ``must be <what>``, instead of
    one per shape.
    """

    def validate(value: Any, handler: Callable[[Any], Any]) -> Any:
        try:
            return handler(value)
        except ValidationError:
            kind = 'shape'
            raise PydanticCustomError(kind, 'must be {what}', {'what': what}) from None

    return WrapValidator(validate)


def check(predicate: Callable[[Any], bool], problem: str) -> AfterValidator:
    """A validator refusing a value (already of its type) for which ``predicate`` is false.

    The message is ``<path>: <problem>, got <value>``.
    """

    def validate(value: Any) -> Any:
        if not predicate(value):
            kind = 'invalid'
            raise PydanticCustomError(kind, problem)
        return value

    return AfterValidator(validate)


#: The error type of :func:`refuse_at`.
_AT = 'refused_at'


def refuse_at(key: str, problem: str) -> NoReturn:
    """Refuse, from a check of a whole mapping, the value at ``key`` inside it.

    For the checks that compare keys (``command_min_voltage`` below ``command_max_voltage``,
    a channel used twice in a list): ``key`` is the dotted path of the refused value inside the
    validated one (``'1.command_channel'``), and the message is
    ``<path>.<key>: <problem>`` (``problem`` says the value itself). Called from a validator.

    Raises:
        PydanticCustomError: always (turned into one line by :func:`one_line`).
    """
    kind = _AT
    raise PydanticCustomError(kind, '{problem}', {'at': key, 'problem': problem})


def _shape(value: Any) -> str:
    """The shape of a value: ``mapping``, ``list``, ``number``, ``string`` or ``other``."""
    if isinstance(value, Mapping):
        return 'mapping'
    if isinstance(value, list):
        return 'list'
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return 'number'
    if isinstance(value, str):
        return 'string'
    return 'other'


def by_shape(fallback: str, **shapes: str) -> Discriminator:
    """A discriminator choosing a union's member (a :class:`pydantic.Tag`) by the value's shape.

    ``by_shape('mapping', list='list')`` takes the ``list`` member for a list and the
    ``mapping`` member for anything else (which then says what is wrong with it).
    """

    def choose(value: Any) -> str:
        return shapes.get(_shape(value), fallback)

    return Discriminator(choose)


#: A scalar, a list (a diagonal) or a list of rows (a matrix) of finite numbers.
FloatMatrix = Annotated[
    Annotated[Finite, Tag('number')]
    | Annotated[list[Annotated[Annotated[Finite, Tag('number')]
                               | Annotated[list[Finite], Tag('list')],
                               by_shape('number', list='list')]], Tag('list')],
    by_shape('number', list='list')]

#: What a string matching a pattern of the schemas is, in words, for messages (a pattern not
#: here is named as it is).
_PATTERN_WORDS = {
    r'^[A-Za-z0-9_.\-]{1,64}$': '1-64 letters, digits, "_", "-" or "."',
    r'^[A-Za-z][A-Za-z0-9_]{0,63}$': 'a name of letters, digits and _ starting with a letter',
    r'^\s*[^\s,:][^,:]*$': 'one physical channel such as Dev1/ao0 (no list or range)',
}


def _pattern_problem(pattern: str) -> str:
    words = _PATTERN_WORDS.get(pattern)
    return f'must match {pattern}' if words is None else f'must be {words}'


#: The messages of pydantic's error types, in the words of the project's parsers.
_MESSAGES: dict[str, Callable[[Mapping[str, Any]], str]] = {
    'greater_than': lambda ctx: f'must be > {ctx["gt"]:g}',
    'greater_than_equal': lambda ctx: f'must be >= {ctx["ge"]:g}',
    'less_than': lambda ctx: f'must be < {ctx["lt"]:g}',
    'less_than_equal': lambda ctx: f'must be <= {ctx["le"]:g}',
    'finite_number': lambda _: 'must be a finite number',
    'float_type': lambda _: 'must be a number',
    'float_parsing': lambda _: 'must be a number',
    'int_type': lambda _: 'must be an integer',
    'int_parsing': lambda _: 'must be an integer',
    'int_from_float': lambda _: 'must be an integer',
    'bool_type': lambda _: 'must be true or false',
    'string_type': lambda _: 'must be a string',
    'list_type': lambda _: 'must be a list',
    'dict_type': lambda _: 'must be a mapping',
    'model_type': lambda _: 'must be a mapping',
    'model_attributes_type': lambda _: 'must be a mapping',
    'literal_error': lambda ctx: f'must be one of {str(ctx["expected"]).replace(" or ", ", ")}',
    'string_too_short': lambda ctx: f'must have at least {ctx["min_length"]} character(s)',
    'string_pattern_mismatch': lambda ctx: _pattern_problem(ctx['pattern']),
    'too_short': lambda ctx: f'must have at least {ctx["min_length"]} item(s)',
    'too_long': lambda ctx: f'must have at most {ctx["max_length"]} item(s)',
}


def show_value(value: Any) -> str:
    """A value for a message, as YAML writes it.

    ``-1``, ``'abc'``, ``true``, ``null``, a short list or mapping (cut after 60 characters).
    """
    if value is None:
        return 'null'
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, (int, float)):
        return repr(value)
    try:
        text = json.dumps(value, default=str, ensure_ascii=False)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= 60 else f'{text[:57]}...'


def error_path(data: Any, loc: Sequence[int | str], *, key: bool = False) -> str:
    """The dotted path of an error location in ``data``.

    Pydantic's location also names the branch of a union (``float``, ``list[float]``, the tag of
    a discriminated union): those steps are not keys of the data and are left out, except the
    last one of a missing or unknown key (``key``).
    """
    parts: list[str] = []
    current: Any = data
    for number, step in enumerate(loc):
        last = number == len(loc) - 1
        inside = (step in current if isinstance(current, Mapping)
                  else isinstance(current, list) and isinstance(step, int)
                  and 0 <= step < len(current))
        if inside:
            current = current[step]
            parts.append(str(step))
        elif key and last and isinstance(current, Mapping):
            parts.append(str(step))  # a missing or unknown key
            current = None
    return '.'.join(parts)


#: The errors whose location ends with a key absent from the data (or a discriminator).
_KEY_ERRORS = ('missing', 'extra_forbidden', 'union_tag_invalid', 'union_tag_not_found')


def _problem(error: ErrorDetails) -> str:
    """What is wrong (without the value) in the project's words."""
    kind = error['type']
    ctx: Mapping[str, Any] = error.get('ctx') or {}
    if kind == 'missing':
        return 'is required'
    if kind == 'extra_forbidden':
        return 'unknown key'
    if kind == 'union_tag_invalid':
        return f'must be one of {ctx.get("expected_tags", "")}'
    if kind == 'union_tag_not_found':
        return 'is required'
    message = _MESSAGES.get(kind)
    if message is not None:
        try:
            return message(ctx)
        except (KeyError, TypeError, ValueError):
            pass
    text = error['msg']
    return text.removeprefix('Value error, ').removeprefix('Assertion failed, ')


def _score(data: Any, error: ErrorDetails) -> int:
    """How deep an error's location goes into ``data`` (the deepest of a union's is kept)."""
    path = error_path(data, error['loc'], key=error['type'] in _KEY_ERRORS)
    return path.count('.') + 1 if path else 0


def one_line(err: ValidationError, data: Any, source: str) -> SchemaError:
    """The first refusal of ``err`` as a :class:`SchemaError` of one line.

    ``err`` was raised validating ``data`` of the file ``source``.

    Of a union's several errors (one per shape tried), the one that reached deepest into the
    data is kept: ``[1, 'x']`` for a list of numbers is ``<key>.1: must be a number, got 'x'``.
    """
    errors = err.errors(include_url=False)
    best = max(errors, key=lambda error: _score(data, error))
    loc = list(best['loc'])
    kind = best['type']
    if kind == _AT:  # (a check of a mapping naming a key inside it: refuse_at)
        ctx: Mapping[str, Any] = best.get('ctx') or {}
        loc += [int(step) if step.isdigit() else step for step in str(ctx['at']).split('.')]
        return SchemaError(source, error_path(data, loc, key=True), str(ctx['problem']))
    if kind in ('union_tag_invalid', 'union_tag_not_found'):
        discriminator = str((best.get('ctx') or {}).get('discriminator', '')).strip("'")
        if discriminator.isidentifier():
            loc.append(discriminator)
    path = error_path(data, loc, key=kind in _KEY_ERRORS)
    problem = _problem(best)
    if kind in ('missing', 'union_tag_not_found'):
        return SchemaError(source, path, problem)
    value = best['input']
    if kind == 'union_tag_invalid':
        value = (best.get('ctx') or {}).get('tag', value)
    if kind == 'extra_forbidden' or (kind == 'value_error' and isinstance(value, (Mapping, list))):
        return SchemaError(source, path, problem)  # (a mapping's check names its keys)
    return SchemaError(source, path, f'{problem}, got {show_value(value)}')
