"""Who may steer from the console's page: a one-time login token and session cookies.

The console prints a login token on its terminal. A browser that presents it once gets a
session (a random cookie value); the token is then spent. Only requests with a live session
may send controls; any page may watch, and anyone on the console's own page may press the
emergency stop.

Every request must also name, in its ``Host`` header, the address the console serves
(:class:`ServedAddress`): a page of another site whose DNS name was pointed at this machine
(DNS rebinding) reaches the console's address and port, but its requests carry that name.
"""

from __future__ import annotations

import hmac
import ipaddress
import secrets
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

__all__ = ['BRIDGE_CONTROLS', 'SESSION_COOKIE', 'TEST_CONTROLS', 'WILDCARD_HOSTS',
           'ConsoleAccess', 'ControlRequest', 'ServedAddress', 'host_name', 'parse_control',
           'served_address', 'split_host']

#: Controls of the integrator (``/pd/test_control``) the page may send.
TEST_CONTROLS = ('pause', 'resume', 'abort')
#: Controls of a bridge (``/pd/[<site>/]bridge/control``) the page may send.
BRIDGE_CONTROLS = ('reset', 'reset_emergency_stop')
#: The name of the session cookie.
SESSION_COOKIE = 'pd_console_session'
#: Listening addresses that mean every address of the machine.
WILDCARD_HOSTS = ('', '0.0.0.0', '::')


@dataclass(frozen=True)
class ControlRequest:
    """A control the page asked for: ``bridge_site`` ``None`` means the integrator."""

    command: str
    bridge_site: str | None = None
    reason: str = ''


def parse_control(body: object, sites: tuple[str, ...]) -> ControlRequest:
    """The control asked for by a page's JSON body.

    Raises:
        ValueError: not a control the page may send, or an unknown site.
    """
    if not isinstance(body, dict):
        msg = 'control: the body must be a JSON object'
        raise ValueError(msg)
    command = str(body.get('command', '')).strip().lower()
    reason = str(body.get('reason', '') or 'from the console')[:200]
    if command in TEST_CONTROLS:
        return ControlRequest(command, None, reason)
    if command in BRIDGE_CONTROLS:
        site = str(body.get('site', '') or '')
        if sites and site not in sites:
            msg = f'control: unknown site {site!r} (sites: {", ".join(map(repr, sites))})'
            raise ValueError(msg)
        return ControlRequest(command, site, reason)
    allowed = ', '.join((*TEST_CONTROLS, *BRIDGE_CONTROLS))
    msg = f'control: {command!r} is not a console control ({allowed})'
    raise ValueError(msg)


class ConsoleAccess:
    """The login token and the live sessions.

    Args:
        token: the one-time login token (default: 128 random bits, URL-safe).
        session_lifetime: seconds a session lasts after its login.
        clock: monotonic clock (injectable for tests).
    """

    def __init__(self, token: str | None = None, *, session_lifetime: float = 12 * 3600.0,
                 clock: Callable[[], float] | None = None) -> None:
        self._token: str | None = token if token is not None else secrets.token_urlsafe(16)
        self.token = self._token
        self.session_lifetime = session_lifetime
        self._clock = clock or time.monotonic
        self._sessions: dict[str, float] = {}
        self.failed_logins = 0

    @property
    def token_spent(self) -> bool:
        """Whether the token was used."""
        return self._token is None

    def login(self, token: str) -> str | None:
        """A new session for the right, unspent token (then spent); ``None`` otherwise."""
        if self._token is None or not hmac.compare_digest(token.encode(),
                                                          self._token.encode()):
            self.failed_logins += 1
            return None
        self._token = None
        session = secrets.token_urlsafe(32)
        self._sessions[session] = self._clock() + self.session_lifetime
        return session

    def allowed(self, session: str | None) -> bool:
        """Whether ``session`` (a cookie value) may steer."""
        if not session:
            return False
        expires = self._sessions.get(session)
        if expires is None:
            return False
        if self._clock() > expires:
            del self._sessions[session]
            return False
        return True

    def logout(self, session: str | None) -> None:
        """End ``session``."""
        if session:
            self._sessions.pop(session, None)


def host_name(text: str) -> str:
    """``text`` as a ``Host`` header names it.

    ``text`` (a host name or an IP address; IPv6 with or without brackets) as a ``Host``
    header names it: lower case, an IPv6 address in brackets and compressed, an IPv4-mapped
    IPv6 address as its IPv4 address.
    """
    name = text.strip().lower()
    inner = name[1:-1] if name.startswith('[') and name.endswith(']') else name
    try:
        address = ipaddress.ip_address(inner)
    except ValueError:
        return name
    if isinstance(address, ipaddress.IPv6Address):
        if address.ipv4_mapped is not None:
            return str(address.ipv4_mapped)
        return f'[{address.compressed}]'
    return str(address)


def split_host(header: str | None, default_port: int = 80) -> tuple[str, int] | None:
    """A ``Host`` header's name and port, or ``None`` when missing or malformed.

    A ``Host`` header's name (as :func:`host_name` writes it) and port (``default_port``
    when it gives none); ``None`` when missing or malformed (a bare IPv6 address, a port that
    is not a number).
    """
    if not header:
        return None
    text = header.strip()
    if text.startswith('['):
        end = text.find(']')
        if end < 0:
            return None
        name, rest = text[:end + 1], text[end + 1:]
        if rest and not rest.startswith(':'):
            return None
        port_text = rest[1:] if rest else ''
    else:
        name, _, port_text = text.partition(':')
        if ':' in port_text:
            return None
    if not name or name == '[]':
        return None
    if not port_text:
        return host_name(name), default_port
    if not (port_text.isascii() and port_text.isdigit()) or not 0 < int(port_text) < 65536:
        return None
    return host_name(name), int(port_text)


@dataclass(frozen=True)
class ServedAddress:
    """The names a request's ``Host`` header may give for the console's address.

    The names a request's ``Host`` header may give for the address the console listens
    on (made by :func:`served_address`).

    Attributes:
        names: host names and IP addresses, as :func:`host_name` writes them.
        wildcard: listening on every address of the machine: the local address a connection
            reached is also accepted.
    """

    names: frozenset[str]
    wildcard: bool = False

    def allows(self, header: str | None, port: int, local_address: str = '') -> bool:
        """Whether ``header`` (a request's ``Host``) names this console.

        One of ``names`` (or, listening everywhere, ``local_address``, the address the connection
        reached) and ``port``, the port the console listens on.
        """
        split = split_host(header)
        if split is None:
            return False
        name, given = split
        if given != port:
            return False
        return name in self.names or (self.wildcard and bool(local_address)
                                      and name == host_name(local_address))


def served_address(host: str, machine_names: Iterable[str] = ()) -> ServedAddress:
    """The :class:`ServedAddress` of a console told to listen on ``host``: ``host`` itself.

    ``localhost`` too for ``127.0.0.1`` and ``::1`` (and both of them for ``localhost``); for an
    address of every interface (:data:`WILDCARD_HOSTS`), also the loopback names and
    ``machine_names`` (the machine's own names, found by the caller).
    """
    name = host_name(host)
    names = {name} if name else set()
    if name in ('127.0.0.1', '[::1]'):
        names.add('localhost')
    elif name == 'localhost':
        names |= {'127.0.0.1', '[::1]'}
    wildcard = host.strip() in WILDCARD_HOSTS or name in ('0.0.0.0', '[::]')
    if wildcard:
        names |= {'localhost', '127.0.0.1', '[::1]'}
        names |= {host_name(machine) for machine in machine_names if machine.strip()}
    return ServedAddress(frozenset(names), wildcard)
