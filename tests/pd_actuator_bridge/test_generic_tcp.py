"""Tests of the GenericTCP protocol client, driver and controller-side server (loopback only).

Every socket binds to 127.0.0.1 with a port chosen by the OS; every server, thread and process
started here is stopped by the test that started it, and each test is bounded in time.
"""

from __future__ import annotations

import math
import os
import re
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator

import pytest

from pd_actuator_bridge.controller_server import ControllerServer
from pd_actuator_bridge.controllers import (
    ElasticController,
    EmulatorController,
    load_emulator_controller,
    make_controller,
)
from pd_actuator_bridge.core import ActuatorBridge, BridgeConfigError, DriverError, SafetyLimits
from pd_actuator_bridge.core.drivers.generic_tcp import GenericTCPClient, GenericTCPDriver
from pd_actuator_bridge.core.drivers.generic_tcp_protocol import (
    ACTION_DIE,
    ACTION_GET_DAQ_RESPONSE,
    ACTION_SET_TRIAL_RESPONSE,
    DEFAULT_DATA_SIZE,
    DaqResponse,
    GenericTCPError,
    SizeID,
    TrialResponse,
    decode_daq,
    decode_size_id,
    decode_trial,
    decode_vector,
    encode_action,
    encode_daq,
    encode_size_id,
    encode_trial,
    encode_vector,
    normalize_sizes,
)
from pd_actuator_bridge.core.drivers.ramp_hold import RampHoldExecutor
from pd_common.protocol import FeedbackStatus
from support.paths import REPO

pytestmark = pytest.mark.timeout(30)

HOST = '127.0.0.1'
TIMEOUT = 2.0
LIMITS = SafetyLimits(max_displacement=0.1, max_increment=0.05, max_force=1.0e6)


@pytest.fixture
def elastic_server() -> Iterator[Callable[..., ControllerServer]]:
    """Start ControllerServers on demand; stop them all at teardown."""
    servers: list[ControllerServer] = []

    def start(stiffness=1000.0, n_dof: int = 1, **kwargs) -> ControllerServer:
        server = ControllerServer(ElasticController(stiffness, n_dof), HOST, 0,
                                  idle_timeout=5.0, **kwargs)
        server.start()
        servers.append(server)
        return server

    yield start
    for server in servers:
        server.stop()


class FakeController:
    """A raw peer that answers every getDaqResponse with a fixed (possibly malformed) payload."""

    def __init__(self, reply: bytes, close_after_reply: bool = False,
                 data_size: int = DEFAULT_DATA_SIZE) -> None:
        self.reply = reply
        self.close_after_reply = close_after_reply
        self.data_size = data_size
        self.received: list[list[float]] = []
        self._stop = threading.Event()
        self._listener = socket.create_server((HOST, 0), backlog=1)
        self._listener.settimeout(0.1)
        self.port = self._listener.getsockname()[1]
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _read(self, conn: socket.socket, n: int) -> bytes | None:
        data = b''
        while len(data) < n and not self._stop.is_set():
            try:
                chunk = conn.recv(n - len(data))
            except TimeoutError:
                continue
            except OSError:
                return None
            if not chunk:
                return None
            data += chunk
        return data if len(data) == n else None

    def _run(self) -> None:
        conn = None
        while conn is None and not self._stop.is_set():
            try:
                conn, _ = self._listener.accept()
            except TimeoutError:
                continue
        if conn is None:
            return
        conn.settimeout(0.1)
        try:
            if self._read(conn, 44) is None:
                return
            while not self._stop.is_set():
                payload = self._read(conn, 8 * self.data_size)
                if payload is None:
                    return
                vector = decode_vector(payload, self.data_size)
                self.received.append(vector)
                if vector[0] == ACTION_GET_DAQ_RESPONSE:
                    conn.sendall(self.reply)
                    if self.close_after_reply:
                        return
                elif vector[0] == ACTION_DIE:
                    return
        finally:
            conn.close()

    def join(self, timeout: float) -> bool:
        """Wait for the session to end by itself (99 or disconnect); return whether it did."""
        self._thread.join(timeout)
        return not self._thread.is_alive()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5.0)
        self._listener.close()


@pytest.fixture
def fake_controller() -> Iterator[Callable[..., FakeController]]:
    fakes: list[FakeController] = []

    def start(reply: bytes, close_after_reply: bool = False) -> FakeController:
        fake = FakeController(reply, close_after_reply)
        fakes.append(fake)
        return fake

    yield start
    for fake in fakes:
        fake.stop()


def daq_vector(disp: float, force: float) -> bytes:
    return encode_vector([disp, force], DEFAULT_DATA_SIZE)


# --------------------------------------------------------------------------- encoding


def test_size_id_is_eleven_little_endian_int32() -> None:
    size_id = SizeID({'disp': 2, 'time': 1}, {'disp': 2, 'force': 2}, 256)
    payload = encode_size_id(size_id)
    assert len(payload) == 44
    assert list(struct.unpack('<11i', payload)) == [2, 0, 0, 0, 1, 2, 0, 0, 2, 0, 256]
    assert decode_size_id(payload) == size_id
    big = encode_size_id(size_id, 'big')
    assert list(struct.unpack('>11i', big)) == size_id.as_list()
    assert decode_size_id(big, 'big') == size_id


def test_data_vectors_are_fixed_size_float64_with_the_action_first() -> None:
    size_id = SizeID({'disp': 2, 'vel': 2, 'time': 1}, {'disp': 2, 'force': 2, 'time': 1}, 16)
    trial = TrialResponse(disp=(0.25, -0.5), vel=(1.0, 2.0), time=(3.5,))
    payload = encode_trial(size_id, trial)
    assert len(payload) == 16 * 8
    vector = list(struct.unpack('<16d', payload))
    assert vector[:6] == [ACTION_SET_TRIAL_RESPONSE, 0.25, -0.5, 1.0, 2.0, 3.5]
    assert vector[6:] == [0.0] * 10
    assert decode_trial(decode_vector(payload, 16), size_id) == trial

    daq = DaqResponse(disp=(0.25, -0.5), force=(250.0, -500.0), time=(3.5,))
    payload = encode_daq(size_id, daq)
    vector = list(struct.unpack('<16d', payload))
    assert vector[:5] == [0.25, -0.5, 250.0, -500.0, 3.5]  # no action code in a daq reply
    assert decode_daq(decode_vector(payload, 16), size_id) == daq

    die = decode_vector(encode_action(ACTION_DIE, 16), 16)
    assert die == [99.0] + [0.0] * 15


def test_encoding_rejects_bad_sizes_and_lengths() -> None:
    with pytest.raises(BridgeConfigError, match='unknown response kind'):
        normalize_sizes({'displacement': 1})
    with pytest.raises(BridgeConfigError, match='expected 5 sizes'):
        normalize_sizes([1, 0, 0])
    with pytest.raises(BridgeConfigError, match='>= 0'):
        normalize_sizes([-1, 0, 0, 0, 0])
    with pytest.raises(BridgeConfigError, match='do not fit in data_size 4'):
        SizeID({'disp': 4}, {'disp': 4}, 4)
    size_id = SizeID({'disp': 1}, {'disp': 1, 'force': 1}, 8)
    with pytest.raises(GenericTCPError, match='trial disp has 2 values'):
        encode_trial(size_id, TrialResponse(disp=(1.0, 2.0)))
    with pytest.raises(GenericTCPError, match='must be 64 bytes, got 56'):
        decode_vector(b'\0' * 56, 8)
    with pytest.raises(GenericTCPError, match='do not fit'):
        encode_vector([0.0] * 9, 8)
    with pytest.raises(GenericTCPError, match='invalid size ID'):
        decode_size_id(struct.pack('<11i', 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 1))
    with pytest.raises(GenericTCPError, match='44 bytes'):
        decode_size_id(b'\0' * 40)


# --------------------------------------------------------------------------- client <-> server


@pytest.mark.parametrize(
    ('n_dof', 'stiffness', 'steps'),
    [
        (1, 1000.0, [[0.0], [0.001], [-0.002], [0.0035]]),
        (2, [1000.0, 2500.0], [[0.0, 0.0], [0.001, -0.002], [0.004, 0.003]]),
    ],
)
def test_round_trip_returns_elastic_forces(elastic_server, n_dof, stiffness, steps) -> None:
    server = elastic_server(stiffness, n_dof)
    k = stiffness if isinstance(stiffness, list) else [stiffness] * n_dof
    with GenericTCPClient(HOST, server.port, timeout=TIMEOUT) as client:
        client.setup({'disp': n_dof}, {'disp': n_dof, 'force': n_dof})
        for target in steps:
            client.set_trial_response(disp=target)
            daq = client.get_daq_response()
            client.commit_state()
            assert daq.disp == pytest.approx(target)
            assert daq.force == pytest.approx([ki * xi for ki, xi in zip(k, target, strict=True)])
            assert daq.vel == daq.accel == daq.time == ()
    assert server.wait(TIMEOUT)
    assert server.ended_by_client, server.error
    assert server.steps == len(steps)
    assert server.daq_requests == len(steps)
    assert server.error == ''


def test_round_trip_with_every_response_kind(elastic_server) -> None:
    server = elastic_server(2000.0, 1)
    with GenericTCPClient(HOST, server.port, timeout=TIMEOUT, data_size=32) as client:
        client.setup([1, 1, 1, 0, 1], [1, 1, 1, 1, 2])
        client.set_trial_response(disp=[0.01], vel=[0.2], accel=[-3.0], time=[1.25])
        daq = client.get_daq_response()
    assert daq == DaqResponse(disp=(0.01,), vel=(0.2,), accel=(-3.0,), force=(20.0,),
                              time=(1.25, 1.25))
    assert server.wait(TIMEOUT) and server.ended_by_client
    assert server.size_id.data_size == 32


def test_client_refuses_non_finite_trial_without_sending(elastic_server) -> None:
    server = elastic_server()
    with GenericTCPClient(HOST, server.port, timeout=TIMEOUT) as client:
        client.setup({'disp': 1}, {'disp': 1, 'force': 1})
        with pytest.raises(GenericTCPError, match=r'setTrialResponse: .*non-finite.*disp\[0\]'):
            client.set_trial_response(disp=[math.nan])
        client.set_trial_response(disp=[0.002])
        assert client.get_daq_response().force == (pytest.approx(2.0),)
    assert server.wait(TIMEOUT) and server.steps == 1


def test_client_usage_errors_name_the_address_and_action() -> None:
    client = GenericTCPClient(HOST, 9, timeout=TIMEOUT)
    with pytest.raises(GenericTCPError, match=r'^GenericTCP 127\.0\.0\.1:9: getDaqResponse: '
                                              r'not connected$'):
        client.get_daq_response()
    client.close()  # idempotent, nothing to close
    with pytest.raises(BridgeConfigError, match='port'):
        GenericTCPClient(HOST, 0)
    with pytest.raises(BridgeConfigError, match='timeout'):
        GenericTCPClient(HOST, 9, timeout=0)


def test_setup_is_required(elastic_server) -> None:
    server = elastic_server()
    with (
        GenericTCPClient(HOST, server.port, timeout=TIMEOUT) as client,
        pytest.raises(GenericTCPError, match='setTrialResponse: setup\\(\\) was not called'),
    ):
        client.set_trial_response(disp=[0.0])


# --------------------------------------------------------------------------- failures


def test_connection_refused_is_a_clear_error() -> None:
    # A bound but non-listening socket: the port is ours, and connecting to it is refused.
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as blocker:
        blocker.bind((HOST, 0))
        port = blocker.getsockname()[1]
        client = GenericTCPClient(HOST, port, timeout=TIMEOUT)
        start = time.monotonic()
        with pytest.raises(GenericTCPError) as info:
            client.connect()
        assert time.monotonic() - start < TIMEOUT
    assert str(info.value) == f'GenericTCP {HOST}:{port}: connect: connection refused'
    assert isinstance(info.value, DriverError)
    assert not client.connected


@pytest.mark.parametrize(
    ('reply', 'close_after', 'pattern'),
    [
        (b'\0' * 16, True,
         (r'getDaqResponse: the controller closed the connection mid-message '
          r'\(got 16 of 2048 bytes')),
        (daq_vector(0.001, 1.0) + b'\0' * 8, False,
         r'getDaqResponse: malformed reply: 8 unexpected byte\(s\) after the 2048-byte vector'),
        (daq_vector(0.001, math.nan), False,
         r'getDaqResponse: malformed reply: daq force\[0\] is nan'),
        (daq_vector(math.inf, 1.0), False,
         r'getDaqResponse: malformed reply: daq disp\[0\] is inf'),
        (b'', True, r'getDaqResponse: the controller closed the connection before replying'),
    ],
    ids=['short-then-closed', 'too-long', 'nan-force', 'inf-disp', 'closed-no-reply'],
)
def test_malformed_replies_raise_clear_errors(fake_controller, reply, close_after,
                                              pattern) -> None:
    fake = fake_controller(reply, close_after)
    client = GenericTCPClient(HOST, fake.port, timeout=TIMEOUT)
    client.connect()
    client.setup({'disp': 1}, {'disp': 1, 'force': 1})
    client.set_trial_response(disp=[0.001])
    with pytest.raises(GenericTCPError) as info:
        client.get_daq_response()
    message = str(info.value)
    assert message.startswith(f'GenericTCP {HOST}:{fake.port}: ')
    assert re.search(pattern, message), message
    assert '\n' not in message
    assert not client.connected  # the broken connection is dropped
    client.close()


def test_short_reply_then_silence_times_out(fake_controller) -> None:
    fake = fake_controller(b'\0' * 16)
    client = GenericTCPClient(HOST, fake.port, timeout=0.3)
    client.connect()
    client.setup({'disp': 1}, {'disp': 1, 'force': 1})
    start = time.monotonic()
    with pytest.raises(GenericTCPError, match=r'getDaqResponse: timed out after 0\.3 s waiting '
                                              r'for the reply \(got 16 of 2048 bytes\)'):
        client.get_daq_response()
    assert 0.25 < time.monotonic() - start < 2.0
    client.close()


def test_valid_fake_reply_is_decoded(fake_controller) -> None:
    fake = fake_controller(daq_vector(0.004, 8.0))
    with GenericTCPClient(HOST, fake.port, timeout=TIMEOUT) as client:
        client.setup({'disp': 1}, {'disp': 1, 'force': 1})
        client.set_trial_response(disp=[0.004])
        assert client.get_daq_response() == DaqResponse(disp=(0.004,), force=(8.0,))
    assert fake.join(TIMEOUT)
    # What the fake received: the trial [3, 0.004, 0...], the request [6, ...], then [99, ...].
    assert [v[0] for v in fake.received] == [3.0, 6.0, 99.0]
    assert fake.received[0][1] == 0.004


# --------------------------------------------------------------------------- driver and bridge


def make_bridge(port: int, n_dof: int = 1, timeout: float = TIMEOUT):
    driver = GenericTCPDriver(HOST, port, n_dof=n_dof, timeout=timeout)
    names = [f'dof{i}' for i in range(n_dof)]
    return ActuatorBridge(driver, LIMITS, names), driver


def test_driver_through_the_bridge_completes_steps(elastic_server) -> None:
    server = elastic_server([1000.0, 3000.0], 2)
    bridge, driver = make_bridge(server.port, n_dof=2)
    driver.open()
    assert driver.position() == [0.0, 0.0]
    targets = [[0.0, 0.0], [0.01, -0.01], [0.02, 0.005], [0.015, 0.0]]
    for step, target in enumerate(targets):
        reply = bridge.handle_command('t1', step, target)
        assert reply is not None and reply.status is FeedbackStatus.OK, reply
        assert reply.step == step
        assert reply.measured_displacement == pytest.approx(target)
        assert reply.restoring_force == pytest.approx([1000.0 * target[0], 3000.0 * target[1]])
    # A repeated step is answered from the bridge's memory without moving.
    assert bridge.handle_command('t1', 3, targets[3]).status is FeedbackStatus.OK
    assert server.steps == len(targets)
    driver.close()
    assert server.wait(TIMEOUT) and server.ended_by_client, server.error
    assert bridge.state == 'ready'


@pytest.mark.parametrize('mode', ['server-stopped', 'dies-mid-step'])
def test_dead_controller_makes_the_bridge_hold(elastic_server, mode) -> None:
    n_ok = 3
    if mode == 'server-stopped':
        server = elastic_server()
    else:
        server = elastic_server(die_after=n_ok)
    bridge, driver = make_bridge(server.port)
    driver.open()
    for step in range(n_ok):
        assert bridge.handle_command('t1', step, [0.001 * step]).status is FeedbackStatus.OK
    if mode == 'server-stopped':
        server.stop()
    start = time.monotonic()
    reply = bridge.handle_command('t1', n_ok, [0.001 * n_ok])  # must not raise
    assert time.monotonic() - start < TIMEOUT + 1.0
    assert reply.status is FeedbackStatus.FAULT
    assert bridge.state == 'holding'
    assert f'{HOST}:{server.port}' in reply.message
    assert re.search(r'(closed|reset) the connection', reply.message), reply.message
    assert driver.hold_count == 1
    # the last measured position
    assert reply.measured_displacement == pytest.approx([0.001 * (n_ok - 1)])
    assert driver.fault and not driver.is_open
    # Later commands are answered with the latched hold, still without exceptions.
    later = bridge.handle_command('t1', n_ok + 1, [0.0])
    assert later.status is FeedbackStatus.FAULT and bridge.state == 'holding'
    assert server.wait(TIMEOUT)
    if mode == 'dies-mid-step':
        assert 'died after 3 steps' in server.error
    driver.close()


def test_driver_open_refused_and_usage_errors() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as blocker:
        blocker.bind((HOST, 0))
        port = blocker.getsockname()[1]
        driver = GenericTCPDriver(HOST, port, timeout=TIMEOUT)
        with pytest.raises(GenericTCPError, match='connect: connection refused'):
            driver.open()
    with pytest.raises(DriverError, match='not connected'):
        driver.command(0, [0.0])
    with pytest.raises(DriverError, match='target has 2 values, expected 1'):
        driver.command(0, [0.0, 0.0])
    assert all(math.isnan(x) for x in driver.position())
    with pytest.raises(BridgeConfigError, match='n_dof'):
        GenericTCPDriver(HOST, port, n_dof=0)


def test_server_rejects_a_size_id_it_cannot_serve(elastic_server) -> None:
    server = elastic_server(1000.0, 2)
    client = GenericTCPClient(HOST, server.port, timeout=TIMEOUT)
    client.connect()
    client.setup({'disp': 1}, {'disp': 1, 'force': 1})  # the server has 2 DOF
    assert server.wait(TIMEOUT)
    assert 'setup' in server.error and '2 controlled displacement' in server.error
    with pytest.raises(GenericTCPError, match='closed the connection'):
        client.set_trial_response(disp=[0.0])
        client.get_daq_response()
    client.close()


def test_server_reports_a_client_that_leaves_without_99(elastic_server) -> None:
    server = elastic_server()
    with socket.create_connection((HOST, server.port), timeout=TIMEOUT) as sock:
        sock.sendall(encode_size_id(SizeID({'disp': 1}, {'disp': 1, 'force': 1})))
    assert server.wait(TIMEOUT)
    assert not server.ended_by_client
    assert 'without sending 99' in server.error


def test_server_idle_timeout_ends_the_session() -> None:
    server = ControllerServer(ElasticController(), HOST, 0, idle_timeout=0.3)
    server.start()
    try:
        with socket.create_connection((HOST, server.port), timeout=TIMEOUT):
            assert server.wait(3.0)
        assert 'no data for 0.3 s' in server.error
    finally:
        server.stop()


def test_server_stop_without_client_is_prompt() -> None:
    server = ControllerServer(ElasticController(), HOST, 0)
    server.start()
    start = time.monotonic()
    server.stop()
    assert time.monotonic() - start < 1.0
    assert server.done


# --------------------------------------------------------------------------- emulator hook


def test_emulator_that_cannot_be_built_falls_back_with_a_message() -> None:
    messages: list[str] = []
    controller = make_controller(1, -500.0, emulator=True, warn=messages.append)
    assert isinstance(controller, ElasticController)
    assert len(messages) == 1
    assert 'not available' in messages[0] and 'falling back' in messages[0]


def test_emulator_backend_is_served_over_tcp(elastic_server) -> None:
    class Backend:
        def __init__(self, n_dof: int, stiffness: float) -> None:
            self.stiffness = stiffness
            self.targets: list[list[float]] = []

        def execute(self, target):
            self.targets.append(list(target))
            measured = [0.9 * x for x in target]  # a 10 % undershoot
            return measured, [self.stiffness * x for x in measured]

    controller = EmulatorController(Backend(1, 400.0), 1)
    assert isinstance(controller, EmulatorController)
    server = ControllerServer(controller, HOST, 0, idle_timeout=5.0)
    server.start()
    try:
        with GenericTCPClient(HOST, server.port, timeout=TIMEOUT) as client:
            client.setup({'disp': 1}, {'disp': 1, 'force': 1})
            client.set_trial_response(disp=[0.01])
            daq = client.get_daq_response()
        assert daq.disp == pytest.approx((0.009,))
        assert daq.force == pytest.approx((3.6,))
        assert controller.backend.targets == [[0.01]]
    finally:
        server.stop()


def test_real_emulator_backend_tracks_the_command() -> None:
    k = 312559.0
    controller = load_emulator_controller(1, k, ramp_time=0.1, hold_time=0.3)
    assert isinstance(controller.backend, RampHoldExecutor)
    server = ControllerServer(controller, HOST, 0, idle_timeout=5.0)
    server.start()
    try:
        with GenericTCPClient(HOST, server.port, timeout=5.0) as client:
            client.setup({'disp': 1}, {'disp': 1, 'force': 1})
            for target in (0.001, -0.002):
                client.set_trial_response(disp=[target])
                daq = client.get_daq_response()
                # Plumbing check, not a tuning check: the actuator got there within 10 % and
                # the load cell reads the elastic specimen's force at the measured position.
                assert daq.disp[0] == pytest.approx(target, rel=0.10)
                assert daq.force[0] == pytest.approx(k * daq.disp[0], rel=0.02)
        assert server.wait(TIMEOUT) and server.ended_by_client, server.error
    finally:
        server.stop()


# --------------------------------------------------------------------------- executable


def test_controller_server_executable() -> None:
    env = dict(os.environ)
    source = str(REPO / 'src' / 'pd_actuator_bridge')
    env['PYTHONPATH'] = source + os.pathsep + env.get('PYTHONPATH', '')
    process = subprocess.Popen(
        [sys.executable, '-m', 'pd_actuator_bridge.controller_server', '--port', '0',
         '--dofs', '1', '--stiffness', '500', '--idle-timeout', '10'],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )
    try:
        lines: list[str] = []
        reader = threading.Thread(target=lambda: lines.append(process.stdout.readline()),
                                  daemon=True)
        reader.start()
        reader.join(10.0)
        assert lines, 'controller_server printed no port within 10 s'
        match = re.fullmatch(r'controller_server: listening on 127\.0\.0\.1:(\d+)\n', lines[0])
        assert match, lines[0]
        port = int(match.group(1))
        with GenericTCPClient(HOST, port, timeout=5.0) as client:
            client.setup({'disp': 1}, {'disp': 1, 'force': 1})
            for x in (0.0, 0.002, -0.004):
                client.set_trial_response(disp=[x])
                daq = client.get_daq_response()
                assert daq.disp == (pytest.approx(x),)
                assert daq.force == (pytest.approx(500.0 * x),)
        assert process.wait(timeout=10.0) == 0
        stderr = process.stderr.read()
        assert 'client ended the session (99) after 3 steps' in stderr
    finally:
        if process.poll() is None:
            process.kill()
            process.wait(timeout=5.0)
        process.stdout.close()
        process.stderr.close()
