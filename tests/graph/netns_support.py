"""Multi-host ROS 2 tests on one machine: network namespaces that the test creates itself.

``NetnsHub`` creates N network namespaces in a hub topology: namespace 0 (the hub, e.g. the
"integrator") is joined by one veth pair to each other namespace (the "sites"). Link ``k``
(k = 1..N-1) is the private /30 ``10.251.k.0/30``: the hub end is ``10.251.k.1``, the site end
``10.251.k.2``. The veths are created directly inside the namespaces (``ip -n NS link add ...
netns OTHER``), so no interface ever appears in, and no address is ever added to, the host's
namespace; each namespace has ``lo`` up, its veth(s) and nothing else (no route off the box).
The hub forwards between its links (``net.ipv4.ip_forward=1`` inside the hub namespace only)
and every site routes ``10.251.0.0/16`` via the hub, so every address a participant announces
is reachable, as on a real routed test network.

Names are ``pdt<pid>x<n>-<name>`` (pid of the creating process, n a counter), so parallel
pytest-xdist workers never collide. At start, namespaces of that pattern whose creating process
is dead (a crashed or SIGKILLed earlier run) are removed, after killing what still runs in them.
Teardown (``__exit__``, also on failure or KeyboardInterrupt, and at interpreter exit as a last
resort) stops the processes started with ``popen`` (SIGINT to the process group, then SIGKILL),
kills whatever else still runs inside the namespaces, and deletes them (which destroys the veths).

DDS settings that work across the namespaces (ROS 2 Kilted, rmw_fastrtps_cpp 9.3.3,
Fast DDS 3.2.3 wheels), as set by ``NetnsHub.env``::

    ROS_DOMAIN_ID=<the test's domain>          (kept from the base environment)
    ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET
    ROS_STATIC_PEERS=<peers_for(name), ';'-separated>
                     (site k: 10.251.k.1; the hub: every 10.251.k.2)
    FASTDDS_BUILTIN_TRANSPORTS=UDPv4
    (ROS_LOCALHOST_ONLY removed)

Findings (this machine, 2 cores; tests/graph/test_netns.py prints the numbers of each run):

* ``SUBNET`` + ``ROS_STATIC_PEERS`` + ``FASTDDS_BUILTIN_TRANSPORTS=UDPv4`` (the default here):
  for SUBNET the rmw leaves the transports to Fast DDS, which honours the variable: UDPv4 only,
  no process maps a ``/dev/shm/fastdds_*`` segment, and every sample crosses the veths (their
  byte counters grow with the payload). The static peers (Fast DDS initial peers) make discovery
  independent of multicast; SUBNET's multicast (239.255.0.1) can only leave through the test's
  own veths: the host's interfaces are not in these namespaces.
* ``LOCALHOST`` + ``ROS_STATIC_PEERS`` discovers across the namespaces as well (per the rmw
  source: static peers and 127.0.0.1 become initial peers, multicast locators are dropped), **but**
  ``FASTDDS_BUILTIN_TRANSPORTS`` is ignored: for LOCALHOST rmw_fastrtps switches the built-in
  transports off and installs its own shared-memory + UDPv4 transports (the processes map
  ``fastdds_*`` segments). In these runs the data still crossed the veths, because Fast DDS
  only uses shared memory with participants of the "same host", and its host id (bytes 2-3 of
  the GUID prefix) is derived from the network addresses, which differ per namespace (observed
  ``b8e3``, ``8fb4``, ``fde6`` for the three namespaces). That is an implementation detail, so
  the harness does not rely on it; ``test_localhost_range_keeps_shared_memory`` pins the
  behaviour. Namespaces share ``/dev/shm``: without UDP-only a future Fast DDS could bypass the
  links.
* The kernel marks a new veth operationally UP up to ~1 s after both ends are set up and drops
  what is sent before; participants started in that window never matched (10 s; their traffic
  went to 127.0.0.1 instead: apparently no usable locator was announced). ``NetnsHub``
  therefore waits until every veth is UP (~1 s).
* The hub has one address per link and announces all of them; a site reaches the hub's other
  addresses over its own link (routes above), and Fast DDS sends each sample to every
  announced unicast locator, so a site's tx is about twice its payload. Sites only discover the
  hub (star); for site-to-site traffic pass ``extra_peers`` to ``env`` (routed by the hub).
* Discovery (node creation to the first ping answered by both sites, all three processes
  started together): 0.16-0.39 s. Median round trip hub -> both sites -> hub with 2 KiB
  Float64MultiArray, EventsExecutor spin_once loops: 0.46-1.23 ms (max 0.7-3.1 ms).

Everything else on the host (the pytest process) keeps ``ROS_AUTOMATIC_DISCOVERY_RANGE=
LOCALHOST``; the harness needs root and ``ip`` (iproute2) and raises ``NetnsUnavailable``
otherwise (the pytest fixture turns that into a skip with the reason).
"""

from __future__ import annotations

import atexit
import itertools
import json
import os
import re
import shutil
import signal
import subprocess
import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

ADDRESS_PREFIX = '10.251'
NAME_PATTERN = re.compile(r'^pdt(\d+)x\d+-')
HUB_LINK = 'v-hub'          # the site's end of its link (inside the site's namespace)
_COUNTER = itertools.count()
_LIVE: set[NetnsHub] = set()


class NetnsUnavailable(RuntimeError):
    """Network namespaces cannot be used here (not root, no iproute2, netns add refused)."""


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(['ip', *args], capture_output=True, text=True, timeout=30,
                            check=False)
    if check and result.returncode != 0:
        raise RuntimeError(f'ip {" ".join(args)} failed: {result.stderr.strip()}')
    return result


def _pid_alive(pid: int) -> bool:
    """True if ``pid`` runs (a zombie counts as dead)."""
    try:
        stat = (Path('/proc') / str(pid) / 'stat').read_text(encoding='utf-8')
    except OSError:
        return False
    return stat.rsplit(')', 1)[-1].split()[0] not in ('Z', 'X')


def list_namespaces() -> list[str]:
    """Names of the named network namespaces (``ip netns list``)."""
    result = _ip('netns', 'list', check=False)
    return [line.split()[0] for line in result.stdout.splitlines() if line.strip()]


def _kill_inside(namespace: str) -> None:
    """SIGKILL every process still running in ``namespace``."""
    result = _ip('netns', 'pids', namespace, check=False)
    for token in result.stdout.split():
        try:
            os.kill(int(token), signal.SIGKILL)
        except (ValueError, ProcessLookupError):
            pass


def _delete(namespace: str) -> None:
    _kill_inside(namespace)
    _ip('netns', 'del', namespace, check=False)


def clean_stale() -> list[str]:
    """Delete ``pdt<pid>x<n>-*`` namespaces whose creating process is gone; return their names."""
    removed = []
    for namespace in list_namespaces():
        match = NAME_PATTERN.match(namespace)
        if match and not _pid_alive(int(match.group(1))):
            _delete(namespace)
            removed.append(namespace)
    return removed


def check_available() -> None:
    """Raise ``NetnsUnavailable`` with the reason if this process cannot create namespaces."""
    if os.geteuid() != 0:
        raise NetnsUnavailable('network namespace tests need root (ip netns add)')
    if shutil.which('ip') is None:
        raise NetnsUnavailable("'ip' (iproute2) is not installed: run scripts/setup.sh or "
                               'install iproute2')


class NetnsHub:
    """N network namespaces: ``names[0]`` is the hub, one veth pair to each other name.

    Use as a context manager::

        with NetnsHub(['integrator', 'site_a', 'site_b']) as ns:
            env = ns.env('site_a', base_env)
            process = ns.popen('site_a', [sys.executable, 'node.py'], env)
            ...
            ns.link_bytes('site_a')  # {'rx': ..., 'tx': ...}
    """

    def __init__(self, names: Sequence[str], *, discovery_range: str = 'SUBNET',
                 transports: str | None = 'UDPv4') -> None:
        if len(names) < 2 or len(set(names)) != len(names):
            raise ValueError('give at least two distinct names (the hub first)')
        if len(names) > 254:
            raise ValueError('at most 253 sites')
        for name in names:
            if not re.fullmatch(r'[A-Za-z0-9_]{1,40}', name):
                raise ValueError(f'bad namespace name {name!r} (letters, digits, _)')
        self.names = list(names)
        self.hub = self.names[0]
        self.discovery_range = discovery_range
        self.transports = transports
        self.prefix = f'pdt{os.getpid()}x{next(_COUNTER)}'
        self.created: list[str] = []
        self.started: list[subprocess.Popen[Any]] = []
        self.removed_stale: list[str] = []

    # ------------------------------------------------------------------ set-up / teardown
    def namespace(self, name: str) -> str:
        """The system name of the namespace ``name`` (for ``ip netns exec``)."""
        self._index(name)
        return f'{self.prefix}-{name}'

    def _index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f'no namespace {name!r} in {self.names}') from None

    @staticmethod
    def link_name(site_index: int) -> str:
        """The hub's end of the link to site ``site_index`` (1-based)."""
        return f'v-s{site_index}'

    def __enter__(self) -> NetnsHub:
        check_available()
        self.removed_stale = clean_stale()
        _LIVE.add(self)
        try:
            self._create()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _create(self) -> None:
        for name in self.names:
            namespace = f'{self.prefix}-{name}'
            result = _ip('netns', 'add', namespace, check=False)
            if result.returncode != 0:
                raise NetnsUnavailable(f'ip netns add {namespace} failed: '
                                       f'{result.stderr.strip()}')
            self.created.append(namespace)
            _ip('-n', namespace, 'link', 'set', 'lo', 'up')
        hub = self.namespace(self.hub)
        for k, name in enumerate(self.names[1:], start=1):
            site = self.namespace(name)
            link = self.link_name(k)
            # Both ends are created inside the test's namespaces: nothing in the host's.
            _ip('-n', hub, 'link', 'add', link, 'type', 'veth',
                'peer', 'name', HUB_LINK, 'netns', site)
            _ip('-n', hub, 'addr', 'add', f'{ADDRESS_PREFIX}.{k}.1/30', 'dev', link)
            _ip('-n', site, 'addr', 'add', f'{ADDRESS_PREFIX}.{k}.2/30', 'dev', HUB_LINK)
            _ip('-n', hub, 'link', 'set', link, 'up')
            _ip('-n', site, 'link', 'set', HUB_LINK, 'up')
            _ip('-n', site, 'route', 'add', f'{ADDRESS_PREFIX}.0.0/16',
                'via', f'{ADDRESS_PREFIX}.{k}.1')
        # Forwarding between the hub's links (site to site), in the hub's namespace only:
        # /proc/sys/net is per network namespace.
        subprocess.run(['ip', 'netns', 'exec', hub, 'sh', '-c',
                        'echo 1 > /proc/sys/net/ipv4/ip_forward'],
                       capture_output=True, check=False, timeout=30)
        self._wait_links_up()

    def _wait_links_up(self, timeout: float = 5.0) -> None:
        """Wait until every veth's operstate is UP.

        The kernel's link watcher marks a new veth UP (and gives it its real queueing
        discipline) up to ~1 s after both ends are set up; until then it drops what is sent.
        Fast DDS participants started in that window never matched (10 s), so nothing may
        start before the links are up.
        """
        deadline = time.monotonic() + timeout
        while True:
            down = [f'{name}:{link}' for name in self.names
                    for link, state in self._link_states(name).items()
                    if link in self.link_names(name) and state != 'UP']
            if not down:
                return
            if time.monotonic() > deadline:
                raise RuntimeError(f'veth links not UP after {timeout} s: {down}')
            time.sleep(0.02)

    def _link_states(self, name: str) -> dict[str, str]:
        result = _ip('-n', self.namespace(name), '-j', 'link', 'show')
        return {link['ifname']: link.get('operstate', '') for link in json.loads(result.stdout)}

    def close(self) -> None:
        """Stop the started processes and delete the namespaces (idempotent)."""
        try:
            self.stop_all()
        finally:
            for namespace in reversed(self.created):
                _delete(namespace)
            self.created.clear()
            _LIVE.discard(self)

    def stop_all(self, timeout: float = 5.0) -> None:
        """SIGINT every process group started here, then SIGKILL what is left."""
        for process in reversed(self.started):
            if process.poll() is None:
                _signal_group(process, signal.SIGINT)
        deadline = time.monotonic() + timeout
        for process in self.started:
            try:
                process.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                _signal_group(process, signal.SIGKILL)
                process.wait()

    # ------------------------------------------------------------------ addressing / env
    def address(self, name: str, toward: str | None = None) -> str:
        """IPv4 address of ``name``: a site's only address; the hub's on the link ``toward``
        a site (default: its link to the first site)."""
        index = self._index(name)
        if index > 0:
            return f'{ADDRESS_PREFIX}.{index}.2'
        site = self._index(toward) if toward is not None else 1
        if site == 0:
            raise ValueError('toward must name a site')
        return f'{ADDRESS_PREFIX}.{site}.1'

    def peers_for(self, name: str) -> list[str]:
        """Static DDS peers of ``name``: a site → the hub's end of its link; the hub → every
        site."""
        index = self._index(name)
        if index > 0:
            return [f'{ADDRESS_PREFIX}.{index}.1']
        return [self.address(site) for site in self.names[1:]]

    def env(self, name: str, base_env: dict[str, str],
            extra_peers: Iterable[str] = ()) -> dict[str, str]:
        """Environment for a ROS process in ``name``: ``base_env`` (ROS_DOMAIN_ID kept) plus
        discovery range, static peers and the UDP-only transport."""
        env = dict(base_env)
        env.pop('ROS_LOCALHOST_ONLY', None)
        env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = self.discovery_range
        env['ROS_STATIC_PEERS'] = ';'.join([*self.peers_for(name), *extra_peers])
        if self.transports is None:
            env.pop('FASTDDS_BUILTIN_TRANSPORTS', None)
        else:
            env['FASTDDS_BUILTIN_TRANSPORTS'] = self.transports
        env.setdefault('HOME', str(Path(__file__).resolve().parents[2]))
        return env

    # ------------------------------------------------------------------ processes
    def command(self, name: str, argv: Sequence[str]) -> list[str]:
        """``argv`` prefixed to run inside ``name`` (``ip netns exec`` execs it: same pid)."""
        return ['ip', 'netns', 'exec', self.namespace(name), *argv]

    def popen(self, name: str, argv: Sequence[str], env: dict[str, str],
              **kw: Any) -> subprocess.Popen[Any]:
        """Start ``argv`` inside ``name`` in its own session; stopped at teardown."""
        if not self.created:
            raise RuntimeError('namespaces not created (use NetnsHub as a context manager)')
        kw.setdefault('start_new_session', True)
        process = subprocess.Popen(self.command(name, argv), env=env, **kw)
        self.started.append(process)
        return process

    # ------------------------------------------------------------------ measurements
    def link_names(self, name: str) -> list[str]:
        """The veth(s) of ``name`` (hub: one per site)."""
        index = self._index(name)
        if index > 0:
            return [HUB_LINK]
        return [self.link_name(k) for k in range(1, len(self.names))]

    def link_bytes(self, name: str) -> dict[str, int]:
        """Bytes received/sent through the veth(s) of ``name`` so far: ``{'rx', 'tx'}``."""
        result = _ip('-n', self.namespace(name), '-j', '-s', 'link', 'show')
        totals = {'rx': 0, 'tx': 0}
        wanted = set(self.link_names(name))
        for link in json.loads(result.stdout):
            if link.get('ifname') in wanted:
                stats = link['stats64']
                totals['rx'] += int(stats['rx']['bytes'])
                totals['tx'] += int(stats['tx']['bytes'])
        return totals


def _signal_group(process: subprocess.Popen[Any], sig: int) -> None:
    try:
        os.killpg(process.pid, sig)
    except ProcessLookupError:
        pass


def shm_mappings(pid: int) -> set[str]:
    """Fast DDS shared-memory files (``/dev/shm/fastdds_*``) that process ``pid`` has mapped or
    open: empty for a UDP-only participant."""
    found: set[str] = set()
    proc = Path('/proc') / str(pid)
    try:
        for line in (proc / 'maps').read_text(encoding='utf-8', errors='replace').splitlines():
            if '/dev/shm/' in line and 'fastdds' in line:
                found.add(line.rsplit('/', 1)[-1].split(' ')[0])
        for fd in (proc / 'fd').iterdir():
            try:
                target = os.readlink(fd)
            except OSError:
                continue
            if target.startswith('/dev/shm/') and 'fastdds' in target:
                found.add(target.rsplit('/', 1)[-1])
    except OSError:
        pass
    return found


@atexit.register
def _close_all() -> None:
    for hub in list(_LIVE):
        hub.close()
