"""The console's web server without ROS: the page, frames, login, refused and sent controls,
the Host and origin checks, and what a dropped client leaves on the terminal."""

from __future__ import annotations

import asyncio
import json
import logging
import socket
import struct
import threading
import time
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import pytest
from aiohttp import ClientSession, WSServerHandshakeError
from aiohttp.test_utils import TestClient, TestServer

from pd_common.protocol import Command, Feedback
from pd_console.console import (
    ConsoleServer,
    ConsoleSettingError,
    FoxgloveFeed,
    Unshown,
    default_bridge_limits,
    serve,
    spin_on,
    web_directory,
)
from pd_console.core import (
    ConsoleAccess,
    ConsoleModel,
    ControlRequest,
    foxglove_layout,
)
from pd_console.core.access import served_address

TOKEN = 'the-token'


class FakeNode:
    """What the server needs of the console node: sites, controls, the e-stop."""

    def __init__(self) -> None:
        self.sent: list[ControlRequest] = []
        self.stops: list[str] = []

    def sites(self) -> tuple[str, ...]:
        return ('',)

    def send_control(self, request: ControlRequest) -> tuple[bool, str]:
        self.sent.append(request)
        return True, '/pd/test_control'

    def emergency_stop(self, reason: str) -> str:
        self.stops.append(reason)
        return '/pd/emergency_stop'


def served(node: FakeNode | None, check: Callable[[TestClient[Any, Any], ConsoleServer],
                                                  Awaitable[None]]) -> None:
    model = ConsoleModel(time.monotonic)
    model.on_command('', Command(test_id='t', step=0, test_time=0.0, dof_names=('top',),
                                 target_displacement=(0.0,)))
    model.on_feedback('', Feedback(test_id='t', step=0, measured_displacement=(0.0,),
                                   restoring_force=(1.0,)))
    server = ConsoleServer(model, threading.Lock(), ConsoleAccess(TOKEN), node,  # type: ignore[arg-type]
                           update_rate=20.0)

    async def body() -> None:
        async with TestClient(TestServer(server.app())) as client:
            await check(client, server)

    asyncio.run(body())


def test_the_page_and_its_scripts_are_served_from_the_package() -> None:
    assert (web_directory() / 'console.js').is_file()

    async def check(client: TestClient[Any, Any], server: ConsoleServer) -> None:
        page = await client.get('/')
        assert page.status == 200
        text = await page.text()
        assert '/static/console.js' in text and 'http' not in text.replace('http-equiv', '')
        script = await (await client.get('/static/console.js')).text()
        assert 'drawPlot' in script and '://' not in script.replace('${scheme}://', '')
        assert (await client.get('/static/secret.key')).status == 404
        assert (await client.get('/figures/x.png')).status == 404
        frame = await (await client.get('/api/frame')).json()
        assert frame['sites'][0]['dofs'][0]['force'] == [1.0]
        socket = await client.ws_connect('/ws')
        pushed = json.loads((await socket.receive(timeout=5.0)).data)
        assert pushed['type'] == 'frame'
        await socket.close()
        foreign = await client.get('/ws', headers={'Origin': 'http://evil.example',
                                                   'Upgrade': 'websocket',
                                                   'Connection': 'Upgrade',
                                                   'Sec-WebSocket-Version': '13',
                                                   'Sec-WebSocket-Key': 'dGhlIHNhbXBsZQ=='})
        assert foreign.status == 403

    served(FakeNode(), check)


def test_an_unauthenticated_page_is_refused_and_nothing_is_sent() -> None:
    node = FakeNode()

    async def check(client: TestClient[Any, Any], server: ConsoleServer) -> None:
        response = await client.post('/api/control', json={'command': 'pause'})
        assert response.status == 403
        assert (await client.post('/api/login', json={'token': 'guess'})).status == 403
        assert (await client.post('/api/control', json={'command': 'abort'})).status == 403
        # the e-stop is open to everyone
        stop = await client.post('/api/estop', json={'reason': 'hands off'})
        assert stop.status == 200 and node.stops == ['hands off']

    served(node, check)
    assert node.sent == []


def test_the_token_logs_in_once_and_the_session_steers() -> None:
    node = FakeNode()

    async def check(client: TestClient[Any, Any], server: ConsoleServer) -> None:
        # a cross-site form post, or another origin, is refused even with the right token
        form = await client.post('/api/login', data={'token': TOKEN})
        assert form.status == 403
        foreign = await client.post('/api/login', json={'token': TOKEN},
                                    headers={'Origin': 'http://evil.example'})
        assert foreign.status == 403
        login = await client.post('/api/login', json={'token': TOKEN})
        assert login.status == 200
        assert (await (await client.get('/api/session')).json())['authenticated']
        sent = await client.post('/api/control', json={'command': 'pause'})
        assert sent.status == 200 and (await sent.json())['topic'] == '/pd/test_control'
        bad = await client.post('/api/control', json={'command': 'restarted'})
        assert bad.status == 400
        reset = await client.post('/api/control', json={'command': 'reset', 'site': ''})
        assert reset.status == 200
        # the token is spent: a second browser cannot log in with it
        client.session.cookie_jar.clear()
        assert (await client.post('/api/login', json={'token': TOKEN})).status == 403
        assert (await client.post('/api/control', json={'command': 'abort'})).status == 403

    served(node, check)
    assert [(c.command, c.bridge_site) for c in node.sent] == [('pause', None), ('reset', '')]


def test_a_finished_run_has_no_controls() -> None:
    async def check(client: TestClient[Any, Any], server: ConsoleServer) -> None:
        assert (await client.post('/api/login', json={'token': TOKEN})).status == 200
        assert (await client.post('/api/control', json={'command': 'pause'})).status == 409
        assert (await client.post('/api/estop', json={})).status == 409

    served(None, check)


def test_bridge_limits_come_from_a_parameter_file(tmp_path: Path) -> None:
    path = tmp_path / 'bridge.yaml'
    path.write_text('/**:\n  ros__parameters:\n    max_force: 5000.0\n    max_increment: 0.01\n'
                    '    driver: sim_servo\n', encoding='utf-8')
    assert default_bridge_limits(str(path)) == {'max_force': 5000.0, 'max_increment': 0.01}
    # a file named that is missing, or that the bridge would refuse (read through the same
    # schema), is one line naming the setting: not gauges quietly without limits
    with pytest.raises(ConsoleSettingError, match=r'^bridge_params: .*missing\.yaml: cannot '
                                                   r'read the bridge parameter file'):
        default_bridge_limits(str(tmp_path / 'missing.yaml'))
    path.write_text('/**:\n  ros__parameters:\n    max_force: -5000.0\n', encoding='utf-8')
    with pytest.raises(ConsoleSettingError, match=r'^bridge_params: .*max_force'):
        default_bridge_limits(str(path))
    assert default_bridge_limits()['max_displacement'] == pytest.approx(0.25)


def test_the_foxglove_feed_advertises_the_test_and_the_layout_is_shipped() -> None:
    shipped = (web_directory() / 'foxglove_layout.json').read_text(encoding='utf-8')
    assert shipped.strip() == foxglove_layout({'': ['top']})
    layout = json.loads(shipped)
    assert '"xAxisVal":"custom"' in shipped and layout['content']['type'] == 'split'

    model = ConsoleModel(time.monotonic, fresh_rows=100)
    for step in range(5):
        model.on_command('', Command(test_id='t', step=step, test_time=0.01 * step,
                                     dof_names=('top',), target_displacement=(0.001 * step,)))
        model.on_feedback('', Feedback(test_id='t', step=step,
                                       measured_displacement=(0.001 * step,),
                                       restoring_force=(10.0 * step,)))
    feed = FoxgloveFeed(model, threading.Lock(), '127.0.0.1', 0)
    try:
        feed.tick()
        assert model.drain() == {}  # the feed took every row

        async def advertised() -> set[str]:
            topics: set[str] = set()
            async with ClientSession() as session, session.ws_connect(
                    f'ws://127.0.0.1:{feed.port}/',
                    protocols=('foxglove.sdk.v1', 'foxglove.websocket.v1')) as socket:
                deadline = time.monotonic() + 5.0
                while '/pd_console/default/top' not in topics and time.monotonic() < deadline:
                    message = await socket.receive(timeout=5.0)
                    if isinstance(message.data, str):
                        data = json.loads(message.data)
                        if data.get('op') == 'advertise':
                            topics |= {channel['topic'] for channel in data['channels']}
            return topics

        topics = asyncio.run(advertised())
    finally:
        feed.stop()
    assert {'/pd_console/default/top', '/pd_console/status',
            '/pd_console/default/gauges'} <= topics


# -- another site's page, the Host header ----------------------------------------------------
def test_another_sites_page_cannot_press_the_emergency_stop() -> None:
    node = FakeNode()

    async def check(client: TestClient[Any, Any], server: ConsoleServer) -> None:
        own = f'http://127.0.0.1:{client.port}'
        # what any web page can send without a CORS preflight: an HTML form's post...
        form = await client.post('/api/estop', data={'reason': 'drive-by'})
        assert form.status == 403
        plain = await client.post('/api/estop', data='{"reason": "drive-by"}',
                                  headers={'Content-Type': 'text/plain'})
        assert plain.status == 403
        # ...and JSON from another origin (or an opaque one) is refused as well
        for origin in ('http://evil.example', 'null', 'http://127.0.0.1:1'):
            foreign = await client.post('/api/estop', json={'reason': 'drive-by'},
                                        headers={'Origin': origin})
            assert foreign.status == 403, origin
        assert node.stops == []
        # a cross-site logout is refused like every request that changes anything
        assert (await client.post('/api/logout', data={})).status == 403
        # the page's own button: JSON from its own origin, no login needed
        mine = await client.post('/api/estop', json={'reason': 'hands off'},
                                 headers={'Origin': own})
        assert mine.status == 200 and (await mine.json())['topic'] == '/pd/emergency_stop'
        assert server.refused_requests == 6

    served(node, check)
    assert node.stops == ['hands off'] and node.sent == []
    # the page's button sends what the server accepts: a JSON fetch
    script = (web_directory() / 'console.js').read_text(encoding='utf-8')
    assert "post('/api/estop'" in script
    assert "fetch(path" in script and "'Content-Type': 'application/json'" in script


def test_a_foreign_host_header_is_refused_over_http_and_the_websocket() -> None:
    node = FakeNode()

    async def check(client: TestClient[Any, Any], server: ConsoleServer) -> None:
        port = client.port
        # a DNS-rebinding page: this address and port, its own name (and so its own origin)
        evil = {'Host': f'evil.example:{port}'}
        for path in ('/', '/api/frame', '/api/session', '/static/console.js'):
            refused = await client.get(path, headers=evil)
            assert refused.status == 421, path
            assert 'Host' in (await refused.json())['error']
        stop = await client.post('/api/estop', json={'reason': 'rebound'},
                                 headers={**evil, 'Origin': f'http://evil.example:{port}'})
        assert stop.status == 421
        with pytest.raises(WSServerHandshakeError) as handshake:
            await client.ws_connect('/ws', headers=evil)
        assert handshake.value.status == 421
        for host in (f'127.0.0.1:{port + 1}', '127.0.0.1', f'[::1]:{port}',
                     f'localhost.:{port}', f'127.0.0.1:{port}:1'):
            assert (await client.get('/api/frame', headers={'Host': host})).status == 421, host
        # the names of the served address work, over HTTP and the WebSocket
        for host in (f'127.0.0.1:{port}', f'localhost:{port}'):
            assert (await client.get('/api/frame', headers={'Host': host})).status == 200
            socket = await client.ws_connect('/ws', headers={'Host': host,
                                                             'Origin': f'http://{host}'})
            assert json.loads((await socket.receive(timeout=5.0)).data)['type'] == 'frame'
            await socket.close()
        mine = await client.post('/api/estop', json={'reason': 'by name'},
                                 headers={'Host': f'localhost:{port}',
                                          'Origin': f'http://localhost:{port}'})
        assert mine.status == 200

    served(node, check)
    assert node.stops == ['by name']


def test_the_served_address_names_its_host_and_port() -> None:
    loopback = served_address('127.0.0.1')
    assert loopback.allows('127.0.0.1:8765', 8765) and loopback.allows('localhost:8765', 8765)
    assert loopback.allows('LocalHost:8765', 8765)
    for refused in ('evil.example:8765', '127.0.0.1:8766', '127.0.0.1', '[::1]:8765', '',
                    None, '127.0.0.1:x', '127.0.0.1:8765:1', ':8765', '127.0.0.1:99999'):
        assert not loopback.allows(refused, 8765), refused
    assert served_address('127.0.0.1').allows('127.0.0.1', 80)  # no port: HTTP's 80
    ipv6 = served_address('::1')
    assert ipv6.allows('[::1]:8765', 8765) and ipv6.allows('localhost:8765', 8765)
    assert ipv6.allows('[0:0::1]:8765', 8765)
    assert not ipv6.allows('::1:8765', 8765) and not ipv6.allows('[::1:8765', 8765)
    assert not ipv6.allows('127.0.0.1:8765', 8765)
    named = served_address('rig.lab')
    assert named.allows('rig.lab:8765', 8765) and not named.allows('localhost:8765', 8765)
    assert not named.allows('10.0.0.5:8765', 8765, local_address='10.0.0.5')
    # every address: the machine's names, loopback, the address the connection reached
    everywhere = served_address('0.0.0.0', ['rig', 'rig.local'])
    for allowed in ('rig:8765', 'rig.local:8765', 'localhost:8765', '0.0.0.0:8765',
                    '127.0.0.1:8765'):
        assert everywhere.allows(allowed, 8765), allowed
    assert everywhere.allows('10.0.0.5:8765', 8765, local_address='10.0.0.5')
    assert everywhere.allows('10.0.0.5:8765', 8765, local_address='::ffff:10.0.0.5')
    assert not everywhere.allows('10.0.0.6:8765', 8765, local_address='10.0.0.5')
    assert not everywhere.allows('evil.example:8765', 8765, local_address='10.0.0.5')
    assert served_address('::', ['rig']).allows('[fe80::1]:8765', 8765,
                                                local_address='fe80::1')


# -- what the terminal shows -----------------------------------------------------------------
def reset_after(port: int, path: str, *, read_first: bool = False) -> None:
    """Send ``GET path`` (a WebSocket upgrade for ``/ws``) and close with a reset (RST)."""
    upgrade = ('Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Version: 13\r\n'
               'Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n') if path == '/ws' else ''
    with socket.socket() as client:
        client.settimeout(5.0)
        client.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # a small window
        client.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack('ii', 1, 0))
        client.connect(('127.0.0.1', port))
        client.sendall(f'GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n{upgrade}\r\n'
                       .encode())
        if read_first:
            assert client.recv(64).startswith(b'HTTP/1.1 200')
            time.sleep(0.2)


def run_console(server: ConsoleServer, check: Callable[[], Awaitable[None]]) -> None:
    """Run ``check`` against ``serve(server)`` (on a free port), as ``./pd console`` runs."""
    async def body() -> None:
        stop = threading.Event()
        task = asyncio.create_task(serve(server, stop))
        deadline = time.monotonic() + 5.0
        while not server.port and time.monotonic() < deadline:
            await asyncio.sleep(0.01)
        try:
            await check()
        finally:
            stop.set()
            await task

    asyncio.run(body())


async def lines_logged(caplog: pytest.LogCaptureFixture, count: int) -> list[str]:
    """The terminal's lines (WARNING and above) once there are ``count`` (5 s at most)."""
    deadline = time.monotonic() + 5.0
    while True:
        lines = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
        if len(lines) >= count or time.monotonic() > deadline:
            return lines
        await asyncio.sleep(0.02)


def test_a_dropped_client_costs_one_line_and_no_traceback(
        tmp_path: Path, caplog: pytest.LogCaptureFixture,
        capsys: pytest.CaptureFixture[str]) -> None:
    caplog.set_level(logging.INFO)
    with (tmp_path / 'big.png').open('wb') as file:
        file.truncate(16 << 20)  # sparse; more than the socket buffers on the way hold
    model = ConsoleModel(time.monotonic)
    model.figures = ['big.png']
    server = ConsoleServer(model, threading.Lock(), ConsoleAccess(TOKEN), None,
                           update_rate=20.0, run_dir=tmp_path, port=0)
    expected: list[str] = []

    async def check() -> None:
        # a request and its reset arrive before the server reads either (the event loop is
        # blocked while the client sends them): the handler answers a closed connection
        for path in ('/ws', '/api/frame'):
            reset_after(server.port, path)
            expected.append(f'console: a client dropped its request (GET {path})')
            assert await lines_logged(caplog, len(expected)) == expected
        # a tab closed while a figure is being sent: the reset comes mid-response
        await asyncio.get_running_loop().run_in_executor(
            None, lambda: reset_after(server.port, '/figures/big.png', read_first=True))
        expected.append('console: a client dropped its request (GET /figures/big.png)')
        assert await lines_logged(caplog, len(expected)) == expected
        await asyncio.sleep(0.3)  # nothing more comes

    run_console(server, check)
    assert [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING] == expected
    assert not any(r.exc_info for r in caplog.records)
    assert 'Traceback' not in caplog.text + capsys.readouterr().err
    assert server.dropped_requests == 3


def test_a_malformed_request_and_a_failing_handler_cost_one_line(
        caplog: pytest.LogCaptureFixture, capsys: pytest.CaptureFixture[str]) -> None:
    caplog.set_level(logging.INFO)
    server = ConsoleServer(ConsoleModel(time.monotonic), threading.Lock(),
                           ConsoleAccess(TOKEN), None, update_rate=20.0, port=0)

    def broken() -> str:
        raise RuntimeError('the frame broke\non two lines')

    server.frame_text = broken  # type: ignore[method-assign]

    def ask(raw: bytes) -> bytes:
        with socket.create_connection(('127.0.0.1', server.port), timeout=5.0) as client:
            client.sendall(raw)
            return client.recv(4096)

    async def check() -> None:
        loop = asyncio.get_running_loop()
        host = f'Host: 127.0.0.1:{server.port}\r\n'.encode()
        bad = await loop.run_in_executor(
            None, ask, b'GET / HTTP/1.1\r\n' + host + b'Content-Length: abc\r\n\r\n')
        assert bad.startswith((b'HTTP/1.0 400', b'HTTP/1.1 400'))
        failed = await loop.run_in_executor(None, ask, b'GET /api/frame HTTP/1.1\r\n' + host
                                            + b'Connection: close\r\n\r\n')
        assert failed.startswith(b'HTTP/1.1 500') and b'the frame broke' in failed
        await lines_logged(caplog, 2)

    run_console(server, check)
    lines = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(lines) == 2 and all('\n' not in line for line in lines), lines
    assert lines[0].startswith('console: Error handling request') and 'BadHttpMessage' in lines[0]
    assert lines[1] == ('console: GET /api/frame failed: RuntimeError: the frame broke on two '
                        'lines')
    assert not any(r.exc_info for r in caplog.records)
    assert 'Traceback' not in caplog.text + capsys.readouterr().err


def test_the_consoles_ros_thread_goes_on_past_a_message_it_cannot_show(
        caplog: pytest.LogCaptureFixture) -> None:
    """A callback that raises (a message no test's node sends) is counted, the first said in
    one line, and the thread spins on: it used to end, and the page to freeze."""
    stop = threading.Event()
    unshown = Unshown()
    turns: list[int] = []

    def show(value: int) -> None:
        if value in (2, 3):
            msg = 'no such site'
            raise KeyError(msg)

    guarded = unshown.guarded(show)

    class Executor:
        def spin_once(self, timeout_sec: float) -> None:
            turns.append(1)
            guarded(len(turns))  # (a callback, as the executor calls it)
            if len(turns) == 4:
                raise RuntimeError('what escaped a callback')
            if len(turns) == 6:
                stop.set()

    with caplog.at_level(logging.ERROR, logger='pd_console.console'):
        spin_on(Executor(), stop, unshown, ok=lambda: True)
    assert len(turns) == 6 and unshown.count == 3
    lines = [record.getMessage() for record in caplog.records]
    assert lines == [("a message the console could not show (KeyError: 'no such site'); it "
                      'goes on (counted, not said again)')]
