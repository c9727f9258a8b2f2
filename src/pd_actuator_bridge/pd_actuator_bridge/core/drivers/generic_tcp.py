"""The ``generic_tcp`` driver: a client of OpenFresco's GenericTCP experimental-control protocol.

OpenFresco's ``expControl GenericTCP`` (class ``ECGenericTCP``) drives any controller-side
server over one TCP connection. :class:`GenericTCPClient` plays that client role, so a server
written for OpenFresco (e.g. one running next to a MOOG controller) can be driven by the bridge
through :class:`GenericTCPDriver`; :mod:`pd_actuator_bridge.controller_server` plays the server
role in tests. The wire format (what is sent when, byte by byte, as read in OpenFresco's and
OpenSees's sources) is in :mod:`.generic_tcp_protocol`.
"""

from __future__ import annotations

import math
import socket
from collections.abc import Sequence

from ..errors import BridgeConfigError
from .base import RemoteDriver, StepId
from .generic_tcp_protocol import (
    ACTION_DIE,
    ACTION_GET_DAQ_RESPONSE,
    DEFAULT_DATA_SIZE,
    RESPONSE_KINDS,
    DaqResponse,
    GenericTCPError,
    SizeID,
    SizesLike,
    TrialResponse,
    byte_order_prefix,
    check_count,
    decode_daq,
    decode_vector,
    describe_error,
    encode_action,
    encode_size_id,
    encode_trial,
    first_non_finite,
    pending_bytes,
    recv_exact,
)
from .registry import DriverContext, DriverParameter, DriverSpec, register_driver

# --------------------------------------------------------------------------- client


class GenericTCPClient:
    """Client side of OpenFresco's GenericTCP protocol (the role of ``ECGenericTCP``).

    Every failure raises :class:`GenericTCPError` with a one-line message naming
    ``host:port`` and the action; after a communication failure the connection is closed and
    the client must be reconnected.

    Example::

        with GenericTCPClient('127.0.0.1', 8090, timeout=5.0) as client:
            client.setup({'disp': 1}, {'disp': 1, 'force': 1})
            client.set_trial_response(disp=[0.001])
            daq = client.get_daq_response()
    """

    def __init__(
        self,
        host: str,
        port: int,
        timeout: float = 5.0,
        connect_timeout: float | None = None,
        data_size: int = DEFAULT_DATA_SIZE,
        byte_order: str = 'little',
    ) -> None:
        """Create the client (no connection yet; see :meth:`connect`).

        Args:
            host: Controller-side server address.
            port: Its TCP port.
            timeout: Seconds to wait for any send or reply.
            connect_timeout: Seconds to wait for the connection; ``timeout`` if omitted.
            data_size: Doubles per data vector announced in the size ID (OpenFresco: 256).
            byte_order: ``'little'`` (x86, OpenFresco's usual case) or ``'big'``.

        Raises:
            BridgeConfigError: On an invalid argument.
        """
        if not isinstance(host, str) or not host:
            msg = f'GenericTCP: host must be a non-empty string, got {host!r}'
            raise BridgeConfigError(msg)
        port = check_count(port, 'port')
        if not 0 < port < 65536:
            msg = f'GenericTCP: port must be in 1..65535, got {port}'
            raise BridgeConfigError(msg)
        for name, value in (('timeout', timeout), ('connect_timeout', connect_timeout)):
            if value is None and name == 'connect_timeout':
                continue
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                math.isfinite(value) and value > 0
            ):
                msg = f'GenericTCP: {name} must be a positive number of seconds, got {value!r}'
                raise BridgeConfigError(msg)
        byte_order_prefix(byte_order)
        check_count(data_size, 'data_size')
        self._host = host
        self._port = port
        self._timeout = float(timeout)
        self._connect_timeout = float(connect_timeout if connect_timeout is not None else timeout)
        self._data_size = int(data_size)
        self._byte_order = byte_order
        self._sock: socket.socket | None = None
        self._size_id: SizeID | None = None

    # ------------------------------------------------------------------ properties

    @property
    def address(self) -> str:
        """``host:port`` of the server."""
        return f'{self._host}:{self._port}'

    @property
    def connected(self) -> bool:
        """Whether the connection is open."""
        return self._sock is not None

    @property
    def size_id(self) -> SizeID | None:
        """The size ID sent by :meth:`setup`, or ``None`` before it."""
        return self._size_id

    # ------------------------------------------------------------------ protocol

    def connect(self) -> None:
        """Open the TCP connection.

        Raises:
            GenericTCPError: If already connected, refused, timed out or unreachable.
        """
        action = 'connect'
        if self._sock is not None:
            raise self._error(action, 'already connected')
        try:
            sock = socket.create_connection(
                (self._host, self._port), timeout=self._connect_timeout
            )
        except ConnectionRefusedError:
            raise self._error(action, 'connection refused') from None
        except TimeoutError:
            raise self._error(
                action, f'timed out after {self._connect_timeout:g} s'
            ) from None
        except OSError as exc:
            raise self._error(action, describe_error(exc)) from None
        sock.settimeout(self._timeout)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._sock = sock
        self._size_id = None

    def setup(self, ctrl_sizes: SizesLike, daq_sizes: SizesLike) -> SizeID:
        """Send the 11-integer size ID.

        Args:
            ctrl_sizes: Controlled values per kind, e.g. ``{'disp': 2}``.
            daq_sizes: Acquired values per kind, e.g. ``{'disp': 2, 'force': 2}``.

        Returns:
            The size ID sent.

        Raises:
            BridgeConfigError: On invalid sizes.
            GenericTCPError: If not connected or the send fails.
        """
        size_id = SizeID.from_sizes(ctrl_sizes, daq_sizes, self._data_size)
        self._send('setup', encode_size_id(size_id, self._byte_order))
        self._size_id = size_id
        return size_id

    def set_trial_response(
        self,
        disp: Sequence[float] | None = None,
        vel: Sequence[float] | None = None,
        accel: Sequence[float] | None = None,
        force: Sequence[float] | None = None,
        time: Sequence[float] | None = None,
    ) -> None:
        """Send ``[3, ctrl values]``: the controller moves to the trial (no reply).

        A kind the size ID controls but not given here is sent as zeros.

        Raises:
            GenericTCPError: Before :meth:`setup`, on a size mismatch, a non-finite value or a
                send failure.
        """
        action = 'setTrialResponse'
        size_id = self._require_setup(action)
        trial = TrialResponse(
            **{
                kind: tuple(float(v) for v in values)
                for kind, values in zip(RESPONSE_KINDS, (disp, vel, accel, force, time),
                                        strict=True)
                if values is not None
            }
        )
        bad = first_non_finite(trial)
        if bad is not None:
            raise self._error(action, f'refusing to send a non-finite value: trial {bad}')
        try:
            payload = encode_trial(size_id, trial, self._byte_order)
        except GenericTCPError as exc:
            raise self._error(action, str(exc).removeprefix('GenericTCP: ')) from None
        self._send(action, payload)

    def get_daq_response(self) -> DaqResponse:
        """Send ``[6]`` and read the daq vector.

        Raises:
            GenericTCPError: Before :meth:`setup`, on a timeout, a closed connection, a reply of
                the wrong length or a non-finite value.
        """
        action = 'getDaqResponse'
        size_id = self._require_setup(action)
        self._send(action, encode_action(ACTION_GET_DAQ_RESPONSE, size_id.data_size,
                                         byte_order=self._byte_order))
        payload = self._recv(action, size_id.vector_bytes)
        # A peer that closed right after a valid reply is reported by the next action.
        assert self._sock is not None  # _recv() returned: still connected
        extra, _ = pending_bytes(self._sock)
        if extra:
            self._drop()
            raise self._error(
                action,
                f'malformed reply: {extra} unexpected byte(s) after the '
                f'{size_id.vector_bytes}-byte vector (reply longer than data_size '
                f'{size_id.data_size})',
            )
        daq = decode_daq(decode_vector(payload, size_id.data_size, self._byte_order), size_id)
        bad = first_non_finite(daq)
        if bad is not None:
            self._drop()
            raise self._error(action, f'malformed reply: daq {bad}')
        return daq

    def commit_state(self) -> None:
        """Commit the current step.

        ECGenericTCP's ``commitState()`` sends nothing (the action code 5 exists but generic
        controllers do not expect it), so this only checks that the client is set up.

        Raises:
            GenericTCPError: Before :meth:`setup`.
        """
        self._require_setup('commitState')

    def close(self) -> None:
        """Send ``[99]`` (end of test) if possible and close the connection. Idempotent."""
        sock = self._sock
        if sock is None:
            return
        data_size = self._size_id.data_size if self._size_id is not None else self._data_size
        try:
            sock.settimeout(min(self._timeout, 1.0))
            sock.sendall(encode_action(ACTION_DIE, data_size, byte_order=self._byte_order))
        except OSError:
            pass  # the controller is gone already: nothing more to tell it
        self._drop()

    def __enter__(self) -> GenericTCPClient:
        """Connect (if needed) and return the client."""
        if self._sock is None:
            self.connect()
        return self

    def __exit__(self, *exc_info: object) -> None:
        """Close the connection (sending 99)."""
        self.close()

    # ------------------------------------------------------------------ internals

    def _error(self, action: str, message: str) -> GenericTCPError:
        return GenericTCPError(f'GenericTCP {self.address}: {action}: {message}')

    def _require_setup(self, action: str) -> SizeID:
        if self._sock is None:
            raise self._error(action, 'not connected')
        if self._size_id is None:
            raise self._error(action, 'setup() was not called')
        return self._size_id

    def _drop(self) -> None:
        sock, self._sock = self._sock, None
        self._size_id = None
        if sock is not None:
            try:
                sock.close()
            except OSError:
                pass

    def _send(self, action: str, payload: bytes) -> None:
        if self._sock is None:
            raise self._error(action, 'not connected')
        extra, closed = pending_bytes(self._sock)
        if closed:
            self._drop()
            raise self._error(action, 'the controller closed the connection')
        if extra:
            self._drop()
            raise self._error(
                action,
                f'malformed stream: {extra} unexpected byte(s) from the controller before '
                f'the request (previous reply too long?)',
            )
        try:
            self._sock.sendall(payload)
        except TimeoutError:
            self._drop()
            raise self._error(action, f'send timed out after {self._timeout:g} s') from None
        except OSError as exc:
            self._drop()
            raise self._error(
                action, f'the controller closed the connection ({describe_error(exc)})'
            ) from None

    def _recv(self, action: str, n: int) -> bytes:
        assert self._sock is not None
        data, failure = recv_exact(self._sock, n)
        if not failure:
            return data
        self._drop()
        got = f'got {len(data)} of {n} bytes'
        if failure == 'timeout':
            raise self._error(
                action, f'timed out after {self._timeout:g} s waiting for the reply ({got})'
            )
        if failure == 'closed':
            if data:
                raise self._error(
                    action, f'the controller closed the connection mid-message ({got}: '
                    f'reply shorter than data_size {n // 8})'
                )
            raise self._error(action, 'the controller closed the connection before replying')
        if failure == 'reset':
            raise self._error(action, f'the controller reset the connection ({got})')
        raise self._error(action, f'receive failed ({got}; {failure.removeprefix("error: ")})')


# --------------------------------------------------------------------------- driver


class GenericTCPDriver(RemoteDriver):
    """Synchronous actuator driver for a GenericTCP controller-side server.

    :meth:`open` connects, sends the size ID (displacement controlled; displacement and force
    acquired, one value per DOF each) and acquires once to learn the actuator's current
    position, without commanding anything. :meth:`command` sends the target as the trial
    displacement, acquires, and reports the measured displacement and force through the
    measurement callback before returning. Any communication failure raises
    :class:`GenericTCPError` (a :class:`DriverError`), which makes the bridge hold.

    A GenericTCP controller keeps executing its last command, so :meth:`hold` sends nothing:
    the actuator stays at the last commanded displacement. :meth:`close` sends ``99``.

    Attributes:
        hold_count: Number of :meth:`hold` calls.
        fault: The last communication failure message ('' if none).
    """

    driver_name = 'generic_tcp'

    def force_control_problem(self) -> str | None:
        """Why this driver refuses force-controlled actuators (always: see the docs)."""
        return ('force control not supported; '
                'it sends OpenFresco trial displacements only (see '
                'docs/force_control.md)')

    error_type = GenericTCPError

    def __init__(
        self,
        host: str,
        port: int,
        n_dof: int = 1,
        timeout: float = 5.0,
        connect_timeout: float | None = None,
        data_size: int = DEFAULT_DATA_SIZE,
        byte_order: str = 'little',
    ) -> None:
        """Create the driver (not connected; see :meth:`open`).

        Args:
            host: Controller-side server address.
            port: Its TCP port.
            n_dof: Number of actuated DOF.
            timeout: Seconds to wait for each exchange (must cover the controller's
                ramp-and-hold time per step).
            connect_timeout: Seconds to wait for the connection; ``timeout`` if omitted.
            data_size: Doubles per data vector (OpenFresco: 256).
            byte_order: ``'little'`` or ``'big'``.

        Raises:
            BridgeConfigError: On an invalid argument.
        """
        super().__init__(n_dof, 'GenericTCPDriver')
        self._client = GenericTCPClient(host, port, timeout, connect_timeout, data_size,
                                        byte_order)
        # Validate the sizes now rather than at open().
        SizeID.from_sizes({'disp': n_dof}, {'disp': n_dof, 'force': n_dof}, data_size)

    @property
    def client(self) -> GenericTCPClient:
        """The protocol client."""
        return self._client

    @property
    def connected(self) -> bool:
        """Whether the connection to the controller is open."""
        return self._client.connected

    @property
    def address(self) -> str:
        """``host:port`` of the controller-side server."""
        return self._client.address

    def open(self) -> None:
        """Connect, send the size ID and read the current position and force.

        Raises:
            GenericTCPError: On any communication failure (the connection is then closed).
        """
        if self._client.connected:
            return
        self._client.connect()
        try:
            n = self._n_dof
            self._client.setup({'disp': n}, {'disp': n, 'force': n})
            daq = self._client.get_daq_response()
            self._store(daq.disp, daq.force)
        except GenericTCPError as exc:
            self.fault = str(exc)
            self._client.close()
            raise
        self.fault = ''

    def close(self) -> None:
        """Send ``99`` and disconnect. Idempotent."""
        self._client.close()

    def _exchange(self, step: StepId, target: list[float]) -> tuple[list[float], list[float]]:
        self._client.set_trial_response(disp=target)
        daq = self._client.get_daq_response()
        return list(daq.disp), list(daq.force)


def make_generic_tcp_driver(context: DriverContext) -> GenericTCPDriver:
    """The ``generic_tcp`` driver for ``tcp_host:tcp_port`` (``driver_timeout`` per exchange)."""
    parameters = context.parameters
    return GenericTCPDriver(parameters['tcp_host'], int(parameters['tcp_port']),
                            n_dof=context.n_dof, timeout=float(parameters['driver_timeout']))


GENERIC_TCP = DriverSpec(
    name='generic_tcp',
    factory=make_generic_tcp_driver,
    parameters=(
        DriverParameter('tcp_host', '127.0.0.1', 'controller server host'),
        DriverParameter('tcp_port', 44000, 'controller server port'),
        DriverParameter('driver_timeout', 5.0,
                        'seconds one move may take before the bridge holds'),
    ),
    description='client of an OpenFresco GenericTCP controller-side server, e.g. the '
                'controller_server next to a MOOG controller',
)
register_driver(GENERIC_TCP)
