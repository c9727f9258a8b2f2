"""Run an OpenSees substructure behind an ``adapter`` element: the ``opensees_site`` executable.

The bridge's ``opensees_adapter`` driver
(:mod:`pd_actuator_bridge.core.drivers.opensees_adapter`) is the client; this executable is the
OpenSees side. It builds a model with openseespy, puts an ``adapter`` element on the DOF the
test drives and runs a static analysis one step at a time for as long as the client sends trial
displacements::

    opensees_site --port 44001 --model epp --stiffness 312559 --yield-force 10000

Models:

* ``epp``: a ``zeroLength`` element with ``uniaxialMaterial ElasticPP`` (``--stiffness`` K,
  ``--yield-force`` Fy, i.e. ``epsyP = Fy/K``) between a fixed node and a node with one free
  DOF, which the adapter serves — the same law as ``pd_specimen_sim``'s ``epp`` model.
* ``elastic``: the same with ``uniaxialMaterial Elastic`` (``--stiffness``).
* ``script``: ``--script FILE``, a Python file that builds any model with ``ops`` (the
  openseespy module, given as a global) and creates the adapter element itself on port
  ``port`` (a global too), e.g. ``ops.element('adapter', 9, '-node', 2, '-dof', 1, '-stif',
  1e12, port)``. The analysis below is then set up and run.

Analysis (how the adapter must be driven): ``constraints Plain``, ``numberer Plain``,
``system BandGeneral``, ``test NormDispIncr --tolerance 50``, ``algorithm Newton``,
``integrator LoadControl 1.0``, ``analysis Static``, then ``analyze(1)`` in a loop. Each step
advances the pseudo-time by 1, which makes the adapter read the next message; it connects
(accepts the client) inside the first step. The adapter's ``-stif`` (``--penalty``, default
1e6·K) is the penalty spring that pulls its node to the commanded displacement; the node
lags the command by force/penalty.

Process structure: this executable is a small supervisor. OpenSees runs in a child process
(this same file with ``--worker``) because the adapter ends the process with ``exit(-1)``
when the client sends 99 (status 255 even on success) and busy-waits forever on a client that
disconnects without 99. The supervisor

* starts the child with the bundled libraries of ``openseespylinux`` appended to
  ``LD_LIBRARY_PATH`` (its ``lib/`` holds libblas, libgfortran, libgomp, libquadmath; the
  extension finds most through its RUNPATH, but not libgfortran's libquadmath), so no manual
  step is needed;
* forwards OpenSees's output to stderr; the first stdout line is
  ``opensees_site: serving <model> on port <port>``;
* exits 0 when OpenSees reports that the client ended the test (99), or on SIGINT/SIGTERM;
  1 with a one-line error when OpenSees failed or the client disconnected without 99 (it
  watches the child's connection in ``/proc`` and stops it); 2 when openseespy is missing or
  the options are wrong.

The adapter element listens on all interfaces (OpenSees binds ``INADDR_ANY``); keep the port
behind the lab's firewall. No ``rclpy`` here.
"""

from __future__ import annotations

import argparse
import ctypes
import importlib.util
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from pd_common.signals import StopFlag, restore_handlers, stop_on_signals

PROG = 'opensees_site'
MODELS = ('epp', 'elastic', 'script')
COMPLETED_MARK = 'successfully completed'
"""What the adapter prints on stderr when it receives 99, just before ``exit(-1)``."""
PEER_GONE_STATES = {'07', '08'}
"""``/proc/net/tcp`` states of a connection whose client is gone: CLOSE, CLOSE_WAIT."""
GRACE = 1.0
"""Seconds the child may take to exit after its client closed the connection."""
POLL = 0.1


class SiteError(Exception):
    """A one-line reason why the site cannot run."""


# --------------------------------------------------------------------------- options


def _parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.split('\n', 1)[0])
    parser.add_argument('--port', type=int, required=True,
                        help="TCP port of the adapter element (its ipPort)")
    parser.add_argument('--model', choices=MODELS, default='epp', help='substructure model')
    parser.add_argument('--stiffness', type=float, help='K, N/m (epp, elastic)')
    parser.add_argument('--yield-force', type=float, help='Fy, N (epp)')
    parser.add_argument('--penalty', type=float,
                        help="adapter -stif, N/m (default 1e6*stiffness)")
    parser.add_argument('--script', help='model script (model script)')
    parser.add_argument('--tolerance', type=float, default=1e-12,
                        help='NormDispIncr tolerance, m (default 1e-12)')
    parser.add_argument('--quiet', action='store_true', help="do not forward OpenSees's output")
    parser.add_argument('--worker', action='store_true', help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    try:
        _check_args(args)
    except SiteError as exc:
        parser.exit(2, f'{PROG}: {exc}\n')
    return args


def _check_args(args: argparse.Namespace) -> None:
    if not 0 < args.port < 65536:
        msg = f'--port must be in 1..65535, got {args.port}'
        raise SiteError(msg)
    if args.model in ('epp', 'elastic'):
        if args.stiffness is None or not args.stiffness > 0:
            msg = f'--model {args.model} needs --stiffness > 0'
            raise SiteError(msg)
        if args.model == 'epp' and (args.yield_force is None or not args.yield_force > 0):
            msg = '--model epp needs --yield-force > 0'
            raise SiteError(msg)
        if args.penalty is None:
            args.penalty = 1.0e6 * args.stiffness
        if not args.penalty > 0:
            msg = f'--penalty must be > 0, got {args.penalty}'
            raise SiteError(msg)
    elif not args.script:
        msg = '--model script needs --script FILE'
        raise SiteError(msg)
    elif not Path(args.script).is_file():
        msg = f'--script {args.script}: no such file'
        raise SiteError(msg)
    if not args.tolerance > 0:
        msg = f'--tolerance must be > 0, got {args.tolerance}'
        raise SiteError(msg)


def _worker_argv(args: argparse.Namespace) -> list[str]:
    argv = ['--worker', '--port', str(args.port), '--model', args.model,
            '--tolerance', repr(args.tolerance)]
    for flag, value in (('--stiffness', args.stiffness), ('--yield-force', args.yield_force),
                        ('--penalty', args.penalty)):
        if value is not None:
            argv += [flag, repr(value)]
    if args.script:
        argv += ['--script', str(Path(args.script).resolve())]
    return argv


def describe(args: argparse.Namespace) -> str:
    """One-line description of the model."""
    if args.model == 'epp':
        return (f'epp (zeroLength, ElasticPP K={args.stiffness:g} N/m, Fy={args.yield_force:g} N, '
                f'penalty {args.penalty:g} N/m)')
    if args.model == 'elastic':
        return f'elastic (zeroLength, K={args.stiffness:g} N/m, penalty {args.penalty:g} N/m)'
    return f'script {args.script}'


# --------------------------------------------------------------------------- environment


def opensees_library_dir() -> Path | None:
    """The ``lib/`` folder bundled with ``openseespylinux``, if installed (not imported)."""
    spec = importlib.util.find_spec('openseespylinux')
    if spec is None or not spec.submodule_search_locations:
        return None
    lib = Path(next(iter(spec.submodule_search_locations))) / 'lib'
    return lib if lib.is_dir() else None


def opensees_environment(base: dict[str, str] | None = None) -> dict[str, str]:
    """Environment for a process that imports openseespy: ``LD_LIBRARY_PATH`` extended.

    The existing ``LD_LIBRARY_PATH`` (e.g. the ROS wheels' libraries) is kept in front; the
    bundled folder is appended once. DDS discovery stays on this host by default.
    """
    env = dict(os.environ if base is None else base)
    env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    lib = opensees_library_dir()
    if lib is not None:
        parts = [p for p in env.get('LD_LIBRARY_PATH', '').split(os.pathsep) if p]
        if str(lib) not in parts:
            parts.append(str(lib))
        env['LD_LIBRARY_PATH'] = os.pathsep.join(parts)
    return env


def require_openseespy() -> None:
    """Raise :class:`SiteError` if openseespy is not installed (checked without importing)."""
    if importlib.util.find_spec('openseespy') is None:
        msg = 'openseespy is not installed (pinned in requirements.txt; run ./pd setup)'
        raise SiteError(msg)


# --------------------------------------------------------------------------- worker (OpenSees)


def _build_model(ops: Any, args: argparse.Namespace) -> None:
    ops.wipe()
    if args.model == 'script':
        source = Path(args.script).read_text()
        exec(compile(source, args.script, 'exec'), {'ops': ops, 'port': args.port,
                                                    '__name__': '__opensees_site__'})
    else:
        ops.model('basic', '-ndm', 1, '-ndf', 1)
        ops.node(1, 0.0)
        ops.node(2, 0.0)
        ops.fix(1, 1)
        if args.model == 'epp':
            ops.uniaxialMaterial('ElasticPP', 1, args.stiffness,
                                 args.yield_force / args.stiffness)
        else:
            ops.uniaxialMaterial('Elastic', 1, args.stiffness)
        ops.element('zeroLength', 1, 1, 2, '-mat', 1, '-dir', 1)
        ops.element('adapter', 2, '-node', 2, '-dof', 1, '-stif', args.penalty, args.port)
    ops.constraints('Plain')
    ops.numberer('Plain')
    ops.system('BandGeneral')
    ops.test('NormDispIncr', args.tolerance, 50)
    ops.algorithm('Newton')
    ops.integrator('LoadControl', 1.0)
    ops.analysis('Static')


def run_worker(args: argparse.Namespace) -> int:
    """Build the model and analyse until the adapter ends the process (client sent 99)."""
    # Imported here, in the worker process only: openseespy is optional (exit 2 without it),
    # needs the LD_LIBRARY_PATH the supervisor gives the worker, and the adapter element exits
    # the process that runs the analysis, so the supervisor must never import it.
    try:
        import openseespy.opensees as ops  # noqa: PLC0415 - optional, worker only (see above)
    except Exception as exc:  # noqa: BLE001 - any import failure is reported the same way
        print(f'{PROG}: cannot import openseespy: {type(exc).__name__}: {exc}',
              file=sys.stderr, flush=True)
        return 2
    try:
        _build_model(ops, args)
    except Exception as exc:  # noqa: BLE001 - OpenSees raises plain exceptions
        print(f'{PROG}: building the model failed: {type(exc).__name__}: {exc}',
              file=sys.stderr, flush=True)
        return 1
    step = 0
    while True:
        status = ops.analyze(1)
        if status != 0:
            print(f'{PROG}: OpenSees analysis step {step + 1} failed (analyze returned '
                  f'{status}; wrong size ID or no convergence)', file=sys.stderr, flush=True)
            return 1
        step += 1


# --------------------------------------------------------------------------- supervisor


def _die_with_parent() -> None:  # pragma: no cover - runs in the child before exec
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except Exception:  # noqa: BLE001 - best effort (not Linux)
        pass


def client_gone(pid: int, port: int) -> bool:
    """Whether ``pid`` holds a connection on local ``port`` whose client has closed it.

    Reads ``/proc/<pid>/fd`` (socket inodes) and ``/proc/<pid>/net/tcp{,6}``; returns False
    where ``/proc`` is not available.
    """
    try:
        inodes = set()
        for fd in os.listdir(f'/proc/{pid}/fd'):
            try:
                target = os.readlink(f'/proc/{pid}/fd/{fd}')
            except OSError:
                continue
            if target.startswith('socket:['):
                inodes.add(target[8:-1])
        for table in ('tcp', 'tcp6'):
            try:
                lines = Path(f'/proc/{pid}/net/{table}').read_text().splitlines()[1:]
            except OSError:
                continue
            for line in lines:
                fields = line.split()
                if len(fields) < 10 or fields[9] not in inodes:
                    continue
                local_port = int(fields[1].rsplit(':', 1)[1], 16)
                remote_port = int(fields[2].rsplit(':', 1)[1], 16)
                if local_port == port and remote_port != 0 and fields[3] in PEER_GONE_STATES:
                    return True
    except OSError:
        return False
    return False


class _OutputForwarder(threading.Thread):
    """Forward the child's output to stderr and notice the adapter's completion message."""

    def __init__(self, stream: Iterable[str], quiet: bool) -> None:
        super().__init__(daemon=True)
        self._stream = stream
        self._quiet = quiet
        self.completed = False
        self.last_line = ''

    def run(self) -> None:
        for line in self._stream:
            text = line.rstrip()
            if COMPLETED_MARK in text:
                self.completed = True
            if text:
                self.last_line = text
            if not self._quiet:
                print(text, file=sys.stderr, flush=True)


def run_supervisor(args: argparse.Namespace) -> int:
    """Start OpenSees in a child process and supervise it (see the module docstring)."""
    try:
        require_openseespy()
    except SiteError as exc:
        print(f'{PROG}: {exc}', file=sys.stderr, flush=True)
        return 2
    command = [sys.executable, str(Path(__file__).resolve()), *_worker_argv(args)]
    child = subprocess.Popen(
        command, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        text=True, env=opensees_environment(), preexec_fn=_die_with_parent)
    assert child.stdout is not None  # stdout=PIPE
    forwarder = _OutputForwarder(child.stdout, args.quiet)
    forwarder.start()
    print(f'{PROG}: serving {describe(args)} on port {args.port}', flush=True)

    stop = StopFlag()
    previous = stop_on_signals(stop)
    gone_since: float | None = None
    reason = ''
    try:
        while child.poll() is None:
            if stop.is_set():
                break
            if client_gone(child.pid, args.port):
                gone_since = gone_since or time.monotonic()
                if time.monotonic() - gone_since > GRACE:
                    reason = (f'port {args.port}: the client closed the connection without '
                              f'ending the test (99); OpenSees stopped')
                    break
            time.sleep(POLL)
    finally:
        if child.poll() is None:
            child.kill()
        child.wait()
        forwarder.join(2.0)
        restore_handlers(previous)
    if stop.is_set():
        print(f'{PROG}: stopped on request', file=sys.stderr, flush=True)
        return 0
    if forwarder.completed:
        print(f'{PROG}: the client ended the test (99)', file=sys.stderr, flush=True)
        return 0
    if not reason:
        last = f': {forwarder.last_line}' if forwarder.last_line else ''
        reason = f'port {args.port}: OpenSees exited with status {child.returncode}{last}'
    print(f'{PROG}: {reason}', file=sys.stderr, flush=True)
    return 1


def main(args: Sequence[str] | None = None) -> int:
    """Entry point: the supervisor, or the OpenSees worker with ``--worker``."""
    options = _parse_args(args)
    return run_worker(options) if options.worker else run_supervisor(options)


if __name__ == '__main__':
    sys.exit(main())
