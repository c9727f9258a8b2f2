"""The element server's socket: the bind policy, the allow-list, one client at a time.

OpenSees's TCP link carries no authentication, so :func:`check_bind` allows the loopback
address only, unless the caller says ``allow_remote`` and names the client addresses that may
connect; anything else is refused in one line naming the parameter. :class:`ElementLink`
accepts the element's connection (closing, with one log line, any client not on the
allow-list), reads its size message and then hands over one event at a time
(:class:`~.exchange.ElementExchange`). A malformed or out-of-order message, or a client that
disconnects, ends the connection: :class:`~pd_common.errors.ElementProtocolError` or
:class:`ElementLinkLostError`.
"""

from __future__ import annotations

import ipaddress
import logging
import socket
import time
from collections.abc import Callable, Sequence

from ..errors import ElementProtocolError
from . import wire
from .exchange import ElementExchange, Event

LOG = logging.getLogger('pd.element_server')

LOOPBACK = '127.0.0.1'
#: Seconds between two calls of :attr:`ElementLink.idle` while waiting for the element.
IDLE_INTERVAL = 0.5
_QUICKACK: int | None = getattr(socket, 'TCP_QUICKACK', None)


class ElementLinkLostError(ElementProtocolError):
    """The element's connection closed (or timed out) without ``DIE``."""


def allow_list(text: str) -> tuple[str, ...]:
    """The client addresses of an ``allow`` setting (comma separated; blanks ignored)."""
    return tuple(address.strip() for address in text.split(',') if address.strip())


def bind_listener(host: str, port: int) -> socket.socket:
    """A TCP socket bound to ``host:port`` for the element to connect to (not listening yet).

    ``SO_REUSEADDR``: a port a finished test's connection left in TIME_WAIT binds again.

    Raises:
        ElementProtocolError: the port cannot be bound (taken by another server or program).
    """
    listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        listener.bind((host, port))
    except OSError as err:
        listener.close()
        msg = (f'port: cannot bind {host}:{port} ({err.strerror}); another element server or '
               'program holds it')
        raise ElementProtocolError(msg) from None
    return listener


def check_bind(host: str, allow: Sequence[str], allow_remote: bool) -> list[str]:
    """Check the address to bind and the allow-list; returns the warnings to print.

    Raises:
        ElementProtocolError: A non-loopback ``host`` without ``allow_remote`` or without an
            allow-list, or an address that is not an IP address (the message names it).
    """
    try:
        bind = ipaddress.ip_address(host)
    except ValueError:
        msg = f'host: not an IP address: {host!r}'
        raise ElementProtocolError(msg) from None
    for address in allow:
        try:
            ipaddress.ip_address(address)
        except ValueError:
            msg = f'allow: not an IP address: {address!r}'
            raise ElementProtocolError(msg) from None
    if bind.is_loopback:
        return []
    if not allow_remote:
        msg = (f'host: {host} is not the loopback address; OpenSees\'s link has no '
               'authentication: pass allow_remote and an allow-list of client addresses')
        raise ElementProtocolError(msg)
    if not allow:
        msg = f'allow: binding {host} needs the list of client addresses that may connect'
        raise ElementProtocolError(msg)
    warning = (f'WARNING: serving OpenSees on {host} (no authentication on this link); '
               f'clients allowed: {", ".join(allow)}')
    return [warning]


class ElementLink:
    """A listening socket that serves one ``genericClient`` connection at a time.

    Args:
        host: Address to bind (checked by :func:`check_bind`).
        port: Port (0: the OS chooses; see :attr:`port`).
        allow: Client addresses allowed besides loopback clients of a loopback bind.
        allow_remote: The explicit consent to bind a non-loopback address.
        timeout: Seconds to wait for a connection or a message.

    Attributes:
        idle: Called about every :data:`IDLE_INTERVAL` s while waiting for the element (its
            connection or its next message), e.g. to keep a node's heartbeat going while
            OpenSees builds its model; ``None``: not called.
    """

    def __init__(self, host: str = LOOPBACK, port: int = 0, allow: Sequence[str] = (),
                 allow_remote: bool = False, timeout: float = 600.0) -> None:
        self.warnings = check_bind(host, allow, allow_remote)
        self._allow = {str(ipaddress.ip_address(a)) for a in allow}
        self._loopback_only = ipaddress.ip_address(host).is_loopback
        self.timeout = timeout
        self._listener = bind_listener(host, int(port))
        self._listener.listen(1)
        self.port: int = self._listener.getsockname()[1]
        self._client: socket.socket | None = None
        self.exchange: ElementExchange | None = None
        self.exchange_seconds: list[float] = []
        self.idle: Callable[[], None] | None = None

    @property
    def connected(self) -> bool:
        """Whether an element is connected."""
        return self._client is not None

    def _allowed(self, address: str) -> bool:
        if address in self._allow:
            return True
        return self._loopback_only and ipaddress.ip_address(address).is_loopback

    def accept(self, stiffness: Callable[[int], Sequence[Sequence[float]]]) -> None:
        """Wait for an allowed client and read its size message.

        Args:
            stiffness: The ``n`` x ``n`` stiffness to answer, given the element's DOFs.

        Raises:
            ElementLinkLostError: No allowed client within :attr:`timeout`.
            ElementProtocolError: A bad size message (the client is closed).
        """
        deadline = time.monotonic() + self.timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                msg = f'no OpenSees element connected within {self.timeout:g} s'
                raise ElementLinkLostError(msg)
            self._listener.settimeout(min(remaining, IDLE_INTERVAL))
            try:
                client, (address, _) = self._listener.accept()
            except TimeoutError:
                if self.idle is not None:
                    self.idle()
                continue
            if self._allowed(address):
                break
            LOG.warning('element server: refused a connection from %s (not allowed)', address)
            client.close()
        client.settimeout(min(self.timeout, IDLE_INTERVAL))
        client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._client = client
        try:
            size = wire.decode_size_message(self._read(wire.SIZE_MESSAGE_BYTES))
            self.exchange = ElementExchange(size, stiffness(size.n_dof))
        except ElementProtocolError as err:
            self.close(f'refused: {err}')
            raise

    def _read(self, n: int) -> bytes:
        assert self._client is not None
        chunks: list[bytes] = []
        got = 0
        deadline = time.monotonic() + self.timeout
        while got < n:
            try:
                if _QUICKACK is not None:  # acknowledge at once: the element's small writes
                    # without replies (trial, commit) would otherwise wait on Nagle's algorithm
                    # against a delayed ACK (40 ms per exchange)
                    self._client.setsockopt(socket.IPPROTO_TCP, _QUICKACK, 1)
                chunk = self._client.recv(n - got)
            except TimeoutError:
                if time.monotonic() < deadline:
                    if self.idle is not None:
                        self.idle()
                    continue
                msg = f'the element\'s connection failed: no message within {self.timeout:g} s'
                raise ElementLinkLostError(msg) from None
            except OSError as err:  # a reset
                msg = f'the element\'s connection failed: {err}'
                raise ElementLinkLostError(msg) from None
            if not chunk:
                msg = 'the element closed its connection without DIE'
                raise ElementLinkLostError(msg)
            chunks.append(chunk)
            got += len(chunk)
        return b''.join(chunks)

    def next_event(self) -> Event:
        """Answer queries until the test must act: a force request, a commit or the end.

        Raises:
            ElementLinkLostError: The connection closed or timed out (it is closed).
            ElementProtocolError: A malformed or out-of-order message (it is closed).
        """
        exchange = self.exchange
        if exchange is None or self._client is None:
            msg = 'no element is connected'
            raise ElementLinkLostError(msg)
        try:
            while True:
                event, reply = exchange.take(self._read(exchange.size.vector_bytes))
                if reply is not None:
                    self._client.sendall(reply)
                if event is not None:
                    return event
        except ElementProtocolError as err:
            self.close(str(err))
            raise
        except OSError as err:
            self.close(f'send failed: {err}')
            msg = f'the element\'s connection failed: {err}'
            raise ElementLinkLostError(msg) from None

    def answer_force(self, force: Sequence[float], measured: Sequence[float]) -> None:
        """Send the owed ``getForce`` reply.

        Raises:
            ElementLinkLostError: The connection failed (it is closed).
        """
        assert self.exchange is not None and self._client is not None
        reply = self.exchange.answer_force(force, measured)
        try:
            self._client.sendall(reply)
        except OSError as err:
            self.close(f'send failed: {err}')
            msg = f'the element\'s connection failed: {err}'
            raise ElementLinkLostError(msg) from None

    def close(self, reason: str = '') -> None:
        """Close the client's connection (the listener stays open), logging ``reason``."""
        if reason:
            LOG.warning('element server: connection closed: %s', reason)
        if self._client is not None:
            try:
                self._client.close()
            finally:
                self._client = None
                self.exchange = None

    def shutdown(self) -> None:
        """Close the connection and the listener."""
        self.close()
        self._listener.close()
