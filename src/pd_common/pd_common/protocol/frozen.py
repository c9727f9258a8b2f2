"""The step's records made on its hot path without their dataclass ``__init__``.

A frozen dataclass's generated ``__init__`` sets each field through ``object.__setattr__``
(1.9 µs for a :class:`~.messages.Command` here, 1.0 for a :class:`~.signature.Signature`), and
:func:`dataclasses.replace` looks every field up first (3.4 µs for a feedback). The records a
step makes several times over (a message read by its layout, a signature, an answer stamped
with its test and epoch) are made here by filling the new instance's ``__dict__`` (0.4 µs for a
signature): the same object, equal and hashing as one ``__init__`` makes.

The makers take every field, positionally, in the dataclass's order (the tests check that they
cover every field of their class); like ``__init__``, they convert and check nothing.
"""

from __future__ import annotations

from typing import Any, TypeVar

from ..types import FloatArray
from .messages import Command, Feedback, FeedbackStatus, StateOrigin
from .signature import Signature

__all__ = ['amended', 'command_of', 'feedback_of', 'signature_of']

R = TypeVar('R')
_new = object.__new__


def signature_of(key_id: str, session: str, sequence: int, mac: bytes) -> Signature:
    """``Signature(key_id, session, sequence, mac)``."""
    record = _new(Signature)
    fields = record.__dict__
    fields['key_id'] = key_id
    fields['session'] = session
    fields['sequence'] = sequence
    fields['mac'] = mac
    return record


def command_of(test_id: str, step: int, test_time: float, dof_names: tuple[str, ...],
               target_displacement: tuple[float, ...], iteration: int,
               control_mode: tuple[int, ...], target_force: tuple[float, ...]) -> Command:
    """``Command(...)`` of every field, in order."""
    record = _new(Command)
    fields = record.__dict__
    fields['test_id'] = test_id
    fields['step'] = step
    fields['test_time'] = test_time
    fields['dof_names'] = dof_names
    fields['target_displacement'] = target_displacement
    fields['iteration'] = iteration
    fields['control_mode'] = control_mode
    fields['target_force'] = target_force
    return record


def feedback_of(test_id: str, step: int, measured_displacement: tuple[float, ...] | FloatArray,
                restoring_force: tuple[float, ...] | FloatArray, status: FeedbackStatus,
                message: str, iteration: int, epoch: str, state_origin: StateOrigin
                ) -> Feedback:
    """``Feedback(...)`` of every field, in order."""
    record = _new(Feedback)
    fields = record.__dict__
    fields['test_id'] = test_id
    fields['step'] = step
    fields['measured_displacement'] = measured_displacement
    fields['restoring_force'] = restoring_force
    fields['status'] = status
    fields['message'] = message
    fields['iteration'] = iteration
    fields['epoch'] = epoch
    fields['state_origin'] = state_origin
    return record


def amended(record: R, **changes: Any) -> R:
    """``record`` with ``changes``, as :func:`dataclasses.replace` makes it.

    For a record without ``__post_init__``; a name that is not one of its fields is a
    ``TypeError``.
    """
    if not changes.keys() <= record.__dataclass_fields__.keys():  # type: ignore[attr-defined]
        msg = f'{type(record).__name__}: no field among {sorted(changes)}'
        raise TypeError(msg)
    copy = _new(type(record))
    fields = copy.__dict__
    fields.update(record.__dict__)
    fields.update(changes)
    return copy
