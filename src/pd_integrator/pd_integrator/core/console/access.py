"""Who may steer from the console's page: a one-time login token and session cookies.

The console prints a login token on its terminal. A browser that presents it once gets a
session (a random cookie value); the token is then spent. Only requests with a live session
may send controls; any page may watch, and anyone may press the emergency stop.
"""

from __future__ import annotations

import hmac
import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ['BRIDGE_CONTROLS', 'SESSION_COOKIE', 'TEST_CONTROLS', 'ConsoleAccess',
           'ControlRequest', 'parse_control']

#: Controls of the integrator (``/pd/test_control``) the page may send.
TEST_CONTROLS = ('pause', 'resume', 'abort')
#: Controls of a bridge (``/pd/[<site>/]bridge/control``) the page may send.
BRIDGE_CONTROLS = ('reset', 'reset_emergency_stop')
#: The name of the session cookie.
SESSION_COOKIE = 'pd_console_session'


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
