"""The wire format of OpenSees's ``genericClient`` element (the client) and its server.

Facts read in the public sources (no code copied):

* OpenSees ``SRC/element/generic/GenericClient.h`` lines 36-51: the action codes
  ``RemoteTest_*`` (setTrialResponse 3, commitState 5, getDisp 7 .. getMass 15, DIE 99).
* ``GenericClient.cpp`` ``setupConnection()`` (lines 1051-1088): the client connects, then
  sends an ID of ``2*5+1`` ints with ``sendID``: control sizes (disp, vel, accel, force, time)
  = ``(n, n, n, 0, 1)``, acquired sizes = ``(0, 0, 0, n, 0)`` and ``dataSize`` (default 256,
  at least ``1 + 3n + 1`` and ``n*n``), ``n`` the element's basic DOFs (all ``-dof`` entries of
  all its nodes). Every later message, either way, is one vector of ``dataSize`` doubles.
* ``update()`` (lines 437-467): ``[3, d_1..d_n, v_1..v_n, a_1..a_n, t]`` (trial displacement,
  velocity, acceleration of the basic DOFs, domain time); no reply.
* ``getResistingForce()`` (lines 586-602): ``[10, ...]``; the reply's first ``n`` doubles are
  the basic forces.
* ``getTangentStiff()``, ``getInitialStiff()``, ``getDamp()``, ``getMass()`` (lines 472-545):
  actions 13, 12, 14, 15; the reply holds an ``n`` x ``n`` matrix, column-major (OpenSees's
  ``Matrix`` over the receive buffer).
* ``commitState()`` (lines 395-406): ``[5, ...]``, no reply; ``~GenericClient()`` (lines
  270-275): ``[99, ...]`` on exit or ``wipe``. ``revertToLastCommit`` is refused by the
  element itself (nothing is sent).
* OpenSees ``SRC/actor/channel/TCP_Socket.cpp``: ``sendID``/``sendVector`` write the raw
  ``int``/``double`` arrays with no header (native byte order: little-endian on x86-64).

Verified with openseespy (``NewmarkExplicit``; ``Newmark`` with ``Newton``): see
``docs/how-to/bring-your-opensees-model.md``.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass

from ..errors import ElementProtocolError

SET_TRIAL_RESPONSE = 3
COMMIT_STATE = 5
GET_DAQ_RESPONSE = 6
GET_DISP = 7
GET_VEL = 8
GET_ACCEL = 9
GET_FORCE = 10
GET_TIME = 11
GET_INITIAL_STIFF = 12
GET_TANGENT_STIFF = 13
GET_DAMP = 14
GET_MASS = 15
DIE = 99

ACTION_NAMES = {
    SET_TRIAL_RESPONSE: 'setTrialResponse', COMMIT_STATE: 'commitState',
    GET_DAQ_RESPONSE: 'getDaqResponse', GET_DISP: 'getDisp', GET_VEL: 'getVel',
    GET_ACCEL: 'getAccel', GET_FORCE: 'getForce', GET_TIME: 'getTime',
    GET_INITIAL_STIFF: 'getInitialStiff', GET_TANGENT_STIFF: 'getTangentStiff',
    GET_DAMP: 'getDamp', GET_MASS: 'getMass', DIE: 'DIE',
}
"""Every action a ``genericClient`` sends (and ``getDaqResponse``, answered as getForce)."""

SIZE_MESSAGE_INTS = 11
"""Ints in the size message (``2 * 5 + 1``)."""
SIZE_MESSAGE_BYTES = 4 * SIZE_MESSAGE_INTS
MAX_DATA_SIZE = 1 << 16
"""Largest ``dataSize`` accepted (a guard against garbage: 512 KiB per message)."""


@dataclass(frozen=True)
class SizeMessage:
    """What the element announced when it connected.

    Attributes:
        n_dof: Basic DOFs of the element.
        data_size: Doubles per message.
    """

    n_dof: int
    data_size: int

    @property
    def vector_bytes(self) -> int:
        """Bytes per message."""
        return 8 * self.data_size


@dataclass(frozen=True)
class Trial:
    """One ``setTrialResponse``: the element's basic trial response.

    Attributes:
        displacement: Basic displacements, m.
        velocity: Basic velocities, m/s.
        acceleration: Basic accelerations, m/s².
        time: The domain's time, s.
    """

    displacement: tuple[float, ...]
    velocity: tuple[float, ...]
    acceleration: tuple[float, ...]
    time: float


def decode_size_message(payload: bytes) -> SizeMessage:
    """Check the 11 ints a ``genericClient`` sends first.

    Raises:
        ElementProtocolError: Not 44 bytes, or not the layout ``genericClient`` sends.
    """
    if len(payload) != SIZE_MESSAGE_BYTES:
        msg = f'size message: expected {SIZE_MESSAGE_BYTES} bytes, got {len(payload)}'
        raise ElementProtocolError(msg)
    ids = struct.unpack(f'<{SIZE_MESSAGE_INTS}i', payload)
    n = ids[0]
    expected = (n, n, n, 0, 1, 0, 0, 0, n, 0)
    if n < 1 or tuple(ids[:10]) != expected:
        msg = (f'size message: {list(ids)} is not a genericClient element\'s '
               '(n, n, n, 0, 1, 0, 0, 0, n, 0, dataSize)')
        raise ElementProtocolError(msg)
    data_size = ids[10]
    if not max(1 + 3 * n + 1, n * n) <= data_size <= MAX_DATA_SIZE:
        msg = (f'size message: dataSize {data_size} does not fit {n} DOFs (or exceeds '
               f'{MAX_DATA_SIZE})')
        raise ElementProtocolError(msg)
    return SizeMessage(n, data_size)


def encode_size_message(n_dof: int, data_size: int = 256) -> bytes:
    """The size message a ``genericClient`` with ``n_dof`` basic DOFs sends (for tests)."""
    data_size = max(data_size, 1 + 3 * n_dof + 1, n_dof * n_dof)
    return struct.pack(f'<{SIZE_MESSAGE_INTS}i', n_dof, n_dof, n_dof, 0, 1, 0, 0, 0, n_dof, 0,
                       data_size)


def decode_message(payload: bytes, size: SizeMessage) -> tuple[int, list[float]]:
    """``(action, values)`` of one message; ``values`` follow the action code.

    Raises:
        ElementProtocolError: Wrong length, an unknown action code, non-finite values.
    """
    if len(payload) != size.vector_bytes:
        msg = f'message: expected {size.vector_bytes} bytes, got {len(payload)}'
        raise ElementProtocolError(msg)
    values = list(struct.unpack(f'<{size.data_size}d', payload))
    code = values[0]
    if not (math.isfinite(code) and code == int(code) and int(code) in ACTION_NAMES):
        msg = f'message: unknown action code {code!r}'
        raise ElementProtocolError(msg)
    action = int(code)
    if action == SET_TRIAL_RESPONSE:
        used = values[1:2 + 3 * size.n_dof]
        if not all(map(math.isfinite, used)):
            msg = f'setTrialResponse: non-finite values {used}'
            raise ElementProtocolError(msg)
    return action, values[1:]


def decode_trial(values: Sequence[float], n_dof: int) -> Trial:
    """The trial in a ``setTrialResponse``'s values (after the action code)."""
    n = n_dof
    return Trial(tuple(values[:n]), tuple(values[n:2 * n]), tuple(values[2 * n:3 * n]),
                 float(values[3 * n]))


def encode_trial(trial: Trial, size: SizeMessage) -> bytes:
    """A ``setTrialResponse`` message (for tests and clients)."""
    return encode_reply([float(SET_TRIAL_RESPONSE), *trial.displacement, *trial.velocity,
                         *trial.acceleration, trial.time], size)


def encode_action(action: int, size: SizeMessage) -> bytes:
    """A message with only its action code (for tests and clients)."""
    return encode_reply([float(action)], size)


def encode_reply(values: Sequence[float], size: SizeMessage) -> bytes:
    """One message: ``values`` zero-padded to ``dataSize`` doubles.

    Raises:
        ElementProtocolError: More values than ``dataSize``.
    """
    if len(values) > size.data_size:
        msg = f'reply: {len(values)} values do not fit in dataSize {size.data_size}'
        raise ElementProtocolError(msg)
    padded = [float(v) for v in values] + [0.0] * (size.data_size - len(values))
    return struct.pack(f'<{size.data_size}d', *padded)


def matrix_values(matrix: Sequence[Sequence[float]]) -> list[float]:
    """An ``n`` x ``n`` matrix as the element reads it: column by column."""
    n = len(matrix)
    return [float(matrix[i][j]) for j in range(n) for i in range(n)]
