"""The console's web server without ROS: the page, frames, login, refused and sent controls."""

from __future__ import annotations

import asyncio
import json
import threading
import time
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import pytest
from aiohttp import ClientSession
from aiohttp.test_utils import TestClient, TestServer

from pd_common.protocol import Command, Feedback
from pd_integrator.console import (
    ConsoleServer,
    FoxgloveFeed,
    default_bridge_limits,
    web_directory,
)
from pd_integrator.core.console import (
    ConsoleAccess,
    ConsoleModel,
    ControlRequest,
    foxglove_layout,
)

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
    assert default_bridge_limits(str(tmp_path / 'missing.yaml')) == {}
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
