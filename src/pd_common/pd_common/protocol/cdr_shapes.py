"""Step messages of a known shape, encoded and read by one compiled layout.

A step command's or feedback's strings, array lengths and modes (its *shape*) are the same
step after step; only its numbers change. For each shape in use the whole message is one
:class:`struct.Struct`: the constant runs (padding, counts, strings) as ``Ns`` fields, the
numbers as theirs. Encoding packs the numbers between the runs; reading unpacks bytes of the
shape's exact length and takes them only if every constant run is the one of the message the
layout was learned from (which the full reader checked), so any other byte than a number's
sends a message to the full reader. A layout is kept only if it reproduces the full encoder's
bytes, or the full reader's record, for the message it was made from. :mod:`.cdr` uses it.
"""

from __future__ import annotations

import operator
import struct
from collections.abc import Callable
from typing import Any, NamedTuple

from .cdr_parts import (
    ENCAPSULATION,
    FEEDBACK_STATUS,
    NS,
    PAD,
    STATE_ORIGIN,
    STEP,
    STEP_TIME,
    U32,
    Decoded,
    string_bytes,
)
from .frozen import command_of, feedback_of, signature_of
from .messages import Command, Feedback, FeedbackStatus, StateOrigin
from .signature import Signature

__all__ = ['decode_command', 'decode_feedback', 'encode_command', 'encode_feedback']

_MAX_SHAPES = 64  # layouts kept per message type (the cache is emptied when full)


class _Layout:
    """Builds one shape's layout: constant runs and fields, as the encoder lays them out."""

    def __init__(self) -> None:
        self.codes: list[str] = []
        self.consts: list[bytes] = []
        self.const_at: list[int] = []  # the index of each constant run among the values
        self.values = 0                # values unpacked so far
        self.size = 0
        self.covered = 0               # where the bytes a MAC covers end
        self._run = bytearray()

    def const(self, data: bytes) -> None:
        self._run += data
        self.size += len(data)

    def pad4(self) -> None:
        self.const(PAD[-self.size & 3])

    def pad8(self) -> None:
        self.const(PAD[(4 - self.size) & 7])

    def _close_run(self) -> None:
        self.codes.append(f'{len(self._run)}s')
        self.consts.append(bytes(self._run))
        self.const_at.append(self.values)
        self.values += 1
        self._run.clear()

    def field(self, code: str, size: int, values: int) -> None:
        """A field of ``values`` numbers (``size`` bytes), after the constant run before it."""
        self._close_run()
        self.codes.append(code)
        self.size += size
        self.values += values

    def doubles(self, count: int) -> None:
        self.pad4()
        self.const(U32.pack(count))
        if count:
            self.pad8()
        self.field(f'{count}d', 8 * count, count)

    def signature(self, key_id: str, session: str, mac_bytes: int) -> None:
        self.pad4()
        self.const(string_bytes(key_id))
        self.pad4()
        self.const(string_bytes(session))
        self.pad8()
        self.field('Q', 8, 1)
        self.pad4()
        self.covered = self.size
        self.const(U32.pack(mac_bytes))
        self.field(f'{mac_bytes}s', mac_bytes, 1)

    def header(self, test_id: str) -> None:
        self.const(ENCAPSULATION)
        self.field('iI', 8, 2)                  # sec, nanosec
        self.const(b'\x01\x00\x00\x00\x00')   # frame_id: '' (its length 1, its NUL)
        self.pad4()
        self.const(string_bytes(test_id))

    def compile(self) -> _Compiled:
        self._close_run()
        return _Compiled(struct.Struct('<' + ''.join(self.codes)), tuple(self.consts),
                         operator.itemgetter(*self.const_at), self.covered)


class _Compiled(NamedTuple):
    """One shape's layout: the message's struct, its constant runs, and where they are."""

    layout: struct.Struct
    consts: tuple[bytes, ...]
    pick_consts: Callable[[tuple[Any, ...]], tuple[Any, ...]]
    covered: int


def _command_shape(command: Command, signature: Signature) -> _Compiled:
    """The layout of ``command``'s shape, signed as ``signature`` (its MAC's length)."""
    shape = _Layout()
    shape.header(command.test_id)
    shape.pad8()
    shape.field('QI4xd', STEP_TIME.size, 3)     # step, iteration, test_time
    shape.pad4()
    shape.const(U32.pack(len(command.dof_names)))
    for name in command.dof_names:
        shape.pad4()
        shape.const(string_bytes(name))
    shape.doubles(len(command.target_displacement))
    shape.pad4()
    shape.const(U32.pack(len(command.control_mode)) + bytes(command.control_mode))
    shape.doubles(len(command.target_force))
    shape.signature(signature.key_id, signature.session, len(signature.mac))
    return shape.compile()


def _feedback_shape(feedback: Feedback, signature: Signature) -> _Compiled:
    """The layout of ``feedback``'s shape, signed as ``signature`` (its MAC's length)."""
    shape = _Layout()
    shape.header(feedback.test_id)
    shape.pad8()
    shape.field('QI', STEP.size, 2)             # step, iteration
    shape.doubles(len(feedback.measured_displacement))
    shape.doubles(len(feedback.restoring_force))
    shape.field('B', 1, 1)                        # status
    shape.pad4()
    shape.const(string_bytes(feedback.message))
    shape.pad4()
    shape.const(string_bytes(feedback.epoch))
    shape.field('B', 1, 1)                        # state origin
    shape.signature(signature.key_id, signature.session, len(signature.mac))
    return shape.compile()


def _pack_command(shape: _Compiled, command: Command, stamp_ns: int, signature: Signature
                 ) -> bytes:
    """The bytes of ``command`` (of ``shape``'s shape) stamped and signed."""
    sec, nanosec = divmod(stamp_ns, NS)
    c = shape.consts
    return shape.layout.pack(c[0], sec, nanosec, c[1], command.step, command.iteration,
                             command.test_time, c[2], *command.target_displacement, c[3],
                             *command.target_force, c[4], signature.sequence, c[5],
                             signature.mac, c[6])


def _pack_feedback(shape: _Compiled, feedback: Feedback, stamp_ns: int, signature: Signature
                  ) -> bytes:
    """The bytes of ``feedback`` (of ``shape``'s shape) stamped and signed."""
    sec, nanosec = divmod(stamp_ns, NS)
    c = shape.consts
    return shape.layout.pack(c[0], sec, nanosec, c[1], feedback.step, feedback.iteration, c[2],
                             *feedback.measured_displacement, c[3], *feedback.restoring_force,
                             c[4], feedback.status, c[5], feedback.state_origin, c[6],
                             signature.sequence, c[7], signature.mac, c[8])


_COMMAND_SHAPES: dict[tuple[Any, ...], _Compiled | None] = {}
_FEEDBACK_SHAPES: dict[tuple[Any, ...], _Compiled | None] = {}


def _command_key(command: Command, signature: Signature) -> tuple[Any, ...]:
    """What a command's layout depends on."""
    return (command.test_id, command.dof_names, len(command.target_displacement),
            command.control_mode, len(command.target_force), signature.key_id,
            signature.session, len(signature.mac))


def _feedback_key(feedback: Feedback, signature: Signature) -> tuple[Any, ...]:
    """What a feedback's layout depends on."""
    return (feedback.test_id, len(feedback.measured_displacement),
            len(feedback.restoring_force), feedback.message, feedback.epoch, signature.key_id,
            signature.session, len(signature.mac))


def _encode_shaped(shapes: dict[tuple[Any, ...], _Compiled | None], key: tuple[Any, ...],
                   make: Callable[[], _Compiled], pack: Callable[[_Compiled], bytes],
                   full: Callable[[], bytes]) -> bytes:
    """The bytes of a message of shape ``key``, packed by the shape's layout.

    The layout is made on the shape's first message, and kept only if it packs the bytes the
    full encoder (``full``) makes of it. A record whose shape is no key (a list where the
    record holds a tuple) is encoded by the full encoder.
    """
    try:
        known = key in shapes
    except TypeError:  # unhashable
        return full()
    if not known:
        data = full()  # raises what cannot be carried, as it always did
        shape = _layout_of(shapes, key, make)
        try:
            if shape is not None and pack(shape) != data:  # (never: kept only if it is right)
                shapes[key] = None
        except (struct.error, TypeError, OverflowError):
            shapes[key] = None
        return data
    shape = shapes[key]
    if shape is not None:
        try:
            return pack(shape)
        except (struct.error, TypeError, OverflowError):
            pass  # a value out of its field's range: the full encoder says which
    return full()


# -- reading by a shape's layout --------------------------------------------------------------
_MAX_READERS = 8  # layouts tried per message length (several sites, several senders)


class _CommandReader(NamedTuple):
    """Reads commands of one shape (:class:`_Compiled`) without the full reader."""

    shape: _Compiled
    test_id: str
    dof_names: tuple[str, ...]
    control_mode: tuple[int, ...]
    displacements: int
    forces: int
    key_id: str
    session: str

    def read(self, data: bytes) -> Decoded[Command] | None:
        shape = self.shape
        values = shape.layout.unpack(data)
        if shape.pick_consts(values) != shape.consts:
            return None  # not this shape
        forces_at = 9 + self.displacements
        end = forces_at + self.forces
        command = command_of(self.test_id, values[4], values[6], self.dof_names,
                             values[8:forces_at - 1], values[5], self.control_mode,
                             values[forces_at:end])
        signature = signature_of(self.key_id, self.session, values[end + 1], values[end + 3])
        return _DECODED(Decoded, (command, values[1] * NS + values[2], signature,
                                  data[:shape.covered]))


class _FeedbackReader(NamedTuple):
    """Reads feedback of one shape (:class:`_Compiled`) without the full reader."""

    shape: _Compiled
    test_id: str
    message: str
    epoch: str
    displacements: int
    forces: int
    key_id: str
    session: str

    def read(self, data: bytes) -> Decoded[Feedback] | None:
        shape = self.shape
        values = shape.layout.unpack(data)
        if shape.pick_consts(values) != shape.consts:
            return None
        forces_at = 8 + self.displacements
        end = forces_at + self.forces
        feedback = feedback_of(self.test_id, values[4], values[7:forces_at - 1],
                               values[forces_at:end],
                               FEEDBACK_STATUS.get(values[end + 1], FeedbackStatus.FAULT),
                               self.message, values[5], self.epoch,
                               STATE_ORIGIN.get(values[end + 3], StateOrigin.FRESH))
        signature = signature_of(self.key_id, self.session, values[end + 5], values[end + 7])
        return _DECODED(Decoded, (feedback, values[1] * NS + values[2], signature,
                                  data[:shape.covered]))


_DECODED = tuple.__new__  # (a NamedTuple's own __new__ is a Python function)
_Reader = _CommandReader | _FeedbackReader


def _command_reader(decoded: Decoded[Command]) -> _CommandReader | None:
    """A reader of ``decoded``'s shape (``None``: the shape has no layout)."""
    command, signature = decoded.record, decoded.signature
    shape = _layout_of(_COMMAND_SHAPES, _command_key(command, signature),
                       lambda: _command_shape(command, signature))
    return None if shape is None else _CommandReader(
        shape, command.test_id, command.dof_names, command.control_mode,
        len(command.target_displacement), len(command.target_force), signature.key_id,
        signature.session)


def _feedback_reader(decoded: Decoded[Feedback]) -> _FeedbackReader | None:
    """A reader of ``decoded``'s shape (``None``: the shape has no layout)."""
    feedback, signature = decoded.record, decoded.signature
    shape = _layout_of(_FEEDBACK_SHAPES, _feedback_key(feedback, signature),
                       lambda: _feedback_shape(feedback, signature))
    return None if shape is None else _FeedbackReader(
        shape, feedback.test_id, feedback.message, feedback.epoch,
        len(feedback.measured_displacement), len(feedback.restoring_force), signature.key_id,
        signature.session)


def _layout_of(shapes: dict[tuple[Any, ...], _Compiled | None], key: tuple[Any, ...],
               make: Callable[[], _Compiled]) -> _Compiled | None:
    """The layout of a shape (made once; ``None``: it has none)."""
    if key not in shapes:
        try:
            shape: _Compiled | None = make()
        except (struct.error, ValueError, TypeError, OverflowError):
            shape = None
        if len(shapes) >= _MAX_SHAPES:
            shapes.clear()
        shapes[key] = shape
        return shape
    return shapes[key]


_COMMAND_READERS: dict[int, list[_Reader]] = {}
_FEEDBACK_READERS: dict[int, list[_Reader]] = {}


def _read_shaped(readers: dict[int, list[_Reader]], data: bytes) -> Decoded[Any] | None:
    """``data`` read by the layout of a shape seen before (``None``: none fits)."""
    for reader in readers.get(len(data), ()):
        decoded = reader.read(data)
        if decoded is not None:
            return decoded
    return None


def _learn(readers: dict[int, list[_Reader]], data: bytes, decoded: Decoded[Any],
           make: Callable[[Decoded[Any]], _Reader | None]) -> None:
    """Keep a reader of ``decoded``'s shape if it reads ``data`` as the full reader did.

    Not kept: a shape without a layout, or one that would not read these bytes so (bytes after
    the message's end, as rclpy leaves at times: the full reader reads them).
    """
    reader = make(decoded)
    if (reader is None or reader.shape.layout.size != len(data)
            or repr(reader.read(data)) != repr(decoded)):
        return
    if len(readers) >= _MAX_SHAPES:
        readers.clear()
    known = readers.setdefault(len(data), [])
    if len(known) >= _MAX_READERS:
        del known[0]
    known.append(reader)


# -- what the codec calls ---------------------------------------------------------------------
def encode_command(command: Command, stamp_ns: int, signature: Signature,
                   full: Callable[[], bytes]) -> bytes:
    """The bytes of ``command`` by its shape's layout.

    ``full()``, the full encoder, makes them for a shape's first message and for a record
    holding numpy arrays.
    """
    if type(command.target_displacement) is not tuple or type(command.target_force) is not tuple:
        return full()
    return _encode_shaped(_COMMAND_SHAPES, _command_key(command, signature),
                          lambda: _command_shape(command, signature),
                          lambda shape: _pack_command(shape, command, stamp_ns, signature), full)


def encode_feedback(feedback: Feedback, stamp_ns: int, signature: Signature,
                    full: Callable[[], bytes]) -> bytes:
    """The bytes of ``feedback`` by its shape's layout (``full()``: as :func:`encode_command`)."""
    if (type(feedback.measured_displacement) is not tuple
            or type(feedback.restoring_force) is not tuple):
        return full()
    return _encode_shaped(_FEEDBACK_SHAPES, _feedback_key(feedback, signature),
                          lambda: _feedback_shape(feedback, signature),
                          lambda shape: _pack_feedback(shape, feedback, stamp_ns, signature),
                          full)


def decode_command(data: bytes, full: Callable[[bytes], Decoded[Command]]) -> Decoded[Command]:
    """``data`` read by the layout of a shape seen before, else by ``full``.

    ``full`` is the full reader; what it reads teaches the shape.
    """
    decoded = _read_shaped(_COMMAND_READERS, data)
    if decoded is None:
        decoded = full(data)
        _learn(_COMMAND_READERS, data, decoded, _command_reader)
    return decoded


def decode_feedback(data: bytes, full: Callable[[bytes], Decoded[Feedback]]
                    ) -> Decoded[Feedback]:
    """``data`` read as :func:`decode_command` reads a command."""
    decoded = _read_shaped(_FEEDBACK_READERS, data)
    if decoded is None:
        decoded = full(data)
        _learn(_FEEDBACK_READERS, data, decoded, _feedback_reader)
    return decoded
