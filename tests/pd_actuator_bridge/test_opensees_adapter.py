"""Tests of the OpenSees ``adapter`` element client and the ``opensees_site`` executable.

Part (a) drives :class:`OpenSeesAdapterDriver` against a fake adapter written here (one
thread, 127.0.0.1, port chosen by the OS): wire layout, sign and order of the reply, and
every failure (refused, short read, NaN, too long, silence). Part (b) runs a real OpenSees
``adapter`` element with openseespy (``opensees_site`` in a subprocess on a free loopback
port, always killed at the end) and checks its forces against ``pd_specimen_sim``'s
elastic-perfectly-plastic model through yielding and reversals. Part (b) is skipped only if
openseespy cannot be imported.
"""

from __future__ import annotations

import math
import os
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest

from pd_actuator_bridge import opensees_site
from pd_actuator_bridge.core import (
    ActuatorBridge,
    BridgeConfigError,
    DriverError,
    OpenSeesAdapterDriver,
    OpenSeesAdapterError,
    SafetyLimits,
)
from pd_actuator_bridge.core.drivers.generic_tcp_protocol import DEFAULT_DATA_SIZE, encode_vector
from pd_actuator_bridge.core.drivers.opensees_adapter import (
    ACTION_DIE,
    ACTION_GET_FORCE,
    ACTION_SET_TRIAL_RESPONSE,
)
from pd_common.protocol import FeedbackStatus
from pd_common.specimen.hysteresis import ElasticPerfectlyPlastic
from support.paths import REPO

pytestmark = pytest.mark.timeout(60)

HOST = '127.0.0.1'
TIMEOUT = 2.0
VECTOR_BYTES = 8 * DEFAULT_DATA_SIZE


# --------------------------------------------------------------------------- fake adapter


class FakeAdapter:
    """The server side of the adapter protocol, scripted by ``reply(trial) -> bytes``.

    It accepts one client, reads the 44-byte size ID, then reads fixed-size vectors: ``3``
    stores the trial, ``10`` is answered with ``reply(last trial)`` (``None``: stay silent),
    ``99`` ends; with ``close_after`` it closes the connection after that many ``10``.
    Everything received is kept in :attr:`received`.
    """

    def __init__(self, reply: Callable[[list[float]], bytes | None],
                 close_after: int | None = None, delay: float = 0.0) -> None:
        self._reply = reply
        self._close_after = close_after
        self._delay = delay
        with socket.socket() as probe:
            probe.bind((HOST, 0))
            self.port = probe.getsockname()[1]
        self.size_id: tuple[int, ...] = ()
        self.received: list[tuple[float, ...]] = []
        self.error = ''
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        if self._delay and self._stop.wait(self._delay):
            return  # not listening yet: connections are refused until then
        with socket.socket() as listener:
            listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            listener.bind((HOST, self.port))
            listener.listen(1)
            listener.settimeout(0.1)
            while not self._stop.is_set():
                try:
                    conn, _ = listener.accept()
                except TimeoutError:
                    continue
                with conn:
                    self._session(conn)
                return

    def _recv(self, conn: socket.socket, n: int) -> bytes | None:
        data = b''
        while len(data) < n and not self._stop.is_set():
            try:
                chunk = conn.recv(n - len(data))
            except TimeoutError:
                continue
            if not chunk:
                return None
            data += chunk
        return data if len(data) == n else None

    def _session(self, conn: socket.socket) -> None:
        conn.settimeout(0.1)
        raw = self._recv(conn, 44)
        if raw is None:
            return
        self.size_id = struct.unpack('<11i', raw)
        size = self.size_id[10]
        trial: list[float] = []
        requests = 0
        while True:
            raw = self._recv(conn, 8 * size)
            if raw is None:
                return
            vector = struct.unpack(f'<{size}d', raw)
            self.received.append(vector)
            action = int(vector[0])
            if action == ACTION_SET_TRIAL_RESPONSE:
                trial = list(vector[1:1 + self.size_id[0]])
            elif action == ACTION_GET_FORCE:
                requests += 1
                payload = self._reply(trial)
                if payload is not None:
                    conn.sendall(payload)
                if requests == self._close_after:
                    return
            elif action == ACTION_DIE:
                return
            else:
                self.error = f'unexpected action {action}'
                return

    def wait(self, timeout: float) -> bool:
        """Wait for the session to end by itself (99 or close); return whether it did."""
        self._thread.join(timeout)
        return not self._thread.is_alive()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5.0)


@pytest.fixture
def fake_adapter() -> Iterator[Callable[..., FakeAdapter]]:
    fakes: list[FakeAdapter] = []

    def start(reply: Callable[[list[float]], bytes | None], **kwargs) -> FakeAdapter:
        fake = FakeAdapter(reply, **kwargs)
        fakes.append(fake)
        return fake

    yield start
    for fake in fakes:
        fake.stop()


def spring(k: list[float]) -> Callable[[list[float]], bytes]:
    """A reply like the adapter's: displacements then forces (zeros before any trial)."""
    def reply(trial: list[float]) -> bytes:
        x = trial or [0.0] * len(k)
        return encode_vector([*x, *(ki * xi for ki, xi in zip(k, x, strict=True))],
                             DEFAULT_DATA_SIZE)
    return reply


def driver_for(port: int, n_dof: int = 1, **kwargs) -> OpenSeesAdapterDriver:
    kwargs.setdefault('timeout', TIMEOUT)
    kwargs.setdefault('connect_timeout', TIMEOUT)
    return OpenSeesAdapterDriver(HOST, port, n_dof, **kwargs)


# --------------------------------------------------------------------------- (a) protocol


def test_wire_layout_and_callback_against_a_fake_adapter(fake_adapter) -> None:
    fake = fake_adapter(spring([1000.0, 3000.0]))
    driver = driver_for(fake.port, n_dof=2)
    measured: list[tuple[int, list[float], list[float]]] = []
    driver.set_measurement_callback(
        lambda m: measured.append((m.step, list(m.displacement), list(m.force))))
    driver.open()
    assert driver.position() == [0.0, 0.0] and driver.last_force == [0.0, 0.0]
    driver.command(7, [0.01, -0.002])
    assert measured == [(7, [0.01, -0.002], [10.0, -6.0])]
    driver.hold()  # sends nothing
    assert driver.position() == [0.01, -0.002]
    driver.close()
    driver.close()  # idempotent
    assert fake.wait(TIMEOUT)
    assert fake.error == ''
    assert fake.size_id == (2, 0, 0, 0, 0, 2, 0, 0, 2, 0, DEFAULT_DATA_SIZE)
    actions = [int(v[0]) for v in fake.received]
    assert actions == [ACTION_GET_FORCE, ACTION_SET_TRIAL_RESPONSE, ACTION_GET_FORCE, ACTION_DIE]
    assert all(len(v) == DEFAULT_DATA_SIZE for v in fake.received)
    trial = fake.received[1]
    assert trial[:3] == (3.0, 0.01, -0.002) and not any(trial[3:])
    assert not any(fake.received[2][1:]) and not any(fake.received[3][1:])
    assert driver.hold_count == 1 and not driver.is_open


def test_open_retries_until_the_adapter_listens(fake_adapter) -> None:
    fake = fake_adapter(spring([1.0]), delay=0.4)
    driver = driver_for(fake.port, connect_timeout=5.0)
    start = time.monotonic()
    driver.open()
    assert time.monotonic() - start >= 0.3
    assert driver.is_open and driver.position() == [0.0]
    driver.close()


def test_refused_connection_is_a_one_line_error_after_connect_timeout() -> None:
    with socket.socket() as blocker:  # bound, never listening: every attempt is refused
        blocker.bind((HOST, 0))
        port = blocker.getsockname()[1]
        driver = driver_for(port, connect_timeout=0.3)
        start = time.monotonic()
        with pytest.raises(OpenSeesAdapterError) as info:
            driver.open()
        elapsed = time.monotonic() - start
    assert 0.25 <= elapsed < 2.0
    message = str(info.value)
    assert message.startswith(f'OpenSees adapter {HOST}:{port}: connect: connection refused '
                              f'for 0.3 s')
    assert '\n' not in message and isinstance(info.value, DriverError)
    assert not driver.is_open


@pytest.mark.parametrize(
    ('reply', 'close_after', 'pattern'),
    [
        (lambda t: b'\0' * 24, True,
         r'step 1: OpenSees closed the connection mid-reply \(got 24 of 2048 bytes: short read\)'),
        (lambda t: None, True, r'step 1: OpenSees closed the connection before replying'),
        (lambda t: encode_vector([0.01, math.nan], DEFAULT_DATA_SIZE), False,
         r'step 1: non-finite force\[0\] = nan in the reply'),
        (lambda t: encode_vector([math.inf, 1.0], DEFAULT_DATA_SIZE), False,
         r'step 1: non-finite displacement\[0\] = inf in the reply'),
        (lambda t: encode_vector([0.01, 1.0], DEFAULT_DATA_SIZE) + b'\0' * 8, False,
         r'step 1: wrong reply size: 8 byte\(s\) after the 2048-byte vector'),
        (lambda t: b'\0' * 16, False,
         r'step 1: no reply within 0\.5 s \(got 16 of 2048 bytes'),
    ],
    ids=['short-read', 'closed', 'nan-force', 'inf-disp', 'too-long', 'short-then-silent'],
)
def test_malformed_replies_raise_one_line_errors(fake_adapter, reply, close_after,
                                                 pattern) -> None:
    first = [True]

    def script(trial: list[float]) -> bytes | None:
        if first[0]:  # the reply to open() is good; the step's reply is the bad one
            first[0] = False
            return spring([100.0])(trial)
        return reply(trial)

    fake = fake_adapter(script, close_after=2 if close_after else None)
    driver = driver_for(fake.port, timeout=0.5)
    driver.open()
    measured: list[object] = []
    driver.set_measurement_callback(measured.append)
    with pytest.raises(OpenSeesAdapterError, match=rf'^OpenSees adapter {HOST}:{fake.port}: '
                       + pattern) as info:
        driver.command(1, [0.01])
    assert '\n' not in str(info.value)
    assert measured == [] and not driver.is_open
    assert driver.fault == str(info.value)
    with pytest.raises(DriverError, match=r'command\(\) at step 2 while not connected'):
        driver.command(2, [0.0])
    driver.close()


def test_usage_errors() -> None:
    for kwargs, name in (({'n_dof': 0}, 'n_dof'), ({'port': 0}, 'port'),
                         ({'timeout': -1.0}, 'timeout'), ({'connect_timeout': math.nan},
                                                          'connect_timeout')):
        args = {'host': HOST, 'port': 5000, 'n_dof': 1} | kwargs
        with pytest.raises(BridgeConfigError, match=name):
            OpenSeesAdapterDriver(**args)
    with pytest.raises(BridgeConfigError, match='data_size'):
        OpenSeesAdapterDriver(HOST, 5000, n_dof=2, data_size=3)  # 2*2 daq values do not fit
    driver = OpenSeesAdapterDriver(HOST, 5000, n_dof=1)
    assert math.isnan(driver.position()[0])
    with pytest.raises(DriverError, match='target has 2 values, expected 1'):
        driver.command(0, [0.0, 0.0])
    with pytest.raises(DriverError, match='non-finite target'):
        driver.command(0, [math.nan])
    with pytest.raises(DriverError, match=rf'{HOST}:5000: command\(\) at step 0 while not'):
        driver.command(0, [0.0])


def test_site_without_openseespy_exits_with_one_line(monkeypatch, capsys) -> None:
    real = opensees_site.importlib.util.find_spec
    monkeypatch.setattr(opensees_site.importlib.util, 'find_spec',
                        lambda name, *a: None if name == 'openseespy' else real(name, *a))
    status = opensees_site.main(['--port', '45000', '--stiffness', '1', '--yield-force', '1'])
    err = capsys.readouterr().err
    assert status == 2
    assert err == ('opensees_site: openseespy is not installed (pinned in requirements.txt; '
                   'run ./pd setup)\n')


def test_site_rejects_incomplete_options(capsys) -> None:
    with pytest.raises(SystemExit) as info:
        opensees_site.main(['--port', '45000', '--model', 'epp', '--stiffness', '1'])
    assert info.value.code == 2
    assert capsys.readouterr().err.endswith('opensees_site: --model epp needs --yield-force > 0\n')


def test_library_dir_is_appended_to_ld_library_path() -> None:
    env = opensees_site.opensees_environment({'LD_LIBRARY_PATH': '/ros/libs'})
    lib = opensees_site.opensees_library_dir()
    assert env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'
    if lib is None:
        assert env['LD_LIBRARY_PATH'] == '/ros/libs'
    else:
        assert env['LD_LIBRARY_PATH'] == f'/ros/libs{os.pathsep}{lib}'
        again = opensees_site.opensees_environment(env)
        assert again['LD_LIBRARY_PATH'] == env['LD_LIBRARY_PATH']


# --------------------------------------------------------------------------- (b) real OpenSees


@pytest.fixture(scope='module')
def openseespy_available() -> None:
    """Skip part (b) only if openseespy cannot be imported (checked in a subprocess)."""
    check = subprocess.run([sys.executable, '-c', 'import openseespy.opensees'],
                           env=opensees_site.opensees_environment(), capture_output=True,
                           text=True, timeout=60)
    if check.returncode != 0:
        lines = (check.stderr or check.stdout).strip().splitlines() or ['no output']
        pytest.skip(f'openseespy cannot be imported: {lines[-1]}')


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind((HOST, 0))
        return probe.getsockname()[1]


class Site:
    """``opensees_site`` in its own process group, stopped by :meth:`kill`."""

    def __init__(self, *options: str) -> None:
        self.port = free_port()
        env = dict(os.environ)
        env['PYTHONPATH'] = str(REPO / 'src' / 'pd_actuator_bridge') + os.pathsep + \
            env.get('PYTHONPATH', '')
        env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
        self.process = subprocess.Popen(
            [sys.executable, '-m', 'pd_actuator_bridge.opensees_site', '--port', str(self.port),
             *options], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
            start_new_session=True)

    def finish(self, timeout: float = 10.0) -> tuple[int, str, str]:
        out, err = self.process.communicate(timeout=timeout)
        return self.process.returncode, out, err

    def kill(self) -> None:
        if self.process.poll() is None:
            try:
                os.killpg(self.process.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        self.process.communicate(timeout=10.0)


@pytest.fixture
def site(openseespy_available) -> Iterator[Callable[..., Site]]:
    sites: list[Site] = []

    def start(*options: str) -> Site:
        started = Site(*options)
        sites.append(started)
        return started

    yield start
    for started in sites:
        started.kill()


def cyclic_history(yield_displacement: float) -> list[float]:
    """Ramps through 0.5, 2, -2.5, 3, -1.5 and 0 times d_y: yields, reverses, re-yields."""
    history: list[float] = []
    current = 0.0
    for peak in (0.5, 2.0, -2.5, 3.0, -1.5, 0.0):
        target = peak * yield_displacement
        history.extend(np.linspace(current, target, 25)[1:].tolist())
        current = target
    return history


def test_real_adapter_matches_elastic_perfectly_plastic(site) -> None:
    stiffness, yield_force = 312_559.0, 10_000.0  # the thesis column: d_y = 32 mm
    penalty = 1.0e6 * stiffness
    process = site('--model', 'epp', '--stiffness', repr(stiffness),
                   '--yield-force', repr(yield_force), '--penalty', repr(penalty))
    driver = OpenSeesAdapterDriver(HOST, process.port, 1, timeout=5.0, connect_timeout=20.0)
    measured: list[tuple[int, list[float], list[float]]] = []
    driver.set_measurement_callback(
        lambda m: measured.append((m.step, list(m.displacement), list(m.force))))
    driver.open()
    assert driver.position() == [0.0] and driver.last_force == [0.0]
    history = cyclic_history(yield_force / stiffness)
    start = time.monotonic()
    for step, target in enumerate(history):
        driver.command(step, [target])
    elapsed = time.monotonic() - start
    driver.close()
    status, out, err = process.finish()
    assert status == 0, err
    assert out.startswith(f'opensees_site: serving epp (zeroLength, ElasticPP K=312559 N/m, '
                          f'Fy=10000 N, penalty 3.12559e+11 N/m) on port {process.port}')
    assert err.rstrip().endswith('opensees_site: the client ended the test (99)')

    assert [s for s, _, _ in measured] == list(range(len(history)))
    target = np.array(history)
    x = np.array([m[1][0] for m in measured])
    force = np.array([m[2][0] for m in measured])
    # The node sits where the penalty spring balances the substructure: x = target - f/kp.
    assert np.max(np.abs(x - (target - force / penalty))) < 1e-12
    # Reference: pd_specimen_sim's EPP walked through the displacements OpenSees reached.
    model = ElasticPerfectlyPlastic(stiffness, yield_force)
    reference = []
    for xi in x:
        reference.append(model.set_trial_displacement(float(xi)))
        model.commit()
    difference = np.abs(force - np.array(reference))
    print(f'max |F_opensees - F_epp| = {difference.max():.3e} N over {len(history)} steps '
          f'({elapsed / len(history) * 1e3:.2f} ms/step)')
    # Round-off only: the adapter computes f = kp (target - x) with kp = 3e11 N/m from
    # displacements of ~0.1 m (ulp 1.4e-17 m), i.e. a few 1e-6 N; allow 1e-4 N = 1e-8 Fy.
    assert difference.max() < 1e-4
    # The history really yielded both ways and unloaded elastically in between.
    assert force.max() == pytest.approx(yield_force) and force.min() == pytest.approx(-yield_force)
    assert np.sum(np.isclose(np.abs(force), yield_force, rtol=1e-9)) > 20
    # Back at zero after yielding to -1.5 d_y: plastic offset -0.5 d_y, residual force +Fy/2.
    assert force[-1] == pytest.approx(0.5 * yield_force, rel=1e-5)


def test_real_adapter_through_the_bridge(site) -> None:
    stiffness = 2.0e5
    process = site('--model', 'elastic', '--stiffness', repr(stiffness))
    driver = OpenSeesAdapterDriver(HOST, process.port, 1, timeout=5.0, connect_timeout=20.0)
    bridge = ActuatorBridge(driver, SafetyLimits(max_displacement=0.1, max_increment=0.05,
                                                 max_force=1.0e6), ['x'])
    driver.open()
    for step, target in enumerate([0.0, 0.01, -0.02, 0.005]):
        reply = bridge.handle_command('t1', step, [target])
        assert reply is not None and reply.status is FeedbackStatus.OK, reply
        # The node lags the command by f/penalty (penalty 1e6 K): 1e-6 of the target.
        assert reply.measured_displacement == pytest.approx([target], rel=2e-6, abs=1e-12)
        assert reply.restoring_force == pytest.approx(
            [stiffness * reply.measured_displacement[0]], rel=1e-9, abs=1e-9)
    driver.close()
    status, _, err = process.finish()
    assert status == 0, err


def test_client_leaving_without_99_stops_the_site(site) -> None:
    process = site('--model', 'elastic', '--stiffness', '1e5', '--quiet')
    driver = OpenSeesAdapterDriver(HOST, process.port, 1, timeout=5.0, connect_timeout=20.0)
    driver.open()
    driver.command(0, [0.001])
    driver._drop()  # a crashed client: no 99
    status, _, err = process.finish(timeout=10.0)
    assert status == 1
    assert err.strip().splitlines()[-1] == (
        f'opensees_site: port {process.port}: the client closed the connection without '
        f'ending the test (99); OpenSees stopped')


def test_wrong_dof_count_is_refused_by_the_adapter(site) -> None:
    process = site('--model', 'elastic', '--stiffness', '1e5')
    driver = OpenSeesAdapterDriver(HOST, process.port, 2, timeout=5.0, connect_timeout=20.0)
    with pytest.raises(OpenSeesAdapterError, match=rf'^OpenSees adapter {HOST}:{process.port}: '
                       r'open: OpenSees (closed|reset) the connection'):
        driver.open()
    status, _, err = process.finish()
    assert status == 1
    assert 'wrong data sizes' in err
    assert err.strip().splitlines()[-1].startswith(f'opensees_site: port {process.port}: ')
