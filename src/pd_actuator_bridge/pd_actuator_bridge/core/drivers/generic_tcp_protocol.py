"""OpenFresco's GenericTCP wire protocol: size ID, data vectors, action codes, socket reads.

OpenFresco's ``expControl GenericTCP`` (class ``ECGenericTCP``) drives any controller-side
server over one TCP connection with the OpenSees ``Channel``/``TCP_Socket`` primitives. This
module is the encoding both sides share: the client (:mod:`.generic_tcp`), the OpenSees adapter
driver (:mod:`.opensees_adapter`, the same framing) and the controller-side server
(:mod:`pd_actuator_bridge.controller_server`).

Protocol facts, as read in the public sources (no code was copied from them):

* OpenFresco ``SRC/experimentalControl/ECGenericTCP.cpp`` (``setup``, ``control``,
  ``acquire``, destructor) and ``ECGenericTCP.h``:

  - ``setup()`` sends a size ID of ``2*OF_Resp_All + 1 = 11`` integers with ``sendID``:
    ``[ctrl disp, vel, accel, force, time, daq disp, vel, accel, force, time, dataSize]``,
    i.e. how many values of each response kind are controlled and acquired, then the length
    ``dataSize`` of every data vector that follows (OpenFresco sends its default, 256).
  - Every later message in either direction is one vector of exactly ``dataSize`` doubles
    (``sendVector``/``recvVector``), whatever the DOF count; unused entries are zero.
  - ``control()`` (``setTrialResponse``): ``sData[0] = 3``, followed from index 1 by the
    control values in the order disp, vel, accel, force, time (only the kinds with a non-zero
    size). No reply.
  - ``acquire()`` (``getDaqResponse``): sends ``sData[0] = 6`` (the rest of the vector is the
    last trial, ignored by a server), then receives one vector whose values start at index
    **0** (no action code) in the order disp, vel, accel, force, time.
  - The destructor sends ``sData[0] = 99`` (``OF_RemoteTest_DIE``) to end the session.
  - ``commitState()`` returns at once: ECGenericTCP sends **nothing** on commit.
  - Optional ``-initFile``: each line is sent as a 16385-byte ``Message`` whose first char is
    ``2`` (``OF_RemoteTest_setup``). Not used here.
  - ``setup()`` also calls ``control()`` and ``acquire()`` once (with the zero-initialised
    vector, i.e. a command to zero); this client deliberately only *acquires* at open so that
    connecting never moves the actuator.

* OpenFresco ``SRC/FrescoGlobals.h``: ``OF_Resp_Disp..Time = 0..4``, ``OF_Resp_All = 5``;
  ``OF_RemoteTest_open = 1``, ``setup = 2``, ``setTrialResponse = 3``, ``execute = 4``,
  ``commitState = 5``, ``getDaqResponse = 6``, ``getDisp..getTime = 7..11``,
  ``getInitialStiff = 12``, ``getTangentStiff = 13``, ``getDamp = 14``, ``getMass = 15``,
  ``shutdown = 98``, ``DIE = 99``; ``OF_Network_dataSize = 256``.

* OpenSees ``SRC/actor/channel/TCP_Socket.cpp``: ``sendID`` writes the ID's ``int`` array raw
  (``sz * sizeof(int)`` bytes, so the size ID is eleven **int32**, not doubles: 44 bytes) and
  ``sendVector`` the ``double`` array raw (``sz * sizeof(double)`` bytes); there is no header,
  length prefix or terminator, only native byte order. The byte-order handshake
  (``checkEndianness``) is off by default in the client constructor ECGenericTCP uses, so no
  byte is exchanged before the size ID. On x86 everything is therefore little-endian.

Because the stream has no framing, a reply of the wrong length shows up as a timeout or a
closed connection (too short) or as bytes left over after the fixed-size reply (too long);
both are reported as :class:`GenericTCPError`, as are non-finite values.
"""

from __future__ import annotations

import math
import select
import socket
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields

from ..errors import BridgeConfigError, DriverError

# Action codes (OpenFresco FrescoGlobals.h, OF_RemoteTest_*).
ACTION_OPEN = 1
ACTION_SETUP = 2
ACTION_SET_TRIAL_RESPONSE = 3
ACTION_EXECUTE = 4
ACTION_COMMIT_STATE = 5
ACTION_GET_DAQ_RESPONSE = 6
ACTION_SHUTDOWN = 98
ACTION_DIE = 99

ACTION_NAMES = {
    ACTION_OPEN: 'open',
    ACTION_SETUP: 'setup',
    ACTION_SET_TRIAL_RESPONSE: 'setTrialResponse',
    ACTION_EXECUTE: 'execute',
    ACTION_COMMIT_STATE: 'commitState',
    ACTION_GET_DAQ_RESPONSE: 'getDaqResponse',
    ACTION_SHUTDOWN: 'shutdown',
    ACTION_DIE: 'die',
}

RESPONSE_KINDS = ('disp', 'vel', 'accel', 'force', 'time')
"""Response kinds in protocol order (OF_Resp_Disp .. OF_Resp_Time)."""

SIZE_ID_LENGTH = 2 * len(RESPONSE_KINDS) + 1
"""Number of int32 in the size ID sent at setup (11)."""

DEFAULT_DATA_SIZE = 256
"""OpenFresco's ``OF_Network_dataSize``: doubles per data vector."""

MAX_DATA_SIZE = 1 << 20
"""Largest data size accepted when decoding a size ID (guards memory against garbage)."""

BYTE_ORDERS = {'little': '<', 'big': '>'}

SizesLike = Sequence[int] | Mapping[str, int]
"""Five sizes in protocol order, or a mapping from response kind to size (missing kinds 0)."""


class GenericTCPError(DriverError):
    """A GenericTCP exchange failed: connection, timeout, closed peer or malformed data."""


# --------------------------------------------------------------------------- data classes


@dataclass(frozen=True)
class _Responses:
    disp: tuple[float, ...] = ()
    vel: tuple[float, ...] = ()
    accel: tuple[float, ...] = ()
    force: tuple[float, ...] = ()
    time: tuple[float, ...] = ()

    def sizes(self) -> tuple[int, ...]:
        """Number of values of each kind, in protocol order."""
        return tuple(len(getattr(self, kind)) for kind in RESPONSE_KINDS)


@dataclass(frozen=True)
class TrialResponse(_Responses):
    """Control values of one ``setTrialResponse`` (empty tuple: kind not controlled).

    Attributes:
        disp: Displacements, m.
        vel: Velocities, m/s.
        accel: Accelerations, m/s².
        force: Forces, N.
        time: Times, s.
    """


@dataclass(frozen=True)
class DaqResponse(_Responses):
    """Values returned by one ``getDaqResponse`` (empty tuple: kind not acquired).

    Attributes:
        disp: Measured displacements, m.
        vel: Measured velocities, m/s.
        accel: Measured accelerations, m/s².
        force: Measured forces, N.
        time: Controller times, s.
    """


@dataclass(frozen=True)
class SizeID:
    """The 11-integer size ID sent by the client at setup.

    Attributes:
        ctrl: Controlled values per kind (disp, vel, accel, force, time).
        daq: Acquired values per kind (disp, vel, accel, force, time).
        data_size: Doubles in every data vector that follows.
    """

    ctrl: tuple[int, ...]
    daq: tuple[int, ...]
    data_size: int = DEFAULT_DATA_SIZE

    def __post_init__(self) -> None:
        """Normalise the sizes and check that the vectors fit in ``data_size``.

        Raises:
            BridgeConfigError: On a negative or non-integer size, or vectors too long.
        """
        object.__setattr__(self, 'ctrl', normalize_sizes(self.ctrl, 'ctrl sizes'))
        object.__setattr__(self, 'daq', normalize_sizes(self.daq, 'daq sizes'))
        data_size = check_count(self.data_size, 'data_size')
        if data_size < 1 or data_size > MAX_DATA_SIZE:
            msg = f'GenericTCP: data_size must be in 1..{MAX_DATA_SIZE}, got {data_size}'
            raise BridgeConfigError(msg)
        object.__setattr__(self, 'data_size', data_size)
        if 1 + self.ctrl_length > data_size:
            msg = (
                f'GenericTCP: 1 action + {self.ctrl_length} control values do not fit in '
                f'data_size {data_size}'
            )
            raise BridgeConfigError(msg)
        if self.daq_length > data_size:
            msg = f'GenericTCP: {self.daq_length} daq values do not fit in data_size {data_size}'
            raise BridgeConfigError(msg)

    @classmethod
    def from_sizes(
        cls, ctrl: SizesLike, daq: SizesLike, data_size: int = DEFAULT_DATA_SIZE
    ) -> SizeID:
        """Build the size ID from sizes per kind, e.g. ``{'disp': 2, 'force': 2}``.

        Args:
            ctrl: Controlled values per kind: five integers or a mapping (see
                :func:`normalize_sizes`).
            daq: Acquired values per kind, likewise.
            data_size: Doubles in every data vector.

        Raises:
            BridgeConfigError: On a negative or non-integer size, or vectors too long.
        """
        return cls(normalize_sizes(ctrl, 'ctrl sizes'), normalize_sizes(daq, 'daq sizes'),
                   data_size)

    @property
    def ctrl_length(self) -> int:
        """Total number of control values."""
        return sum(self.ctrl)

    @property
    def daq_length(self) -> int:
        """Total number of daq values."""
        return sum(self.daq)

    @property
    def vector_bytes(self) -> int:
        """Bytes in one data vector."""
        return 8 * self.data_size

    def as_list(self) -> list[int]:
        """The 11 integers in wire order."""
        return [*self.ctrl, *self.daq, self.data_size]


# --------------------------------------------------------------------------- encoding


def check_count(value: object, name: str) -> int:
    """Return ``value`` as an ``int`` if it is an integral number, else raise.

    Raises:
        BridgeConfigError: Naming ``name``, if ``value`` is not an integer.
    """
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or value != int(value)
    ):
        msg = f'GenericTCP: {name} must be an integer, got {value!r}'
        raise BridgeConfigError(msg)
    return int(value)


def byte_order_prefix(byte_order: str) -> str:
    """The ``struct`` prefix of ``byte_order`` (``'little'`` or ``'big'``).

    Raises:
        BridgeConfigError: On another byte order.
    """
    try:
        return BYTE_ORDERS[byte_order]
    except KeyError:
        msg = f"GenericTCP: byte_order must be 'little' or 'big', got {byte_order!r}"
        raise BridgeConfigError(msg) from None


def normalize_sizes(sizes: SizesLike, name: str = 'sizes') -> tuple[int, ...]:
    """Return five non-negative sizes in protocol order.

    Args:
        sizes: Five integers (disp, vel, accel, force, time) or a mapping such as
            ``{'disp': 2, 'force': 2}`` (missing kinds are 0).
        name: Used in error messages.

    Raises:
        BridgeConfigError: On an unknown kind, a wrong count or a negative/non-integer size.
    """
    if isinstance(sizes, Mapping):
        unknown = sorted(set(sizes) - set(RESPONSE_KINDS))
        if unknown:
            msg = (
                f'GenericTCP: {name}: unknown response kind(s) {", ".join(map(str, unknown))} '
                f'(expected {", ".join(RESPONSE_KINDS)})'
            )
            raise BridgeConfigError(msg)
        values = [sizes.get(kind, 0) for kind in RESPONSE_KINDS]
    else:
        values = list(sizes)
        if len(values) != len(RESPONSE_KINDS):
            msg = (
                f'GenericTCP: {name}: expected {len(RESPONSE_KINDS)} sizes '
                f'({", ".join(RESPONSE_KINDS)}), got {len(values)}'
            )
            raise BridgeConfigError(msg)
    result = tuple(check_count(v, name) for v in values)
    if any(v < 0 for v in result):
        msg = f'GenericTCP: {name}: sizes must be >= 0, got {list(result)}'
        raise BridgeConfigError(msg)
    return result


def encode_size_id(size_id: SizeID, byte_order: str = 'little') -> bytes:
    """Encode the size ID as 11 int32 (44 bytes), as ``TCP_Socket::sendID`` does."""
    return struct.pack(f'{byte_order_prefix(byte_order)}{SIZE_ID_LENGTH}i', *size_id.as_list())


def decode_size_id(payload: bytes, byte_order: str = 'little') -> SizeID:
    """Decode and validate a size ID.

    Raises:
        GenericTCPError: If the payload is not 44 bytes or describes impossible sizes.
    """
    expected = 4 * SIZE_ID_LENGTH
    if len(payload) != expected:
        msg = f'GenericTCP: size ID must be {expected} bytes, got {len(payload)}'
        raise GenericTCPError(msg)
    values = struct.unpack(f'{byte_order_prefix(byte_order)}{SIZE_ID_LENGTH}i', payload)
    n = len(RESPONSE_KINDS)
    try:
        return SizeID(values[:n], values[n:2 * n], values[2 * n])
    except BridgeConfigError as exc:
        msg = f'invalid size ID {list(values)}: {exc}'
        raise GenericTCPError(msg) from None


def encode_vector(values: Sequence[float], data_size: int, byte_order: str = 'little') -> bytes:
    """Encode ``values`` as a data vector of exactly ``data_size`` float64, zero padded.

    Raises:
        GenericTCPError: If there are more values than ``data_size``.
    """
    values = [float(v) for v in values]
    if len(values) > data_size:
        msg = f'GenericTCP: {len(values)} values do not fit in a vector of {data_size}'
        raise GenericTCPError(msg)
    values.extend([0.0] * (data_size - len(values)))
    return struct.pack(f'{byte_order_prefix(byte_order)}{data_size}d', *values)


def decode_vector(payload: bytes, data_size: int, byte_order: str = 'little') -> list[float]:
    """Decode one data vector of exactly ``data_size`` float64.

    Raises:
        GenericTCPError: If the payload length is not ``8 * data_size``.
    """
    if len(payload) != 8 * data_size:
        msg = f'GenericTCP: a data vector must be {8 * data_size} bytes, got {len(payload)}'
        raise GenericTCPError(msg)
    return list(struct.unpack(f'{byte_order_prefix(byte_order)}{data_size}d', payload))


def _flatten(sizes: tuple[int, ...], groups: Mapping[str, Sequence[float] | None],
             what: str) -> list[float]:
    values: list[float] = []
    for kind, size in zip(RESPONSE_KINDS, sizes, strict=True):
        group = groups.get(kind)
        if group is None:
            if size:
                values.extend([0.0] * size)
            continue
        group = [float(v) for v in group]
        if len(group) != size:
            msg = f'GenericTCP: {what} {kind} has {len(group)} values, the size ID says {size}'
            raise GenericTCPError(msg)
        values.extend(group)
    return values


def _split(values: Sequence[float], sizes: tuple[int, ...]) -> dict[str, tuple[float, ...]]:
    groups: dict[str, tuple[float, ...]] = {}
    index = 0
    for kind, size in zip(RESPONSE_KINDS, sizes, strict=True):
        groups[kind] = tuple(float(v) for v in values[index:index + size])
        index += size
    return groups


def encode_action(action: int, data_size: int, values: Sequence[float] = (),
                  byte_order: str = 'little') -> bytes:
    """Encode ``[action, *values]`` as one data vector."""
    return encode_vector([float(action), *values], data_size, byte_order)


def encode_trial(size_id: SizeID, trial: TrialResponse, byte_order: str = 'little') -> bytes:
    """Encode a ``setTrialResponse`` vector: ``[3, ctrl values in protocol order]``.

    A kind controlled by the size ID but missing (empty) in ``trial`` is sent as zeros; a kind
    given with the wrong number of values is an error.

    Raises:
        GenericTCPError: On a size mismatch.
    """
    groups = {kind: (getattr(trial, kind) or None) for kind in RESPONSE_KINDS}
    values = _flatten(size_id.ctrl, groups, 'trial')
    return encode_action(ACTION_SET_TRIAL_RESPONSE, size_id.data_size, values, byte_order)


def decode_trial(vector: Sequence[float], size_id: SizeID) -> TrialResponse:
    """Split a received ``setTrialResponse`` vector (action at index 0) into its control values."""
    return TrialResponse(**_split(vector[1:], size_id.ctrl))


def encode_daq(size_id: SizeID, daq: DaqResponse, byte_order: str = 'little') -> bytes:
    """Encode a ``getDaqResponse`` reply: daq values from index 0, in protocol order.

    Raises:
        GenericTCPError: If a kind has a different number of values than the size ID says.
    """
    groups = {kind: getattr(daq, kind) for kind in RESPONSE_KINDS}
    values = _flatten(size_id.daq, groups, 'daq')
    return encode_vector(values, size_id.data_size, byte_order)


def decode_daq(vector: Sequence[float], size_id: SizeID) -> DaqResponse:
    """Split a received ``getDaqResponse`` vector into its daq values (padding ignored)."""
    return DaqResponse(**_split(vector, size_id.daq))


def first_non_finite(response: _Responses) -> str | None:
    """Return ``'kind[i] is nan'`` for the first non-finite value, or ``None``."""
    for field in fields(response):
        for i, value in enumerate(getattr(response, field.name)):
            if not math.isfinite(value):
                return f'{field.name}[{i}] is {value}'
    return None


# --------------------------------------------------------------------------- socket helpers


def recv_exact(sock: socket.socket, n: int) -> tuple[bytes, str]:
    """Read exactly ``n`` bytes.

    Returns:
        ``(data, '')`` on success, else the bytes read so far and ``'closed'`` (orderly EOF),
        ``'reset'`` (connection reset), ``'timeout'`` or ``'error: <exception>'``.
    """
    chunks: list[bytes] = []
    got = 0
    while got < n:
        try:
            chunk = sock.recv(min(n - got, 1 << 16))
        except TimeoutError:
            return b''.join(chunks), 'timeout'
        except ConnectionResetError:
            return b''.join(chunks), 'reset'
        except OSError as exc:
            return b''.join(chunks), f'error: {type(exc).__name__}: {exc}'
        if not chunk:
            return b''.join(chunks), 'closed'
        chunks.append(chunk)
        got += len(chunk)
    return b''.join(chunks), ''


def pending_bytes(sock: socket.socket) -> tuple[int, bool]:
    """Return ``(n, closed)``: bytes readable right now (up to 64 KiB, consumed) and EOF seen.

    Used to detect a reply longer than the fixed vector and a peer that closed between
    messages. Never blocks.
    """
    total = 0
    try:
        while True:
            readable, _, _ = select.select([sock], [], [], 0)
            if not readable:
                return total, False
            chunk = sock.recv(1 << 16)
            if not chunk:
                return total, True
            total += len(chunk)
            if total >= 1 << 16:
                return total, False
    except OSError:
        return total, True


def describe_error(exc: BaseException) -> str:
    """``'Type: message'`` of an exception (``'Type'`` if it has no message)."""
    text = str(exc)
    return f'{type(exc).__name__}: {text}' if text else type(exc).__name__
