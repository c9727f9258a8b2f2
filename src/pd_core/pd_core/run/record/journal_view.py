"""A journal's records as text: one line each for a person, or one JSON object each.

The journal is binary (:mod:`.journal_format`); ``./pd journal RUN`` prints it with these, so
the last command a killed run sent, or the feedback that held it, can be read without code.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
from enum import Enum
from typing import Any

from pd_common.protocol import Command, Feedback, Signature, Status

from .journal import JournalRecord

__all__ = ['record_line', 'record_object']


def _plain(value: Any) -> Any:
    """A record's field as JSON takes it (enumerations by name, tuples as lists)."""
    if isinstance(value, Enum):
        return value.name
    if isinstance(value, (tuple, list)):
        return [_plain(item) for item in value]
    return value


def _signature(signature: Signature) -> dict[str, Any] | None:
    if not signature.signed:
        return None
    return {'key_id': signature.key_id, 'session': signature.session,
            'sequence': signature.sequence, 'mac': signature.mac.hex()}


def record_object(number: int, record: JournalRecord) -> dict[str, Any]:
    """One record as a JSON object: its number, kind, time, topic and content.

    A command, feedback or status has its fields by their protocol names (with its header
    stamp and signature); a definition its JSON; an event its fields; a raw record its size.
    """
    out: dict[str, Any] = {'n': number, 'kind': record.kind, 't_ns': record.t_ns,
                           'topic': record.topic}
    item = record.item
    if isinstance(item, (Command, Feedback, Status)):
        out.update({field.name: _plain(getattr(item, field.name))
                    for field in dataclasses.fields(item)})
        if record.kind in ('cmd', 'fb'):
            out['stamp_ns'] = record.stamp_ns
            out['signature'] = _signature(record.signature)
    elif record.kind == 'def':
        try:
            out['definition'] = json.loads(item)
        except ValueError:
            out['definition'] = item
    elif record.kind == 'ev':
        out.update({'event': item.get('what'),
                    **{key: value for key, value in item.items() if key != 'what'}})
    else:
        out['bytes'] = len(record.data)
    return out


def _values(values: Any) -> str:
    return '[' + ', '.join(f'{float(value):.6g}' for value in values) + ']'


def _time(t_ns: int) -> str:
    moment = datetime.datetime.fromtimestamp(t_ns // 1_000_000_000, tz=datetime.UTC)
    return f'{moment:%Y-%m-%dT%H:%M:%S}.{t_ns % 1_000_000_000 // 1000:06d}Z'


def _signed(signature: Signature) -> str:
    return f'  signed {signature.key_id} #{signature.sequence}' if signature.signed else ''


def _content(record: JournalRecord) -> str:
    item = record.item
    if isinstance(item, Command):
        text = (f'step {item.step}.{item.iteration}  t {item.test_time:.6g} s  '
                f'x {_values(item.target_displacement)}')
        if item.control_mode:
            text += (f'  mode {[int(mode) for mode in item.control_mode]}  '
                     f'fx {_values(item.target_force)}')
        return text + _signed(record.signature)
    if isinstance(item, Feedback):
        text = (f'step {item.step}.{item.iteration}  {item.status.name.lower()}  '
                f'xm {_values(item.measured_displacement)}  r {_values(item.restoring_force)}')
        if item.message:
            text += f'  "{item.message}"'
        if item.state_origin.value:
            text += f'  {item.state_origin.name.lower()} state'
        return text + _signed(record.signature)
    if isinstance(item, Status):
        text = f'{item.state.name.lower()}  step {item.step}/{item.total_steps}'
        if item.node:
            text += f'  {item.node}'
        if item.emergency_stop:
            text += '  EMERGENCY STOP'
        if item.operator_hold:
            text += '  operator hold'
        return text + (f'  "{item.message}"' if item.message else '')
    if record.kind == 'def':
        return f'test definition ({len(record.data):,} bytes)'
    if record.kind == 'ev':
        rest = {key: value for key, value in item.items() if key != 'what'}
        return f'{item["what"]}  {json.dumps(rest, sort_keys=True)}' if rest else item['what']
    return f'{len(record.data):,} bytes'


def record_line(number: int, record: JournalRecord) -> str:
    """One record as a line: its number, time (UTC), kind, topic and what it says."""
    topic = record.topic or '-'
    return f'{number:>7}  {_time(record.t_ns)}  {record.kind:<3}  {topic:<24}  {_content(record)}'
