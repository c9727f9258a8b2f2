"""Controller-side GenericTCP server (``ros2 run pd_actuator_bridge controller_server``).

It plays the role of a server written for OpenFresco's ``expControl GenericTCP`` running next
to the actuator controller (e.g. a MOOG controller): it accepts **one** client, reads the
11-integer size ID, then answers ``setTrialResponse`` (3), ``getDaqResponse`` (6) and
``commitState`` (5, accepted and ignored as a no-op) until the client sends ``99`` (or ``98``)
or disconnects. The wire format is documented in
:mod:`pd_actuator_bridge.core.drivers.generic_tcp_protocol`.
OpenFresco's optional ``-initFile`` parameter messages are not supported.

The "controller" behind the server is pluggable (:class:`~.controllers.Controller`; the
controllers are in :mod:`pd_actuator_bridge.controllers`):

* :class:`~.controllers.ElasticController` (default): an ideal actuator that reaches every trial
  displacement exactly, on an elastic specimen ``f = k x`` (``--stiffness``).
* ``--emulator``: the servo-hydraulic emulator of :mod:`pd_actuator_bridge.core.drivers.emulator`
  (1 kHz closed-loop actuator model) on the same elastic specimen, each step executed by the
  core's ramp-and-hold executor (:class:`~pd_actuator_bridge.core.RampHoldExecutor`: a ramp of
  ``--ramp-time``, a hold of at least ``--hold-time``, until the measurement has settled), see
  :func:`~.controllers.load_emulator_controller`. If the emulator cannot be built the server
  says so on stderr and falls back to the elastic controller.

Usage::

    controller_server --host 127.0.0.1 --port 0 --dofs 1 --stiffness 2e6

The first line on stdout is ``controller_server: listening on HOST:PORT`` (with the port the OS
chose for ``--port 0``). The exit code is 0 when the client ended the session with 99 (or the
server was interrupted), 1 when the session ended on an error or a disconnect without 99.

No ``rclpy``: the server is usable in-process (:class:`ControllerServer`, started in a thread)
as the tests do, and as a plain executable.
"""

from __future__ import annotations

import argparse
import logging
import math
import socket
import sys
import threading
import time
from collections.abc import Sequence

from pd_actuator_bridge.controllers import Controller, ControllerError, make_controller
from pd_actuator_bridge.core.drivers.generic_tcp_protocol import (
    ACTION_COMMIT_STATE,
    ACTION_DIE,
    ACTION_GET_DAQ_RESPONSE,
    ACTION_NAMES,
    ACTION_SET_TRIAL_RESPONSE,
    ACTION_SHUTDOWN,
    SIZE_ID_LENGTH,
    GenericTCPError,
    SizeID,
    decode_size_id,
    decode_trial,
    decode_vector,
    encode_daq,
    first_non_finite,
)
from pd_common.signals import StopFlag, restore_handlers, stop_on_signals

LOGGER = logging.getLogger('pd_actuator_bridge.controller_server')

_POLL = 0.1
"""Seconds between checks of the stop request while waiting on a socket."""


# --------------------------------------------------------------------------- server


class ControllerServer:
    """A GenericTCP controller-side server for one client session.

    :meth:`start` binds and listens (``port=0`` lets the OS choose: read :attr:`port`) and
    serves in a background thread; :meth:`stop` ends the session at once (closing the
    connection, like a controller that dies) and joins the thread. Usable as a context manager.

    Attributes:
        steps: Number of ``setTrialResponse`` messages executed.
        daq_requests: Number of ``getDaqResponse`` messages answered.
        ended_by_client: Whether the client ended the session with 99 (or 98).
        error: Why the session ended abnormally ('' otherwise).
        size_id: The client's size ID, once received.
    """

    def __init__(
        self,
        controller: Controller,
        host: str = '127.0.0.1',
        port: int = 0,
        idle_timeout: float | None = None,
        byte_order: str = 'little',
        die_after: int | None = None,
    ) -> None:
        """Create the server (not listening yet).

        Args:
            controller: The controller executing the trials.
            host: Address to bind (loopback by default).
            port: Port to bind; 0 lets the OS choose.
            idle_timeout: End the session if the client sends nothing for this many seconds
                (``None``: wait indefinitely, as a lab server does between steps).
            byte_order: ``'little'`` or ``'big'``.
            die_after: Fault injection: after this many trials, drop the connection on the next
                ``setTrialResponse`` without answering (a controller crash). ``None``: never.
        """
        self._controller = controller
        self._host = host
        self._requested_port = int(port)
        self._idle_timeout = idle_timeout
        self._byte_order = byte_order
        self._die_after = die_after
        self._listener: socket.socket | None = None
        self._conn: socket.socket | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._done = threading.Event()
        self._lock = threading.Lock()
        self._port = 0
        self.steps = 0
        self.daq_requests = 0
        self.ended_by_client = False
        self.error = ''
        self.size_id: SizeID | None = None

    # ------------------------------------------------------------------ lifecycle

    @property
    def host(self) -> str:
        """Bound address."""
        return self._host

    @property
    def port(self) -> int:
        """Bound port (0 before :meth:`start`)."""
        return self._port

    @property
    def done(self) -> bool:
        """Whether the session has ended (or was stopped)."""
        return self._done.is_set()

    def start(self) -> int:
        """Bind, listen and serve one session in a background thread.

        Returns:
            The bound port.

        Raises:
            OSError: If the address cannot be bound.
        """
        if self._thread is not None:
            msg = 'ControllerServer: start() called twice'
            raise RuntimeError(msg)
        family = socket.AF_INET6 if ':' in self._host else socket.AF_INET
        listener = socket.create_server((self._host, self._requested_port), family=family,
                                        backlog=1)
        listener.settimeout(_POLL)
        self._listener = listener
        self._port = listener.getsockname()[1]
        self._thread = threading.Thread(
            target=self._run, name=f'controller_server:{self._port}', daemon=True
        )
        self._thread.start()
        return self._port

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the session to end; return whether it has."""
        return self._done.wait(timeout)

    def stop(self, timeout: float = 5.0) -> None:
        """End the session now, close every socket and join the thread. Idempotent.

        The connection is shut down at once (the client sees it closed, as when a controller
        dies); the serving thread notices within a poll period and exits.
        """
        self._stop.set()
        with self._lock:
            conn = self._conn
        if conn is not None:
            try:
                conn.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout)
        self._close_sockets()
        self._done.set()

    def __enter__(self) -> ControllerServer:
        """Start the server (if needed) and return it."""
        if self._listener is None:
            self.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        """Stop the server."""
        self.stop()

    # ------------------------------------------------------------------ serving

    def _run(self) -> None:
        try:
            conn = self._accept()
            if conn is not None:
                with self._lock:
                    self._conn = conn
                host, port = conn.getpeername()[:2]
                LOGGER.info('client %s:%s connected', host, port)
                self._session(conn)
        except Exception as exc:  # noqa: BLE001 - report, never crash the thread silently
            self._fail(f'internal error: {type(exc).__name__}: {exc}')
        finally:
            self._close_sockets()
            self._done.set()

    def _accept(self) -> socket.socket | None:
        listener = self._listener
        assert listener is not None
        while not self._stop.is_set():
            try:
                conn, _ = listener.accept()
            except TimeoutError:
                continue
            except OSError:
                return None  # closed by stop()
            # One client only: stop listening.
            with self._lock:
                self._listener = None
            listener.close()
            conn.settimeout(_POLL)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            return conn
        return None

    def _session(self, conn: socket.socket) -> None:
        payload = self._receive(conn, 4 * SIZE_ID_LENGTH, 'the size ID')
        if payload is None:
            return
        try:
            size_id = decode_size_id(payload, self._byte_order)
            self._controller.setup(size_id)
        except (GenericTCPError, ControllerError) as exc:
            self._fail(f'setup: {exc}')
            return
        self.size_id = size_id
        LOGGER.info('size ID %s', size_id.as_list())
        while not self._stop.is_set():
            payload = self._receive(conn, size_id.vector_bytes, 'a request', between=True)
            if payload is None:
                return
            vector = decode_vector(payload, size_id.data_size, self._byte_order)
            if not self._handle(conn, size_id, vector):
                return

    def _handle(self, conn: socket.socket, size_id: SizeID, vector: list[float]) -> bool:
        """Execute one request; return whether the session goes on."""
        code = vector[0]
        if not math.isfinite(code) or code != int(code):
            self._fail(f'malformed request: action code {code!r}')
            return False
        action = int(code)
        name = ACTION_NAMES.get(action, str(action))
        try:
            if action == ACTION_SET_TRIAL_RESPONSE:
                if self._die_after is not None and self.steps >= self._die_after:
                    self._fail(f'fault injection: controller died after {self.steps} steps')
                    return False
                trial = decode_trial(vector, size_id)
                bad = first_non_finite(trial)
                if bad is not None:
                    self._fail(f'{name}: refusing a non-finite trial: {bad}')
                    return False
                self._controller.set_trial_response(trial)
                self.steps += 1
            elif action == ACTION_GET_DAQ_RESPONSE:
                daq = self._controller.get_daq_response()
                conn.settimeout(self._idle_timeout if self._idle_timeout else 5.0)
                conn.sendall(encode_daq(size_id, daq, self._byte_order))
                conn.settimeout(_POLL)
                self.daq_requests += 1
            elif action == ACTION_COMMIT_STATE:
                self._controller.commit_state()
            elif action in (ACTION_DIE, ACTION_SHUTDOWN):
                self.ended_by_client = True
                LOGGER.info('client ended the session (%d) after %d steps', action, self.steps)
                return False
            else:
                self._fail(f'unsupported action {action}')
                return False
        except (ControllerError, GenericTCPError) as exc:
            self._fail(f'{name}: {exc}')
            return False
        except OSError as exc:
            self._fail(f'{name}: connection lost: {type(exc).__name__}: {exc}')
            return False
        except Exception as exc:  # noqa: BLE001 - a controller failure ends the session
            self._fail(f'{name}: controller failed: {type(exc).__name__}: {exc}')
            return False
        return True

    def _receive(self, conn: socket.socket, n: int, what: str,
                 between: bool = False) -> bytes | None:
        """Read ``n`` bytes, honouring stop requests and the idle timeout."""
        chunks: list[bytes] = []
        got = 0
        last = time.monotonic()
        while got < n:
            if self._stop.is_set():
                return None
            try:
                chunk = conn.recv(n - got)
            except TimeoutError:
                if self._idle_timeout is not None and time.monotonic() - last > self._idle_timeout:
                    self._fail(f'no data for {self._idle_timeout:g} s while waiting for {what} '
                               f'({got} of {n} bytes)')
                    return None
                continue
            except OSError as exc:
                if not self._stop.is_set():
                    self._fail(f'connection lost waiting for {what}: {type(exc).__name__}')
                return None
            if not chunk:
                if self._stop.is_set():
                    return None
                if got or not between:
                    self._fail(f'client closed the connection mid-message ({got} of {n} bytes '
                               f'of {what})')
                else:
                    self._fail('client closed the connection without sending 99')
                return None
            chunks.append(chunk)
            got += len(chunk)
            last = time.monotonic()
        return b''.join(chunks)

    def _fail(self, message: str) -> None:
        if not self.error:
            self.error = message
        LOGGER.error('%s', message)

    def _close_sockets(self) -> None:
        with self._lock:
            listener, self._listener = self._listener, None
            conn, self._conn = self._conn, None
        for sock in (conn, listener):
            if sock is None:
                continue
            try:
                sock.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            sock.close()


# --------------------------------------------------------------------------- executable


def _parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog='controller_server',
        description='OpenFresco GenericTCP controller-side server (one client session).',
    )
    parser.add_argument('--host', default='127.0.0.1', help='address to bind (127.0.0.1)')
    parser.add_argument('--port', type=int, default=0,
                        help='port to bind; 0 lets the OS choose and prints it (0)')
    parser.add_argument('--dofs', type=int, default=1, help='number of actuated DOF (1)')
    parser.add_argument('--stiffness', type=float, default=1.0e6,
                        help='elastic specimen stiffness per DOF, N/m (1e6)')
    parser.add_argument('--emulator', action='store_true',
                        help='use the servo-hydraulic emulator (ramp-and-hold) if it can be built')
    parser.add_argument('--ramp-time', type=float, default=0.2,
                        help='emulator: ramp duration per step, s (0.2)')
    parser.add_argument('--hold-time', type=float, default=0.3,
                        help='emulator: minimum hold per step before sampling, s (0.3)')
    parser.add_argument('--idle-timeout', type=float, default=None,
                        help='end the session after this many seconds without data (never)')
    parser.add_argument('--byte-order', choices=('little', 'big'), default='little',
                        help='byte order of the wire data (little, as OpenFresco on x86)')
    args = parser.parse_args(argv)
    if args.dofs < 1:
        parser.error(f'--dofs must be >= 1, got {args.dofs}')
    if not 0 <= args.port < 65536:
        parser.error(f'--port must be in 0..65535, got {args.port}')
    if not math.isfinite(args.stiffness):
        parser.error(f'--stiffness must be finite, got {args.stiffness}')
    if not (args.ramp_time >= 0 and args.hold_time > 0):
        parser.error('--ramp-time must be >= 0 and --hold-time > 0')
    if args.idle_timeout is not None and not args.idle_timeout > 0:
        parser.error(f'--idle-timeout must be > 0, got {args.idle_timeout}')
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Run one GenericTCP session; see the module docstring for options and exit codes."""
    args = _parse_args(argv)
    logging.basicConfig(level=logging.INFO, stream=sys.stderr,
                        format='controller_server: %(levelname)s: %(message)s')

    def warn(message: str) -> None:
        print(f'controller_server: {message}', file=sys.stderr, flush=True)

    controller = make_controller(args.dofs, args.stiffness, args.emulator, warn,
                                 args.ramp_time, args.hold_time)
    server = ControllerServer(controller, args.host, args.port, args.idle_timeout,
                              args.byte_order)
    try:
        port = server.start()
    except OSError as exc:
        print(f'controller_server: cannot listen on {args.host}:{args.port}: {exc}',
              file=sys.stderr)
        return 1
    print(f'controller_server: listening on {args.host}:{port}', flush=True)
    LOGGER.info('controller: %s', controller.describe())

    stop_requested = StopFlag()
    previous = stop_on_signals(stop_requested)
    try:
        while not server.wait(_POLL):
            if stop_requested.is_set():
                LOGGER.info('stop requested')
                break
    finally:
        server.stop()
        restore_handlers(previous)
    if stop_requested.is_set():
        return 0
    return 0 if server.ended_by_client else 1


if __name__ == '__main__':
    sys.exit(main())
