"""The live test console in the browser.

``./pd console [RUN]`` (``ros2 run pd_console console``).

A local web server (aiohttp, its WebSocket) serving one page, with its JavaScript and plotting
shipped in this package (``share/pd_console/console``): nothing is loaded from the
internet. Live, the node only *subscribes* to the graph's topics — the integrator's status and
test definition, every site's step command and feedback and its bridge's status — and pushes a
decimated frame to the page on a timer (``update_rate`` Hz, at most ``max_points`` rows per
series): it never slows the test. The data handling is the pure
:mod:`pd_console.core`; this module is its shell.

Controls (pause, resume, abort; a bridge's reset and reset_emergency_stop) are signed with the
test's key exactly as ``./pd control`` signs them, and only a browser that logged in with the
one-time token printed on this terminal may send them; any other page can watch, and its
control requests are refused (HTTP 403) with nothing published. The emergency stop needs no
login (unsigned, as the e-stop topic is by design), but like every request that changes
anything it must be a JSON POST from the console's own page: another site's page (a form
post) is refused. Every request must name the served address in its ``Host`` header (DNS
rebinding is refused, HTTP 421). A client that drops its request costs one line on this
terminal, never a traceback.

``./pd console runs/<run>`` shows a finished run (its bag, or its journal) and its figures.
The server listens on 127.0.0.1 unless ``--host`` says otherwise (a lab network: a warning
is printed).
"""

from __future__ import annotations

import argparse
import asyncio
import ipaddress
import json
import logging
import math
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from socket import gethostname
from typing import Any

import foxglove
import rclpy
from aiohttp import WSMsgType, web
from aiohttp.typedefs import Handler
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.context import Context
from rclpy.node import Node
from rclpy.utilities import remove_ros_args
from std_msgs.msg import String

from pd_common.auth import (
    AuthError,
    Key,
    Refusal,
    StatusGate,
    WatchGate,
    WirePayload,
    command_payload,
    feedback_payload,
    load_key,
    operator_key_path,
)
from pd_common.config import SchemaError, default_bridge_parameter_file, read_bridge_parameter_file
from pd_common.protocol import (
    GLOBAL_EMERGENCY_STOP,
    Signature,
    Status,
    decode_command,
    decode_feedback,
    signed_from_bytes,
    site_topic,
    site_topic_name,
)
from pd_common.resources import ResourceError, share_file
from pd_common.ros import (
    CONTROL_DEPTH,
    LATCHED_QOS,
    LATCHED_READER_QOS,
    RESEND_S,
    STEP_QOS,
    ControlSender,
    RefusalLog,
    events_executor,
    init_with_stop_flag,
    read_offer,
    repeat_emergency_stop,
    seal_parameters,
)
from pd_common.signals import StopFlag
from pd_core.errors import BagError
from pd_msgs.msg import SessionOffer, StepCommand, StepFeedback

from .core import (
    BRIDGE_LIMITS,
    SESSION_COOKIE,
    STATUS_TOPIC,
    ConsoleAccess,
    ConsoleModel,
    ControlRequest,
    DefinitionWitness,
    gauges_message,
    gauges_topic,
    load_run_folder,
    parse_control,
    response_message,
    response_topic,
)
from .core.access import WILDCARD_HOSTS, served_address

#: Why a genuine step message may go unshown for a moment (a session the receiver's offer has
#: not named yet, or one it has left): not worth a line.
SESSION_CHANGES = frozenset({Refusal.NO_SESSION, Refusal.FOREIGN_SESSION})

#: Seconds before the latched test definition is read again while the one the integrator's
#: signed status names is missing (see :class:`pd_console.core.DefinitionWitness`); doubled
#: after each reading up to :data:`DEFINITION_REREAD_MAX_S`, reset once it is shown.
DEFINITION_REREAD_S = 2.0
DEFINITION_REREAD_MAX_S = 30.0

#: Seconds the console waits for a control's receiver and its acknowledgement.
CONTROL_WAIT_S = 3.0

DEFAULT_PORT = 8765
STATIC_FILES = {'console.js': 'application/javascript', 'console.css': 'text/css',
                'index.html': 'text/html', 'foxglove_layout.json': 'application/json'}
DEFAULT_FOXGLOVE_PORT = 8766
FOXGLOVE_ROWS = 4096  # rows per site buffered between two Foxglove ticks
#: Methods that change nothing: every other one must come from the console's own page.
SAFE_METHODS = frozenset({'GET', 'HEAD', 'OPTIONS'})
#: aiohttp's loggers whose records may carry a traceback (see :class:`OneLineLog`).
AIOHTTP_LOGGERS = ('aiohttp.server', 'aiohttp.web', 'aiohttp.websocket', 'aiohttp.internal')

#: The console's lines on its terminal (warnings and errors reach stderr through Python's
#: last-resort handler, one line each, even when nothing configured logging).
LOG = logging.getLogger('pd_console.console')


def web_directory() -> Path:
    """The page's files: installed in ``share/pd_console/console`` (or the source tree)."""
    try:
        installed = share_file('pd_console', 'console')
        if (installed / 'index.html').is_file():
            return installed
    except ResourceError:
        pass
    return Path(__file__).resolve().parents[1] / 'console'


class ConsoleSettingError(ValueError):
    """A console setting (an option or a parameter) out of its range: one line naming it."""


def default_bridge_limits(path: str = '') -> dict[str, float]:
    """The bridge limits of a site whose test definition names none.

    ``path`` (a bridge parameter file) or the shipped one, read through its schema as
    ``./pd run`` reads it; the limits the file sets (the gauges show no others). The shipped
    file unreadable gives none (the gauges show no limits).

    Raises:
        ConsoleSettingError: ``path`` names a file that cannot be read or is refused.
    """
    try:
        file = Path(path) if path else default_bridge_parameter_file()
        parameters = read_bridge_parameter_file(file).parameters()
    except SchemaError as err:
        if path:  # asked for by name: one line, not gauges quietly without limits
            msg = f'bridge_params: {err}'
            raise ConsoleSettingError(msg) from None
        return {}
    return {name: float(parameters[name]) for name in (*BRIDGE_LIMITS, 'step_duration')
            if isinstance(parameters.get(name), int | float)}


def check_settings(*, port: int, update_rate: float, max_points: int,
                   foxglove_port: int | None) -> None:
    """Refuse a setting the server could not use, naming it (before anything listens).

    Raises:
        ConsoleSettingError: a port outside 0–65535 (the Foxglove port: 1–65535), an update
            rate that is not a positive number, fewer than 2 rows per series.
    """
    if not 0 <= port <= 65535:
        msg = f'port: must be 0 (any free port) to 65535, got {port}'
        raise ConsoleSettingError(msg)
    if not (math.isfinite(update_rate) and update_rate > 0.0):
        msg = f'update_rate: must be a positive number of frames per second, got {update_rate}'
        raise ConsoleSettingError(msg)
    if max_points < 2:
        msg = f'max_points: must be at least 2 rows per series, got {max_points}'
        raise ConsoleSettingError(msg)
    if foxglove_port is not None and foxglove_port != 0 and not 1 <= foxglove_port <= 65535:
        msg = f'foxglove_port: must be 1 to 65535 (0: off), got {foxglove_port}'
        raise ConsoleSettingError(msg)


class Unshown:
    """What the console could not show: counted, the first said in one line.

    The console only shows. A message one of its callbacks cannot take (one no test's node
    sends: without a key anyone may publish) must not end the thread that takes them, where the
    page would freeze.
    """

    def __init__(self) -> None:
        self.count = 0

    def add(self, err: Exception) -> None:
        """One more (the first said)."""
        self.count += 1
        if self.count == 1:
            LOG.error('a message the console could not show (%s: %s); it goes on (counted, '
                      'not said again)', type(err).__name__, err)

    def guarded(self, callback: Callable[[Any], None]) -> Callable[[Any], None]:
        """``callback``, with what it raises counted here instead."""
        def call(argument: Any) -> None:
            try:
                callback(argument)
            except Exception as err:  # noqa: BLE001 - a display goes on (said once, counted)
                self.add(err)

        return call


def spin_on(executor: Any, stop: threading.Event, unshown: Unshown,
            ok: Callable[[], bool] = rclpy.ok) -> None:
    """Spin the console's node until ``stop`` or shutdown.

    (Its callbacks are :meth:`Unshown.guarded`; what still escapes the executor is counted on
    ``unshown`` too, and the thread spins on after a pause.)
    """
    while ok() and not stop.is_set():
        try:
            executor.spin_once(timeout_sec=0.1)
        except Exception as err:  # noqa: BLE001 - a display goes on (said once, counted)
            if not ok() or stop.is_set():
                break
            unshown.add(err)
            stop.wait(0.1)


def _listen_error(err: OSError, host: str, port: int) -> str:
    """One line for a server that cannot listen (a busy port, an address not of this host)."""
    return f'cannot listen on {host}:{port} ({err.strerror or err})'


class ConsoleNode(Node):
    """Subscribes to the test's topics and feeds a :class:`ConsoleModel`; sends controls.

    Parameters: ``host``, ``port``, ``update_rate`` (frames per second pushed to the page),
    ``max_points`` (rows per series), ``key_file`` (the test's key; default ``$PD_KEY_FILE``,
    then the rig key), ``bridge_params`` (the bridges' parameter file, for their limits).
    """

    def __init__(self, model: ConsoleModel, lock: threading.Lock,
                 overrides: dict[str, Any] | None = None, *,
                 context: Context | None = None) -> None:
        super().__init__('pd_console', namespace='/pd', context=context)
        overrides = overrides or {}

        def declare(name: str, default: Any, description: str) -> Any:
            value = overrides.get(name, default)
            return self.declare_parameter(name, value, ParameterDescriptor(
                description=description)).value

        self.host = str(declare('host', '127.0.0.1', 'address to listen on (127.0.0.1: '
                                'this computer only)'))
        self.port = int(declare('port', DEFAULT_PORT, 'TCP port (0: any free port)'))
        self.update_rate = float(declare('update_rate', 4.0, 'frames per second pushed to '
                                         'the page'))
        self.max_points = int(declare('max_points', model.max_points,
                                      'rows per series kept and pushed'))
        self.key_file = str(declare('key_file', '', "the test's key file (default: "
                                    '$PD_KEY_FILE, then the rig key)'))
        self.bridge_params = str(declare('bridge_params', '', "the bridges' parameter file "
                                         '(their limits, for the gauges)'))
        self.foxglove_port = int(declare('foxglove_port', 0, "serve the live test to the "
                                         "Foxglove app on this port (foxglove-sdk's "
                                         'WebSocket server; 0: off)'))
        check_settings(port=self.port, update_rate=self.update_rate,
                       max_points=self.max_points, foxglove_port=self.foxglove_port)
        model.max_points = self.max_points
        if self.foxglove_port:
            model.fresh_rows = FOXGLOVE_ROWS
        model.default_limits = default_bridge_limits(self.bridge_params)
        self.model = model
        self.lock = lock
        self.key: Key | None = None
        self.key_error = ''
        try:
            self.key = load_key(operator_key_path(self.key_file or None))
        except AuthError as err:
            if self.key_file:  # asked for by name: refused, not a console that cannot steer
                msg = f'key_file: {err}'
                raise ConsoleSettingError(msg) from None
            self.key_error = str(err)
        # Statuses are believed only as their nodes signed them; controls go out bound to
        # their receivers and are confirmed (pd_common.ros.ControlSender).
        self.controls = ControlSender(self, self.key, 'console')
        self._sites: set[str] = set()
        self._estop = self.create_publisher(String, GLOBAL_EMERGENCY_STOP, CONTROL_DEPTH)
        # The definition only as the integrator's signed status names it, the step messages
        # only as their two ends signed them in the receiver's session (with a key).
        self.witness = DefinitionWitness(authenticated=self.key is not None)
        self._offer_gate = StatusGate(self.key)
        self._watch_gates: dict[str, WatchGate] = {}
        self.unshown = Unshown()  # (every callback below is guarded by it)
        self._refusal_log = RefusalLog(LOG.warning, self.key, 'step message (not shown)')
        self._offer_log = RefusalLog(LOG.warning, self.key, 'session offer (not followed)')
        self.controls.watch(site_topic_name('', 'test_status'),
                            self.unshown.guarded(self._on_status))
        self._definition_sub = self.create_subscription(
            String, 'test_definition', self.unshown.guarded(self._on_definition),
            LATCHED_READER_QOS)
        self._definition_read_at = time.monotonic()
        self._definition_reread_s = DEFINITION_REREAD_S
        self.create_timer(1.0, self._reread_definition)
        self._watch_site('')
        if self.key is not None:  # (its host, port and key as given at start)
            seal_parameters(self, 'the console', 'restart it', self.controls.gate.refused)

    # -- subscriptions (the executor's thread) ---------------------------------------------
    def _watch_site(self, site: str) -> None:
        if site in self._sites:
            return
        self._sites.add(site)
        gate = self._watch_gates[site] = WatchGate(self.key)
        offer_topic = site_topic_name(site, 'session/offer')

        def on_offer(message: Any) -> None:
            offer, reason = read_offer(self._offer_gate, offer_topic, message)
            if offer is not None:
                gate.follow(offer.active_session)
            elif reason is not None:
                # (its key id only: what the line names for another key)
                self._offer_log(reason, Signature(key_id=str(message.signature.key_id)),
                                offer_topic)

        def admitted(payload: WirePayload, signature: Signature, topic: str) -> bool:
            reason = gate.admit(payload, signature)
            if reason is not None and reason not in SESSION_CHANGES:
                self._refusal_log(reason, signature, topic)
            return reason is None

        command_topic = site_topic_name(site, 'step_command')
        feedback_topic = site_topic_name(site, 'step_feedback')

        # (a malformed, forged or replayed one is the receiver's to refuse, never shown)
        def on_command(data: bytes) -> None:
            signed = signed_from_bytes(decode_command, data)
            if signed is not None and admitted(command_payload(signed.covered),
                                               signed.signature, command_topic):
                with self.lock:
                    self.model.on_command(site, signed.record)

        def on_feedback(data: bytes) -> None:
            signed = signed_from_bytes(decode_feedback, data)
            if signed is not None and admitted(feedback_payload(signed.covered),
                                               signed.signature, feedback_topic):
                with self.lock:
                    self.model.on_feedback(site, signed.record)

        self.create_subscription(SessionOffer, site_topic(site, 'session/offer'),
                                 self.unshown.guarded(on_offer), LATCHED_QOS)

        def on_bridge(status: Status) -> None:
            with self.lock:
                self.model.on_bridge_status(site, status)

        # The hot topics as CDR bytes, read without message objects (pd_common.protocol.cdr).
        self.create_subscription(StepCommand, site_topic(site, 'step_command'),
                                 self.unshown.guarded(on_command), STEP_QOS, raw=True)
        self.create_subscription(StepFeedback, site_topic(site, 'step_feedback'),
                                 self.unshown.guarded(on_feedback), STEP_QOS, raw=True)
        self.controls.watch(site_topic_name(site, 'bridge/status'),
                            self.unshown.guarded(on_bridge))

    def _on_status(self, status: Status) -> None:
        with self.lock:
            self.model.on_status(status)
        self._show_definition(self.witness.named(status.definition_digest))

    def _reread_definition(self) -> None:
        """Read the latched definition again if the one a signed status names is missing.

        (Others pushed it out, or it is late.) A new subscription is handed every writer's
        latched sample anew; it is made before the old one goes, only while a writer is
        matched, and less often each time (see :data:`DEFINITION_REREAD_S`).
        """
        if not self.witness.missing:
            self._definition_reread_s = DEFINITION_REREAD_S
            return
        now = time.monotonic()
        if (now - self._definition_read_at < self._definition_reread_s
                or self._definition_sub.get_publisher_count() == 0):
            return
        old = self._definition_sub
        self._definition_sub = self.create_subscription(
            String, 'test_definition', self.unshown.guarded(self._on_definition),
            LATCHED_READER_QOS)
        self.destroy_subscription(old)
        self._definition_read_at = now
        self._definition_reread_s = min(2 * self._definition_reread_s, DEFINITION_REREAD_MAX_S)

    def _on_definition(self, message: Any) -> None:
        self._show_definition(self.witness.heard(str(message.data)))

    def _show_definition(self, text: str | None) -> None:
        if text is None:
            return
        with self.lock:
            self.model.on_definition(text)
            sites = list(self.model.sites)
        for site in sites:
            self._watch_site(site)

    def refused(self) -> dict[str, dict[str, int]]:
        """What the console would not show, by source and reason (offers, step messages)."""
        counts = {f'step[{site or "default"}]': dict(gate.refused)
                  for site, gate in self._watch_gates.items()}
        counts['session_offer'] = dict(self._offer_gate.refused)
        return {source: count for source, count in counts.items() if count}

    # -- controls (the web server's thread) ------------------------------------------------
    def sites(self) -> tuple[str, ...]:
        """The sites known so far."""
        with self.lock:
            return tuple(self.model.sites)

    def send_control(self, request: ControlRequest) -> tuple[bool, str]:
        """Send a signed control as ``./pd control`` does, bound to its receiver.

        And wait for its acknowledgement (up to ``CONTROL_WAIT_S``); (taken, what the receiver
        said).
        """
        if self.key is None:
            return False, f'no key: {self.key_error}'
        if request.bridge_site is not None:
            topic = site_topic_name(request.bridge_site, 'bridge/control')
            status_topic = site_topic_name(request.bridge_site, 'bridge/status')
        else:
            topic = site_topic_name('', 'test_control')
            status_topic = site_topic_name('', 'test_status')
        deadline = time.monotonic() + CONTROL_WAIT_S
        sent = None
        while sent is None:
            sent = self.controls.send(request.command, topic, status_topic, request.reason)
            if sent is None:
                if time.monotonic() > deadline:
                    return False, f'no receiver on {topic} (no status from it, or not listening)'
                time.sleep(0.05)
        self.get_logger().info(f'control {request.command} sent to {sent.control.target}')
        while time.monotonic() < deadline:
            ack = self.controls.acknowledgement(sent)
            if ack is not None:
                return ack.ok, f'{sent.control.target}: {ack.outcome}'
            if time.monotonic() - sent.sent_at >= RESEND_S:
                sent = self.controls.resend(sent)
            time.sleep(0.05)
        return False, f'{request.command}: not confirmed by {sent.control.target}'

    def emergency_stop(self, reason: str) -> str:
        """Publish the lab-wide emergency stop (no key: anyone may stop a machine)."""
        message = String(data=reason or 'console emergency stop')
        repeat_emergency_stop(lambda: self._estop.publish(message), background=True)
        self.get_logger().warning(f'EMERGENCY STOP sent on {GLOBAL_EMERGENCY_STOP}')
        return GLOBAL_EMERGENCY_STOP


class ConsoleServer:
    """The web side: the page, its frames over a WebSocket, login, controls, e-stop.

    Args:
        model: what the page shows (shared with the node under ``lock``).
        lock: guards ``model``.
        access: the login token and sessions.
        node: the console node (``None``: a finished run, no controls).
        update_rate: frames per second pushed.
        run_dir: a finished run's folder (its figures are served).
        host: the address it listens on: a request's ``Host`` header must name it.
        port: the port it listens on (0: the port each connection reached; :func:`serve`
            sets the bound one).
    """

    def __init__(self, model: ConsoleModel, lock: threading.Lock, access: ConsoleAccess,
                 node: ConsoleNode | None, update_rate: float, run_dir: Path | None = None,
                 *, host: str = '127.0.0.1', port: int = 0) -> None:
        self.host = host
        self.port = port
        wildcard = host.strip() in WILDCARD_HOSTS
        self.served = served_address(host, machine_names() if wildcard else ())
        self.model = model
        self.lock = lock
        self.access = access
        self.node = node
        self.period = 1.0 / max(0.2, update_rate)
        self.run_dir = run_dir
        self.web = web_directory()
        self.sockets: set[web.WebSocketResponse] = set()
        self.frames_sent = 0
        self.refused_controls = 0
        self.refused_requests = 0
        self.dropped_requests = 0
        self._frame_text = ''
        self._frame_version = -1
        self._frame_at = 0.0

    def app(self) -> web.Application:
        """The aiohttp application."""
        app = web.Application(client_max_size=64 * 1024, middlewares=[self.guard])
        app.on_startup.append(_quiet_aiohttp)
        app.on_cleanup.append(_loud_aiohttp)
        app.router.add_get('/', self.index)
        app.router.add_get('/static/{name}', self.static)
        app.router.add_get('/figures/{name}', self.figure)
        app.router.add_get('/api/frame', self.frame)
        app.router.add_get('/api/session', self.session)
        app.router.add_get('/ws', self.websocket)
        app.router.add_post('/api/login', self.login)
        app.router.add_post('/api/logout', self.logout)
        app.router.add_post('/api/control', self.control)
        app.router.add_post('/api/estop', self.estop)
        return app

    # -- every request ---------------------------------------------------------------------
    @web.middleware
    async def guard(self, request: web.Request, handler: Handler) -> web.StreamResponse:
        """Every request: its ``Host`` must name the served address (else 421: DNS rebinding).

        And one that changes anything (not GET) must be a JSON request of this page (else 403:
        another site's page, a form post); nothing is done for a refused one. The response is
        written here, so that a client that drops its request costs one line on the terminal, and a
        failing handler one line with its error, never a traceback.
        """
        where = f'{request.method} {request.path}'
        response: web.StreamResponse | None = None
        try:
            if not self._host_allowed(request):
                self.refused_requests += 1
                response = web.json_response(
                    {'error': "misdirected request: the Host header does not name this "
                              "console's address"}, status=421)
            elif request.method not in SAFE_METHODS and not self._same_origin(request):
                self.refused_requests += 1
                response = web.json_response(
                    {'error': "not from this page: a request that changes anything must be "
                              "a JSON POST from the console's own page"}, status=403)
            else:
                response = await handler(request)
            if not response.prepared:
                await response.prepare(request)
                await response.write_eof()
            return response
        except web.HTTPException:
            raise
        except asyncio.CancelledError:
            # aiohttp cancels a handler whose client went away only with
            # ``handler_cancellation`` (its test server); a shutdown cancels one whose
            # connection is still open
            if _gone(request):
                self._dropped_request(where)
            raise
        except ConnectionError as err:
            if not (_gone(request) or isinstance(err, _CLIENT_ERRORS)):
                return self._failed(request, where, err, response)
            self._dropped_request(where)
            return _abandon(request)
        except Exception as err:  # noqa: BLE001 - one line on the terminal, not a traceback
            return self._failed(request, where, err, response)

    def _dropped_request(self, where: str) -> None:
        self.dropped_requests += 1
        LOG.warning('console: a client dropped its request (%s)', where)

    def _failed(self, request: web.Request, where: str, err: Exception,
                response: web.StreamResponse | None) -> web.StreamResponse:
        """A handler failed: one line with the error; a 500 if nothing was sent yet."""
        said = _one_line(err)
        LOG.error('console: %s failed: %s', where, said)
        if (response is not None and response.prepared) or request.writer.output_size:
            return _abandon(request)
        return web.json_response({'error': said}, status=500)

    def _host_allowed(self, request: web.Request) -> bool:
        """Whether the request's ``Host`` names the served address and port."""
        sockname = request.get_extra_info('sockname')
        local = sockname if isinstance(sockname, tuple) and len(sockname) >= 2 else None
        port = self.port or (int(local[1]) if local is not None else 0)
        return self.served.allows(request.headers.get('Host'), port,
                                  str(local[0]) if local is not None else '')

    # -- pages -----------------------------------------------------------------------------
    async def index(self, request: web.Request) -> web.StreamResponse:
        """The console page."""
        return await _file(self.web / 'index.html', STATIC_FILES['index.html'], _NO_CACHE)

    async def static(self, request: web.Request) -> web.StreamResponse:
        """One of the page's static files."""
        name = request.match_info['name']
        if name not in STATIC_FILES:
            raise web.HTTPNotFound
        return await _file(self.web / name, STATIC_FILES[name], _NO_CACHE)

    async def figure(self, request: web.Request) -> web.StreamResponse:
        """One of the run's figures."""
        name = request.match_info['name']
        if self.run_dir is None or name not in self.model.figures:
            raise web.HTTPNotFound
        return await _file(self.run_dir / name, 'image/png')

    def frame_text(self) -> str:
        """The current frame as JSON.

        Made again when the model changed, or each second for the rate and ETA.
        """
        now = time.monotonic()
        with self.lock:
            if self.model.version != self._frame_version or now - self._frame_at > 1.0:
                self._frame_version = self.model.version
                self._frame_at = now
                self._frame_text = json.dumps(self.model.frame(), allow_nan=False,
                                              separators=(',', ':'))
        return self._frame_text

    async def frame(self, request: web.Request) -> web.Response:
        """The current frame as JSON."""
        return web.Response(text=self.frame_text(), content_type='application/json')

    async def session(self, request: web.Request) -> web.Response:
        """Whether this browser is logged in and whether controls are possible."""
        return web.json_response({'authenticated': self._authenticated(request),
                                  'controls': self.node is not None,
                                  'token_spent': self.access.token_spent})

    async def websocket(self, request: web.Request) -> web.WebSocketResponse:
        """Stream the frames to the page over a WebSocket."""
        if not self._own_origin(request):
            raise web.HTTPForbidden(text='another site may not read this console')
        socket = web.WebSocketResponse(heartbeat=20.0)
        await socket.prepare(request)
        self.sockets.add(socket)
        try:
            await socket.send_str(self.frame_text())
            async for message in socket:
                if message.type in (WSMsgType.ERROR, WSMsgType.CLOSE):
                    break
        finally:
            self.sockets.discard(socket)
        return socket

    async def push(self) -> None:
        """Push the frame to every page, ``update_rate`` times a second (only a new one)."""
        last = ''
        while True:
            await asyncio.sleep(self.period)
            if not self.sockets:
                continue
            text = self.frame_text()
            if text == last:
                continue
            last = text
            for socket in list(self.sockets):
                try:
                    await socket.send_str(text)
                    self.frames_sent += 1
                except (ConnectionError, RuntimeError):
                    self.sockets.discard(socket)

    # -- access and controls ---------------------------------------------------------------
    def _authenticated(self, request: web.Request) -> bool:
        return self.access.allowed(request.cookies.get(SESSION_COOKIE))

    @staticmethod
    def _own_origin(request: web.Request) -> bool:
        """No ``Origin`` (not a browser's cross-site request), or this console's own."""
        origin = request.headers.get('Origin')
        return origin is None or origin.lower() == f'{request.scheme}://{request.host}'.lower()

    @classmethod
    def _same_origin(cls, request: web.Request) -> bool:
        """A JSON request from this page.

        A cross-site form cannot send JSON without a CORS preflight (never granted here), and a
        foreign ``Origin`` is refused. Checked by :meth:`guard` on every request that changes
        anything, the e-stop included.
        """
        return request.content_type == 'application/json' and cls._own_origin(request)

    async def login(self, request: web.Request) -> web.Response:
        """Log in with the token; set the session cookie."""
        try:
            body = await request.json()
        except ValueError:
            body = {}
        token = str(body.get('token', '')) if isinstance(body, dict) else ''
        session = self.access.login(token)
        if session is None:
            return web.json_response({'error': 'wrong or spent token'}, status=403)
        response = web.json_response({'authenticated': True})
        response.set_cookie(SESSION_COOKIE, session, httponly=True, samesite='Strict',
                            path='/')
        return response

    async def logout(self, request: web.Request) -> web.Response:
        """Log out; clear the session cookie."""
        self.access.logout(request.cookies.get(SESSION_COOKIE))
        response = web.json_response({'authenticated': False})
        response.del_cookie(SESSION_COOKIE, path='/')
        return response

    async def control(self, request: web.Request) -> web.Response:
        """Send a control of a logged-in person."""
        if not self._authenticated(request):
            self.refused_controls += 1
            return web.json_response(
                {'error': 'not logged in: controls need the token printed on the '
                          "console's terminal"}, status=403)
        if self.node is None:
            return web.json_response({'error': 'a finished run: nothing to steer'},
                                     status=409)
        try:
            body = await request.json()
            control = parse_control(body, self.node.sites())
        except ValueError as err:
            return web.json_response({'error': str(err)}, status=400)
        node = self.node
        sent, said = await asyncio.get_running_loop().run_in_executor(
            None, node.send_control, control)
        if not sent:
            return web.json_response({'error': said}, status=503)
        return web.json_response({'sent': control.command, 'topic': said})

    async def estop(self, request: web.Request) -> web.Response:
        """Send an emergency stop (no login needed: anyone may stop the test)."""
        if self.node is None:
            return web.json_response({'error': 'a finished run: nothing to stop'},
                                     status=409)
        try:
            body = await request.json()
        except ValueError:
            body = {}
        reason = str(body.get('reason', '')) if isinstance(body, dict) else ''
        topic = self.node.emergency_stop(reason[:200] or 'console emergency stop')
        return web.json_response({'sent': 'estop', 'topic': topic})


_NO_CACHE = {'Cache-Control': 'no-store'}


async def _file(path: Path, content_type: str, headers: dict[str, str] | None = None
                ) -> web.Response:
    """A file's bytes (read in a worker thread); 404 if it cannot be read.

    Not aiohttp's ``FileResponse``: :meth:`ConsoleServer.guard` writes every response itself (to
    see a client drop it), and a ``FileResponse`` cannot be prepared twice.
    """
    try:
        body = await asyncio.get_running_loop().run_in_executor(None, path.read_bytes)
    except OSError as err:
        raise web.HTTPNotFound from err
    charset = 'utf-8' if not content_type.startswith('image/') else None
    return web.Response(body=body, content_type=content_type, charset=charset,
                        headers=headers)


#: What a client that goes away raises (aiohttp's ``ClientConnectionResetError`` is a
#: ``ConnectionResetError``).
_CLIENT_ERRORS = (ConnectionResetError, BrokenPipeError, ConnectionAbortedError)


def _gone(request: web.Request) -> bool:
    """Whether the request's connection is closed or closing."""
    transport = request.transport
    return transport is None or transport.is_closing()


def _abandon(request: web.Request) -> web.StreamResponse:
    """Close a connection whose response cannot be finished.

    aiohttp's own attempt to write the returned response then fails quietly (it logs a closed
    connection at debug level).
    """
    transport = request.transport
    if transport is not None:
        transport.close()
    return web.Response(status=500)


class OneLineLog(logging.Filter):
    """aiohttp's error records in one line, without their traceback.

    A dropped connection (what the :meth:`ConsoleServer.guard` does not see, e.g. during aiohttp's
    own writing), a malformed request. The console's terminal shows the login token: no tracebacks.
    """

    def filter(self, record: logging.LogRecord) -> bool:
        """Log the record on one line, without its traceback."""
        if record.exc_info and record.exc_info[1] is not None:
            err = record.exc_info[1]
            said = ' '.join(record.getMessage().split())
            if isinstance(err, ConnectionError | asyncio.CancelledError):
                record.msg = f'console: a client dropped its connection ({said})'
            else:
                record.msg = f'console: {said}: {_one_line(err)}'
            record.args = ()
            record.exc_info = None
            record.exc_text = None
            record.stack_info = None
        return True


_ONE_LINE = OneLineLog()


def _one_line(err: BaseException) -> str:
    """``Type: message`` of an error, on one line."""
    return ' '.join(f'{type(err).__name__}: {err}'.split())


async def _quiet_aiohttp(app: web.Application) -> None:
    for name in AIOHTTP_LOGGERS:
        logging.getLogger(name).addFilter(_ONE_LINE)


async def _loud_aiohttp(app: web.Application) -> None:
    for name in AIOHTTP_LOGGERS:
        logging.getLogger(name).removeFilter(_ONE_LINE)


def machine_names() -> tuple[str, ...]:
    """This machine's own names, found without asking DNS.

    Its host name and its mDNS name (``<host>.local``). Its addresses need no list: a console
    listening on every address accepts the one each connection reached.
    """
    name = gethostname().strip().lower()
    if not name:
        return ()
    short = name.split('.')[0]
    return tuple(dict.fromkeys((name, short, f'{short}.local')))


class FoxgloveFeed:
    """The live test on foxglove-sdk's WebSocket server.

    Every answered step of every DOF, the status and the gauges, logged from the web server's timer
    (never from a ROS callback).
    """

    def __init__(self, model: ConsoleModel, lock: threading.Lock, host: str, port: int
                 ) -> None:
        self.model = model
        self.lock = lock
        self.server = foxglove.start_server(name='pd console', host=host, port=port)
        self.port = int(self.server.port)
        self._channels: dict[str, Any] = {}

    def _log(self, topic: str, message: dict[str, Any], log_time: int) -> None:
        channel = self._channels.get(topic)
        if channel is None:
            channel = foxglove.Channel(topic)
            self._channels[topic] = channel
        channel.log(message, log_time=log_time)

    def tick(self) -> None:
        """Log what arrived since the last tick."""
        with self.lock:
            drained = self.model.drain()
            test = self.model.test_json()
            gauges = {name: gauges_message(view.to_json_gauges())
                      for name, view in self.model.sites.items()}
        now = time.time_ns()
        for site, (dofs, rows) in drained.items():
            for row in rows:
                for dof, values in zip(dofs, row, strict=True):
                    self._log(response_topic(site, dof), response_message(values), now)
        self._log(STATUS_TOPIC, test, now)
        for site, message in gauges.items():
            self._log(gauges_topic(site), message, now)

    async def run(self, period: float) -> None:
        """Tick every ``period`` s."""
        while True:
            await asyncio.sleep(period)
            self.tick()

    def stop(self) -> None:
        """Stop the server."""
        self.server.stop()


def parse_args(argv: list[str]) -> argparse.Namespace:
    """Command-line arguments (ROS arguments removed)."""
    parser = argparse.ArgumentParser(prog='console', description=__doc__.splitlines()[0])
    parser.add_argument('run', nargs='?', default=None,
                        help='a finished run folder, its bag or its journal (default: live)')
    parser.add_argument('--host', default=None, help='address to listen on (default '
                        '127.0.0.1; another one exposes the page to the network)')
    parser.add_argument('--port', type=int, default=None, help=f'TCP port (default '
                        f'{DEFAULT_PORT}; 0: any free port)')
    parser.add_argument('--key', default=None,
                        help="the test's key file (default: $PD_KEY_FILE, then the rig key)")
    parser.add_argument('--bridge-params', default=None,
                        help="the bridges' parameter file (their limits, for the gauges)")
    parser.add_argument('--update-rate', type=float, default=None,
                        help='frames per second pushed to the page (default 4)')
    parser.add_argument('--max-points', type=int, default=None,
                        help='rows per series (default 600)')
    parser.add_argument('--foxglove', type=int, nargs='?', const=DEFAULT_FOXGLOVE_PORT,
                        default=None, metavar='PORT',
                        help='also serve the live test to the Foxglove app (foxglove-sdk '
                        f'WebSocket server, default port {DEFAULT_FOXGLOVE_PORT})')
    return parser.parse_args(argv)


def _is_loopback(host: str) -> bool:
    if host == 'localhost':
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


async def serve(server: ConsoleServer, stop: StopFlag) -> None:
    """Serve on ``server.host`` and ``server.port`` until ``stop`` is set.

    Prints the address and the login token.
    """
    host, port = server.host, server.port
    runner = web.AppRunner(server.app(), access_log=None)
    await runner.setup()
    site = web.TCPSite(runner, host, port)
    await site.start()
    addresses = runner.addresses
    bound = int(addresses[0][1]) if addresses else port
    # the Host header must name this port (port 0 on every address may bind several)
    server.port = bound if len({int(address[1]) for address in addresses}) <= 1 else 0
    shown = host if ':' not in host else f'[{host}]'
    print(f'console: serving http://{shown}:{bound}/', flush=True)
    if not _is_loopback(host):
        print(f'console: WARNING: listening on {host}: anyone who reaches this address can '
              'watch the test (controls still need the token)', flush=True)
        names = ', '.join(sorted(server.served.names))
        also = " and to the machine's address a browser connects to" if (
            server.served.wildcard) else ''
        print(f'console: the page answers to {names}{also}; any other name in the address '
              'bar is refused (start with --host NAME to use one)', flush=True)
    if server.node is not None:
        if server.node.key is None:
            print(f'console: WARNING: no key ({server.node.key_error}): the page can watch, '
                  'controls are off (the emergency stop works)', flush=True)
        print(f'console: login token (one use): {server.access.token}', flush=True)
        print(f'console: or open http://{shown}:{bound}/#token={server.access.token}',
              flush=True)
    tasks = [asyncio.create_task(server.push())]
    feed = None
    if server.node is not None and server.node.foxglove_port:
        feed = FoxgloveFeed(server.model, server.lock, host, server.node.foxglove_port)
        tasks.append(asyncio.create_task(feed.run(server.period)))
        layout = server.web / 'foxglove_layout.json'
        print(f'console: Foxglove: ws://{shown}:{feed.port} (open it in the Foxglove app; '
              f'a layout for the default test: {layout})', flush=True)
    try:
        while not stop.is_set():
            await asyncio.sleep(0.1)
    finally:
        for task in tasks:
            task.cancel()
        if feed is not None:
            feed.stop()
        for socket in list(server.sockets):
            await socket.close()
        await runner.cleanup()


def main(args: list[str] | None = None) -> int:
    """Entry point; 0 on a clean stop, 2 on bad input."""
    argv = list(sys.argv if args is None else ['console', *args])
    options = parse_args(remove_ros_args(argv)[1:])
    overrides: dict[str, Any] = {}
    for name, value in (('host', options.host), ('port', options.port),
                        ('key_file', options.key), ('bridge_params', options.bridge_params),
                        ('update_rate', options.update_rate),
                        ('max_points', options.max_points),
                        ('foxglove_port', options.foxglove)):
        if value is not None:
            overrides[name] = value
    lock = threading.Lock()
    model = ConsoleModel(time.monotonic)
    access = ConsoleAccess()
    if options.run is not None:
        host = options.host or '127.0.0.1'
        port = DEFAULT_PORT if options.port is None else options.port
        update_rate = 4.0 if options.update_rate is None else options.update_rate
        try:
            check_settings(port=port, update_rate=update_rate,
                           max_points=model.max_points if options.max_points is None
                           else options.max_points, foxglove_port=options.foxglove)
            if options.max_points is not None:
                model.max_points = options.max_points
            model.default_limits = default_bridge_limits(options.bridge_params or '')
            run_dir = load_run_folder(options.run, model)
        except (ConsoleSettingError, BagError, OSError) as err:
            print(f'console: error: {err}', file=sys.stderr)
            return 2
        stop = StopFlag()
        server = ConsoleServer(model, lock, access, None, update_rate, run_dir,
                               host=host, port=port)
        try:
            asyncio.run(serve(server, stop))
        except KeyboardInterrupt:
            pass
        except OSError as err:
            print(f'console: error: {_listen_error(err, host, port)}', file=sys.stderr)
            return 2
        return 0
    stop = init_with_stop_flag(argv)
    try:
        node = ConsoleNode(model, lock, overrides)
        executor = events_executor(node)

        thread = threading.Thread(target=spin_on, args=(executor, stop, node.unshown),
                                  name='console-ros', daemon=True)
        thread.start()
        server = ConsoleServer(model, lock, access, node, node.update_rate, host=node.host,
                               port=node.port)
        try:
            asyncio.run(serve(server, stop))
        except OSError as err:
            print(f'console: error: {_listen_error(err, node.host, node.port)}',
                  file=sys.stderr)
            return 2
        finally:
            stop.set()
            thread.join(timeout=2.0)
            executor.shutdown()
            node.destroy_node()
        return 0
    except ConsoleSettingError as err:
        print(f'console: error: {err}', file=sys.stderr)
        return 2
    except OSError as err:
        print(f'console: error: {err}', file=sys.stderr)
        return 2
    finally:
        rclpy.try_shutdown()


if __name__ == '__main__':
    sys.exit(main())
