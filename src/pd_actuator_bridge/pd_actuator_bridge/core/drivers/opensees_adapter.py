"""Client of OpenSees's ``adapter`` element: an OpenSees substructure as one site of a test.

The ``adapter`` element (class ``Adapter``, written for OpenFresco's ``ECSimAdapter``
experimental control) sits on DOF of an OpenSees model and serves them over TCP: a client
sends trial displacements, the element pushes its nodes there through a stiff penalty
spring, and it answers with the displacements the nodes reached and the forces the rest of
the model resists with. This module is that client, as an :class:`ActuatorDriver`, so a
numerical substructure can stand where a specimen behind an actuator would.

Protocol facts, as read in the public sources (no code was copied from them):

* OpenSees ``SRC/element/adapter/Adapter.cpp`` and ``Adapter.h``:

  - The element is the TCP **server**: on its first ``update()`` (i.e. inside the first
    ``analyze`` call) it creates ``TCP_Socket(ipPort)``, accepts one client and reads an
    11-integer size ID ``[ctrl disp, vel, accel, force, time, daq disp, vel, accel, force,
    time, dataSize]``. Every size except ``dataSize`` must be 0 or the element's number of
    basic DOF ``n`` (else the set-up fails). ``dataSize`` is chosen by the **client**: every
    later vector in either direction is exactly ``dataSize`` float64, zero padded.
  - Received vector: ``[action, ctrl disp (n), ...]``; sent vector: ``[daq disp (n), daq
    force (n), ...]`` from index 0, no action code. ``ctrlDisp`` is used unconditionally, so
    the client must control displacements and acquire displacements and forces.
  - Action codes (``Adapter.h``): ``setTrialResponse = 3``, ``getForce = 10``, ``DIE = 99``
    (the others exist but the element does not serve them).
  - ``getResistingForce()`` receives one vector per analysis step, whenever the domain
    time has advanced: if it is ``10`` the element sends its daq vector (the state of the
    previous step) and receives again; the vector must then be ``3`` with the new trial.
    ``99`` prints "The Simulation has successfully completed." and calls ``exit(-1)``; any
    other code prints an error and calls ``exit(-1)`` too.
  - The element's basic force is ``q = kb (db - ctrlDisp)`` with ``kb`` the ``-stif``
    matrix and ``db`` the nodes' trial displacements; it reports ``daqDisp = db`` and
    ``daqForce = -q``.

* OpenSees ``SRC/actor/channel/TCP_Socket.cpp``: vectors and IDs are written raw in native
  byte order (int32 for the ID, float64 for vectors), with no header or terminator.

Consequences for this client:

* **Sequence.** ``open()``: connect (retrying until ``connect_timeout``, since OpenSees
  listens only once its analysis loop starts), send the size ID ``[n,0,0,0,0, n,0,0,n,0,
  data_size]`` and ``[10]``: the element answers with its initial (zero) state, which proves
  the link. ``command()``: ``[3, target…]`` then ``[10]`` and read the reply. The reply to
  ``[10]`` arrives once OpenSees has converged the step of ``[3, …]`` and begun the next
  ``analyze`` call. ``close()``: ``[99]`` — OpenSees then exits (status 255 from its
  ``exit(-1)``; :mod:`pd_actuator_bridge.opensees_site` reports that as success).
* **Sign.** At equilibrium the adapter's basic force ``q`` balances the rest of the model at
  those DOF, so ``daqForce = -q`` is the force the substructure **resists with**: positive
  for a positive displacement of a spring. It is reported unchanged (no sign flip).
* **Displacement.** The nodes settle at ``target - kb⁻¹ r`` (the penalty spring carries the
  restoring force ``r``), so the measured displacement differs from the command by
  ``r / kb``: a tiny, deterministic tracking error. The measured value is what the
  substructure really has; the force belongs to it.
* **No framing.** A reply too short shows as a timeout or a closed connection, a reply too
  long as bytes left over: both are :class:`OpenSeesAdapterError`, as are non-finite values.
"""

from __future__ import annotations

import math
import socket
import time

import numpy as np

from ..errors import BridgeConfigError, DriverError
from .base import RemoteDriver, StepId
from .generic_tcp_protocol import (
    DEFAULT_DATA_SIZE,
    SizeID,
    decode_vector,
    describe_error,
    encode_action,
    encode_size_id,
    pending_bytes,
    recv_exact,
)
from .registry import DriverContext, DriverParameter, DriverSpec, register_driver

ACTION_SET_TRIAL_RESPONSE = 3
"""``RemoteTest_setTrialResponse``: ``[3, ctrl disp…]``, no reply."""

ACTION_GET_FORCE = 10
"""``RemoteTest_getForce``: ``[10]``, answered by ``[daq disp…, daq force…]``."""

ACTION_DIE = 99
"""``RemoteTest_DIE``: end of the test; OpenSees exits."""

CONNECT_RETRY_INTERVAL = 0.05
"""Seconds between connection attempts while OpenSees is not listening yet."""


class OpenSeesAdapterError(DriverError):
    """An exchange with an OpenSees adapter element failed."""


def adapter_size_id(n_dof: int, data_size: int = DEFAULT_DATA_SIZE) -> SizeID:
    """The size ID this client sends: displacements controlled; displacements, forces acquired.

    Raises:
        BridgeConfigError: If ``data_size`` cannot hold ``[action, n targets]`` and ``2 n``
            daq values.
    """
    sizes = {'disp': n_dof}
    return SizeID.from_sizes(sizes, {'disp': n_dof, 'force': n_dof}, data_size)


class OpenSeesAdapterDriver(RemoteDriver):
    """Synchronous driver for an OpenSees ``adapter`` element (see the module docstring).

    Attributes:
        hold_count: Number of :meth:`hold` calls.
        fault: The last communication failure message ('' if none).
    """

    driver_name = 'opensees_adapter'

    def force_control_problem(self) -> str | None:
        """Why this driver refuses force-controlled actuators (always: see the docs)."""
        return ('force control not supported; '
                'the OpenSees adapter element takes displacements only')

    error_type = OpenSeesAdapterError

    def __init__(
        self,
        host: str = '127.0.0.1',
        port: int = 44001,
        n_dof: int = 1,
        timeout: float = 5.0,
        connect_timeout: float = 10.0,
        data_size: int = DEFAULT_DATA_SIZE,
    ) -> None:
        """Create the driver (not connected; see :meth:`open`).

        Args:
            host: Host running OpenSees.
            port: The adapter element's ``ipPort``.
            n_dof: Number of DOF the adapter element serves (its basic DOF).
            timeout: Seconds to wait for each reply (covers one OpenSees analysis step).
            connect_timeout: Seconds to keep retrying the connection while OpenSees is not
                listening yet.
            data_size: Doubles per vector, announced in the size ID (OpenFresco uses 256).

        Raises:
            BridgeConfigError: On an invalid argument.
        """
        super().__init__(n_dof, 'OpenSeesAdapterDriver')
        where = 'OpenSeesAdapterDriver'
        if not isinstance(host, str) or not host:
            msg = f'{where}: host must be a non-empty string, got {host!r}'
            raise BridgeConfigError(msg)
        if isinstance(port, bool) or not isinstance(port, int) or not 0 < port < 65536:
            msg = f'{where}: port must be an integer in 1..65535, got {port!r}'
            raise BridgeConfigError(msg)
        for name, value in (('timeout', timeout), ('connect_timeout', connect_timeout)):
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                math.isfinite(value) and value > 0
            ):
                msg = f'{where}: {name} must be a positive number of seconds, got {value!r}'
                raise BridgeConfigError(msg)
        self._size_id = adapter_size_id(n_dof, data_size)
        self._host = host
        self._port = port
        self._timeout = float(timeout)
        self._connect_timeout = float(connect_timeout)
        self._sock: socket.socket | None = None

    # ------------------------------------------------------------------ properties

    @property
    def address(self) -> str:
        """``host:port`` of the adapter element."""
        return f'{self._host}:{self._port}'

    @property
    def connected(self) -> bool:
        """Whether the connection is open."""
        return self._sock is not None

    @property
    def size_id(self) -> SizeID:
        """The size ID sent at :meth:`open`."""
        return self._size_id

    # ------------------------------------------------------------------ driver API

    def open(self) -> None:
        """Connect (retrying until ``connect_timeout``), send the size ID and read the state.

        Raises:
            OpenSeesAdapterError: If nothing accepts the connection in time or the first
                exchange fails (the connection is then closed).
        """
        if self._sock is not None:
            return
        self._sock = self._connect()
        try:
            self._send('setup', encode_size_id(self._size_id))
            self._store(*self._split(self._acquire('open')))
        except OpenSeesAdapterError as exc:
            self.fault = str(exc)
            self._drop()
            raise
        self.fault = ''

    def _exchange(self, step: StepId, target: list[float]) -> tuple[list[float], list[float]]:
        action = f'step {step}'
        self._send(action, encode_action(ACTION_SET_TRIAL_RESPONSE, self._size_id.data_size,
                                         target))
        return self._split(self._acquire(action))

    def close(self) -> None:
        """Send ``[99]`` (OpenSees ends its analysis) and disconnect. Idempotent."""
        sock = self._sock
        if sock is None:
            return
        try:
            sock.settimeout(min(self._timeout, 1.0))
            sock.sendall(encode_action(ACTION_DIE, self._size_id.data_size))
        except OSError:
            pass  # OpenSees is gone already: nothing more to tell it
        self._drop()

    # ------------------------------------------------------------------ internals

    def _error(self, action: str, message: str) -> OpenSeesAdapterError:
        return OpenSeesAdapterError(f'OpenSees adapter {self.address}: {action}: {message}')

    def _connect(self) -> socket.socket:
        action = 'connect'
        deadline = time.monotonic() + self._connect_timeout
        last = 'no attempt'
        while True:
            remaining = deadline - time.monotonic()
            try:
                sock = socket.create_connection((self._host, self._port),
                                                timeout=max(remaining, 0.05))
            except ConnectionRefusedError:
                last = 'connection refused'
            except TimeoutError:
                last = 'connection attempt timed out'
            except OSError as exc:
                raise self._error(action, describe_error(exc)) from None
            else:
                sock.settimeout(self._timeout)
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                return sock
            if time.monotonic() + CONNECT_RETRY_INTERVAL > deadline:
                raise self._error(
                    action, f'{last} for {self._connect_timeout:g} s (is the OpenSees model '
                    f'with the adapter element running its analysis?)'
                )
            time.sleep(CONNECT_RETRY_INTERVAL)

    def _drop(self) -> None:
        sock, self._sock = self._sock, None
        if sock is not None:
            try:
                sock.close()
            except OSError:
                pass

    def _send(self, action: str, payload: bytes) -> None:
        sock = self._sock
        if sock is None:
            raise self._error(action, 'not connected')
        extra, closed = pending_bytes(sock)
        if closed:
            self._drop()
            raise self._error(action, 'OpenSees closed the connection')
        if extra:
            self._drop()
            raise self._error(
                action, f'malformed stream: {extra} unexpected byte(s) from OpenSees before '
                f'the request (previous reply too long?)'
            )
        try:
            sock.sendall(payload)
        except TimeoutError:
            self._drop()
            raise self._error(action, f'send timed out after {self._timeout:g} s') from None
        except OSError as exc:
            self._drop()
            raise self._error(action, f'OpenSees closed the connection ({describe_error(exc)})') \
                from None

    def _acquire(self, action: str) -> np.ndarray:
        """Send ``[10]`` and return the validated ``2 n`` daq values."""
        size = self._size_id.data_size
        self._send(action, encode_action(ACTION_GET_FORCE, size))
        assert self._sock is not None
        nbytes = 8 * size
        payload, failure = recv_exact(self._sock, nbytes)
        if failure:
            self._drop()
            got = f'got {len(payload)} of {nbytes} bytes'
            if failure == 'timeout':
                message = (f'no reply within {self._timeout:g} s ({got}; OpenSees stuck, '
                           f'not converging, or a reply shorter than data_size {size})')
            elif failure == 'closed':
                message = (f'OpenSees closed the connection mid-reply ({got}: short read)'
                           if payload else 'OpenSees closed the connection before replying')
            elif failure == 'reset':
                message = f'OpenSees reset the connection ({got})'
            else:
                message = f'receive failed ({got}; {failure.removeprefix("error: ")})'
            raise self._error(action, message)
        extra, _ = pending_bytes(self._sock)
        if extra:
            self._drop()
            raise self._error(
                action, f'wrong reply size: {extra} byte(s) after the {nbytes}-byte vector '
                f'(expected exactly data_size {size} doubles)'
            )
        n = self._n_dof
        daq = np.asarray(decode_vector(payload, size)[:2 * n], dtype=float)
        bad = np.flatnonzero(~np.isfinite(daq))
        if bad.size:
            i = int(bad[0])
            kind, index = ('displacement', i) if i < n else ('force', i - n)
            self._drop()
            raise self._error(action, f'non-finite {kind}[{index}] = {daq[i]} in the reply')
        return daq

    def _split(self, daq: np.ndarray) -> tuple[list[float], list[float]]:
        """``(displacement, force)`` of the adapter's ``[disp…, force…]`` reply."""
        n = self._n_dof
        return daq[:n].tolist(), daq[n:2 * n].tolist()


def make_opensees_adapter_driver(context: DriverContext) -> OpenSeesAdapterDriver:
    """The ``opensees_adapter`` driver for the adapter element at ``tcp_host:tcp_port``."""
    parameters = context.parameters
    return OpenSeesAdapterDriver(parameters['tcp_host'], int(parameters['tcp_port']),
                                 n_dof=context.n_dof,
                                 timeout=float(parameters['driver_timeout']))


OPENSEES_ADAPTER = DriverSpec(
    name='opensees_adapter',
    factory=make_opensees_adapter_driver,
    parameters=(
        DriverParameter('tcp_host', '127.0.0.1', 'host running the OpenSees adapter element'),
        DriverParameter('tcp_port', 44000, "the adapter element's port"),
        DriverParameter('driver_timeout', 5.0,
                        'seconds one move (one OpenSees analysis step) may take'),
    ),
    description="client of OpenSees's adapter element: an OpenSees substructure as a site "
                '(run opensees_site)',
)
register_driver(OPENSEES_ADAPTER)
