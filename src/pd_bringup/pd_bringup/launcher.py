"""Run a complete test through the node graph: ``ros2 run pd_bringup run_test [TEST_FILE]``.

Starts each node as its own process, exactly as ``ros2 run`` would (see :mod:`.plan`):

* ``--site bridge`` (default): integrator → ``pd_actuator_bridge`` (namespace ``/pd``, with its
  own limits) → ``pd_specimen_sim`` (namespace ``/pd/specimen``);
* ``--site direct``: integrator → ``pd_specimen_sim`` (namespace ``/pd``), no bridge;
* ``--site none``: only the integrator; the specimen side (e.g. the physical specimen's bridge)
  is started elsewhere.

A substructured test (experimental elements at named sites) gets one bridge and one simulator
per site, each in the site's namespace ``/pd/<site>`` (the simulator in ``/pd/<site>/specimen``
behind the bridge); a site's ``sites.<site>.bridge`` mapping of the test file overrides bridge
parameters (e.g. its limits) for that site only. A site with an ``opensees`` mapping
(``{model: epp|elastic, stiffness, yield_force, penalty}`` or ``{script: FILE}``) is an OpenSees
substructure instead: ``opensees_site`` runs it behind an ``adapter`` element on a free local
port and the site's bridge drives it with the ``opensees_adapter`` driver (with ``--site
direct`` too: the adapter's client is the bridge). ``--faults PLAN`` puts a fault proxy
(:mod:`.fault_proxy`) between the integrator and each site's step receiver (the receiver's step
topics moved to ``<namespace>/behind``); its counters end up in ``summary.json`` (``faults``).

Everything that can be checked is checked before any process starts (the test, its specimen
sections, stability, the key, the run folder). The plan is written to ``launch.json`` in the run
folder; the processes are supervised (:mod:`.supervisor`: a death holds the test and, by
default for a simulated specimen, the process is restarted with its state and the test
resumed); ``--resume RUN_DIR`` continues a stopped run from its record. Once the integrator
has written its ``summary.json`` the other nodes are stopped and the summary is printed while
it still writes its figures; ``run_test`` exits when the integrator has. DDS discovery stays on
this host unless ``ROS_AUTOMATIC_DISCOVERY_RANGE`` is already set; every process gets the
shipped Fast DDS profile (:mod:`pd_common.dds`: announcements every 100 ms for the first 5 s,
so processes started together meet at once, then every 250 ms, so a tool started later finds
them in a fraction of a second) unless the user selected one already
(``FASTDDS_DEFAULT_PROFILES_FILE``, a ``DEFAULT_FASTDDS_PROFILES.xml`` in the working directory).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import sys
from pathlib import Path
from typing import Any, NoReturn

import rclpy
from rclpy.signals import SignalHandlerOptions

from pd_common.auth import KEY_FILE_ENV, AuthError, Key, load_key
from pd_common.config import TestFile
from pd_common.dds import DDS_PROFILE_VARIABLES, discovery_profile
from pd_common.resources import ResourceError, find_executable
from pd_common.ros import events_executor, exit_process
from pd_common.signals import StopFlag, restore_handlers, stop_on_signals
from pd_common.specimen import SpecimenError, SpecimenServer, load_site_server
from pd_common.units import format_quantity
from pd_core.errors import ConfigError, PdIntegratorError
from pd_core.run.definition import TestDefinition
from pd_core.run.loop.session import TestSession
from pd_core.run.record.journal import JOURNAL_FILE
from pd_core.run.resume import load_resumable
from pd_core.run.runner import BAG_DIRECTORY, check_new_run_folder, default_run_directory
from pd_core.run.test_file import (
    PARAMETER_PATHS,
    RUN_PARAMETERS,
    default_test_file,
    parse_overrides,
    read_definition,
    run_parameter,
)

from .operator import Operator
from .plan import (
    LAUNCH_FILE,
    LaunchError,
    LaunchPlan,
    attach_fault_reports,
    attach_realtime_reports,
    insert_fault_proxies,
    parse_cpus,
    site_commands,
    with_key,
)
from .rig import RigError, RigSettings, default_rig_key, load_rig, test_key_path
from .supervisor import HUNG_TIMEOUT, POLICIES, Supervisor, recorded_processes

#: run_test's own output once its terminal is gone (SIGHUP), in the run folder.
LOG_FILE = 'run_test.log'

__all__ = ['LaunchError', 'main', 'resolve_key']


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """Command-line arguments."""
    parser = argparse.ArgumentParser(
        prog='run_test', description='Run a pseudo-dynamic test through the ROS 2 node graph.')
    parser.add_argument('test_file', nargs='?', help='YAML test file (default: the thesis '
                        'section 5.1 test, config/default_test.yaml)')
    parser.add_argument('--site', choices=('bridge', 'direct', 'none'), default='bridge',
                        help='specimen side to start (default: bridge -> simulated specimen)')
    parser.add_argument('--out', help='run folder (default: runs/<test_id>-<UTC time>)')
    parser.add_argument('--bridge-params', help='ROS parameter file of the actuator bridge '
                        '(default: share/pd_actuator_bridge/config/bridge.yaml)')
    parser.add_argument('--param', '-p', action='append', default=[], metavar='NAME:=VALUE',
                        help='integrator parameter override, e.g. -p scale_factor:=0.5')
    parser.add_argument('--no-figures', action='store_true', help='skip the PNG figures')
    parser.add_argument('--key', help='key file of the rig or test, handed to every node '
                        '(default: rig.key_file; for a simulated test a new key per test; '
                        'for --site none the rig key of ./pd keygen)')
    parser.add_argument('--rig', help='rig file: domain_id, discovery, static_peers, key_file')
    parser.add_argument('--no-authentication', action='store_true',
                        help='run every node without a key (an isolated machine only)')
    parser.add_argument('--resume', metavar='RUN_DIR', help='continue a stopped run (its '
                        'launch.json, journal and specimen state files) from its last '
                        'committed step')
    parser.add_argument('--confirm', action='store_true', help='with --resume and a physical '
                        'specimen: move without waiting for ./pd control resume')
    parser.add_argument('--on-child-exit', choices=POLICIES, default=None,
                        help='when a process of the test dies: restart it with its state and '
                        'resume (default for a simulated specimen), hold the test (default for '
                        'a physical one), or abort')
    parser.add_argument('--faults', metavar='PLAN', help='put a fault proxy between the '
                        'integrator and each site\'s step receiver, e.g. drop=0.1,duplicate=0.1,'
                        'delay=0.1,reorder=0.1,delay_s=0.05,seed=1 (its counters go to '
                        'faults.json and summary.json: faults)')
    parser.add_argument('--max-restarts', type=int, default=3, metavar='N',
                        help='restarts of one process before the test is left holding '
                        '(default 3)')
    parser.add_argument('--hung-timeout', type=float, default=HUNG_TIMEOUT, metavar='S',
                        help='seconds a live node may say nothing (no status, no session offer)'
                        f' before it is reported as hung and the test held (default '
                        f'{HUNG_TIMEOUT:g}; 0: off)')
    parser.add_argument('--cpus', action='append', default=[], metavar='KIND=CPUS',
                        help='run the processes of a kind (integrator, bridge, simulator, '
                        'opensees, proxy) on these CPUs (0, 0,2, 1-3); repeatable. E.g. a '
                        'real-time test: --cpus integrator=0 --cpus bridge=1 (recorded: '
                        '--resume places them again)')
    return parser.parse_args(argv)


def resolve_key(args: argparse.Namespace, rig: RigSettings, test_id: str) -> Path | None:
    """The key file every node gets (checked), or ``None`` without authentication.

    Raises:
        LaunchError: no usable key file.
    """
    if args.no_authentication:
        return None
    if args.key:
        path = Path(args.key).expanduser()
    elif rig.key_file is not None:
        path = rig.key_file
    elif os.environ.get(KEY_FILE_ENV):
        path = Path(os.environ[KEY_FILE_ENV]).expanduser()
    elif args.site == 'none':  # a physical specimen side: the rig's own key
        path = default_rig_key()
        if not path.exists():
            msg = (f'--site none: no key file given and no rig key at {path} (make one with '
                   './pd keygen and give it to every node of the rig, or pass --key)')
            raise LaunchError(msg)
    else:  # everything is simulated here: a key of this test only
        try:
            path = test_key_path(test_id)
        except AuthError as err:
            raise LaunchError(str(err)) from None
    try:
        load_key(path)  # refuse a missing, malformed or group/world-readable key now
    except AuthError as err:
        raise LaunchError(str(err)) from None
    return path.resolve()


def check_run_folder(out: Path) -> None:
    """Refuse a folder that holds a run already, or anything else (before any process starts).

    Raises:
        LaunchError: it holds a journal, a bag, a launch plan or a specimen state file (the
            resume hint), or other files, or it is a file.
    """
    held = [name for name in (JOURNAL_FILE, BAG_DIRECTORY, LAUNCH_FILE) if (out / name).exists()]
    held += sorted(path.name for path in out.glob('specimen*.state.jsonl')) if out.is_dir() else []
    if held:
        msg = (f'--out {out}: already holds a run ({", ".join(held)}); choose a new folder, '
               f'or continue it: ./pd run --resume {out}')
        raise LaunchError(msg)
    try:
        check_new_run_folder(out)
    except ConfigError as err:
        msg = f'--out {err}'
        raise LaunchError(msg) from None


def check_specimens(plan: LaunchPlan, test_file: Path | TestFile
                    ) -> dict[str, SpecimenServer]:
    """Build every simulated specimen as its simulator will, before anything starts.

    Build every simulated specimen as its simulator will (a bad section is one line now,
    before anything starts); the specimens per site.

    Raises:
        LaunchError: a specimen section or one of its files is invalid.
    """
    servers = {}
    for child in plan.children:
        if child.kind != 'simulator':
            continue
        try:
            servers[child.site], _, _ = load_site_server(test_file, child.site,
                                                         child.dof_names or None)
        except SpecimenError as err:
            raise LaunchError(str(err)) from None
    return servers


def plan_new_run(args: argparse.Namespace) -> tuple[LaunchPlan, TestDefinition, RigSettings]:
    """The plan of a new run, every input checked.

    Raises:
        PdIntegratorError, ResourceError, RigError: one line naming the file and the key.
    """
    test_file = Path(args.test_file) if args.test_file else default_test_file()
    overrides = parse_overrides(args.param)
    # The integrator's own parameters (not the test's): checked here, passed on as seconds.
    run_values = {name: run_parameter(name, overrides.pop(name))
                  for name in list(overrides) if name in RUN_PARAMETERS}
    for name in overrides:
        if name not in PARAMETER_PATHS:
            msg = (f'--param {name}: not a parameter ./pd run takes (the test\'s: '
                   f'{", ".join(PARAMETER_PATHS)}; the integrator\'s: '
                   f'{", ".join(RUN_PARAMETERS)})')
            raise LaunchError(msg)
    # Read once, fail early, before any process:
    definition, document = read_definition(test_file, overrides)
    if not definition.needs_probe:
        TestSession(definition)  # refuses an unstable test (omega*dt above the limit)
    out = Path(args.out) if args.out else default_run_directory('runs', definition.test_id)
    check_run_folder(out)
    integrator = [str(find_executable('pd_integrator')), '--ros-args',
                  '-p', f'test_file:={test_file.resolve()}',
                  '-p', f'output_dir:={out.resolve()}',
                  '-p', f'figures:={"false" if args.no_figures else "true"}']
    for item in args.param:
        if item.partition(':=')[0] not in run_values:
            integrator += ['-p', item]
    for name, seconds in run_values.items():  # (a double parameter: 1 would be an integer)
        integrator += ['-p', f'{name}:={seconds!r}']
    children, physical = site_commands(
        definition, test_file.resolve(), args.site,
        Path(args.bridge_params) if args.bridge_params else None, out)
    rig = load_rig(document.model.rig, test_file,
                   Path(args.rig) if args.rig else None)
    key_file = resolve_key(args, rig, definition.test_id)
    for child in children:
        child.command = with_key(child.command, key_file)
    if args.faults:  # after the keys: the proxy holds none
        children = insert_fault_proxies(children, args.faults, out)
    plan = LaunchPlan(test_id=definition.test_id, n_steps=definition.n_steps, out=out,
                      site_mode=args.site, physical=physical, key_file=key_file,
                      environment=rig.environment({}), children=children,
                      integrator=with_key(integrator, key_file), figures=not args.no_figures,
                      cpus=parse_cpus(args.cpus))
    servers = check_specimens(plan, document)
    if definition.needs_probe:
        check_probe(plan, definition, test_file, servers)
    return plan, definition, rig


def check_probe(plan: LaunchPlan, definition: TestDefinition, test_file: Path,
                servers: dict[str, SpecimenServer]) -> None:
    """A probed stiffness is known only after the probe has moved the specimen.

    Check the stability limit now with the simulated specimen's own initial stiffness, or say how
    far the probe moves a physical one.

    Raises:
        LaunchError: the simulated specimen's stiffness makes the test unstable.
    """
    amplitude = definition.probe.amplitude
    if definition.model is None and '' in servers and not plan.physical:
        stiffness = servers[''].specimen.initial_stiffness_matrix()
        try:
            TestSession(definition.with_initial_stiffness(stiffness))
        except PdIntegratorError as err:
            msg = (f'{test_file.name}: structure.initial_stiffness: probe: with the simulated '
                   f"specimen's initial stiffness the test is unstable, refused before the "
                   f'probe moves: {err}')
            raise LaunchError(msg) from None
        return
    print(f'run_test: the stiffness probe pushes each DOF by {amplitude:g} m and back before '
          'the test; the stability limit is checked on the measured stiffness (an unstable dt '
          'aborts the test before its first step)', file=sys.stderr)


def plan_resumed_run(args: argparse.Namespace) -> LaunchPlan:
    """The plan of the run to continue, checked.

    Raises:
        PdIntegratorError: not a resumable run folder, or options that do not go with it.
    """
    if args.test_file or args.out or args.param or args.bridge_params or args.faults:
        msg = ('--resume: takes no test file, --out, --param, --bridge-params or --faults (the '
               'run folder has them)')
        raise LaunchError(msg)
    run_dir = Path(args.resume)
    plan = LaunchPlan.load(run_dir)
    try:
        load_resumable(run_dir)
    except PdIntegratorError as err:
        msg = f'--resume: {err}'
        raise LaunchError(msg) from None
    if plan.key_file is not None:
        try:
            load_key(plan.key_file)
        except AuthError as err:
            raise LaunchError(str(err)) from None
    if args.cpus:  # placed anew
        plan.cpus = parse_cpus(args.cpus)
    else:  # as recorded, if this machine has those CPUs
        try:
            parse_cpus([f'{kind}={",".join(map(str, cpus))}' for kind, cpus in plan.cpus.items()])
        except LaunchError as err:
            msg = (f'{run_dir / LAUNCH_FILE}: {str(err).removeprefix("--cpus ")} (place them '
                   'anew with --cpus)')
            raise LaunchError(msg) from None
    return plan


def print_summary(out: Path) -> None:
    """The run's peaks and state, from its summary.json (if written)."""
    path = out / 'summary.json'
    if not path.is_file():
        print(f'run_test: no summary.json in {out} (the integrator did not finish its outputs;'
              f' ./pd recover {out} rebuilds them from the journal)')
        return
    try:
        data = json.loads(path.read_text(encoding='utf-8'))
    except ValueError as err:
        print(f'run_test: {path}: unreadable ({err})')
        return
    committed = data.get('steps')
    for dof, values in (data.get('dofs') or {}).items() if committed else ():
        peaks = values.get('peaks') or {}
        peak = peaks.get('displacement') or {}
        force = peaks.get('restoring_force') or {}
        print(f'run_test: {dof}: peak displacement {format_quantity(peak.get("value"), "m")} '
              f'at {_number(peak.get("time"), ".2f")} s, peak force '
              f'{format_quantity(force.get("value"), "N")}, residual '
              f'{format_quantity(values.get("residual_displacement"), "m")}')
    if collapse := data.get('collapse'):
        print(f'run_test: {collapse.get("message")}')
    extra = _continuations(data)
    reason = f' ({data["message"]})' if not committed and data.get('message') else ''
    print(f'run_test: {data.get("state")}{reason}: {committed} steps in '
          f'{_number(data.get("wall_time"), ".2f")} s{extra}; outputs in {out}')


def _continuations(summary: dict[str, Any]) -> str:
    """``, 1 restart(s), 1 resume(s)``: the processes run_test restarted, the person's resumes.

    From the summary's ``restarts`` and ``resumes`` (counted of the run's events:
    :func:`pd_core.run.record.continuations.count_continuations`).
    """
    restarts, resumes = summary.get('restarts'), summary.get('resumes')
    return (f', {restarts} restart(s)' if restarts else '') + (
        f', {resumes} resume(s)' if resumes else '')


def _report_faults(plan: LaunchPlan) -> None:
    """The fault proxies' counters into summary.json, and one line of them."""
    try:
        faults = attach_fault_reports(plan)
    except LaunchError as err:
        print(f'run_test: {err}', file=sys.stderr)
        return
    if faults is not None:
        totals = faults['totals']
        print(f'run_test: faults ({faults["plan"]}): {totals["received"]} step messages, '
              f'{totals["dropped"]} dropped, {totals["duplicated"]} duplicated, '
              f'{totals["delayed"]} delayed, {totals["reordered"]} reordered', flush=True)


def _report_realtime(plan: LaunchPlan) -> None:
    """The continuous sites' wall-clock statistics into summary.json, one line per site."""
    try:
        block = attach_realtime_reports(plan)
    except LaunchError as err:
        print(f'run_test: {err}', file=sys.stderr)
        return
    for site, stats in (block or {}).items():
        if 'error' in stats:
            print(f'run_test: {site}: {stats["error"]}', file=sys.stderr)
            continue
        print(f'run_test: {site} in real time: {stats.get("ticks")} ticks, '
              f'{stats.get("missed_deadlines")} missed deadlines, slowed '
              f'{100.0 * float(stats.get("slowdown_fraction") or 0.0):.1f} % of the ticks, '
              f'step p99 {_number(stats.get("step_p99_ms"), ".2f")} ms, target latency p99 '
              f'{_number(stats.get("target_latency_p99_us"), ".0f")} µs'
              f'{_wake_ups(stats)}', flush=True)


def _wake_ups(stats: dict[str, Any]) -> str:
    """How the CPUs' wake-up latency was held while the site ticked (pd_common.rths)."""
    if stats.get('cpu_latency_held'):
        return ', idle CPUs kept awake'
    note = stats.get('cpu_latency_note')
    return f', idle CPUs not kept awake ({note})' if note else ''


def _number(value: Any, spec: str) -> str:
    """``value`` formatted, or ``n/a`` (no committed step: no peak)."""
    if isinstance(value, (int, float)) and math.isfinite(value):
        return format(value, spec)
    return 'n/a'


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``ros2 run pd_bringup run_test``."""
    args = parse_args(argv)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    try:
        if args.max_restarts < 0:
            msg = f'--max-restarts: must be 0 or more, got {args.max_restarts}'
            raise LaunchError(msg)
        if not math.isfinite(args.hung_timeout) or args.hung_timeout < 0.0:
            msg = (f'--hung-timeout: must be 0 (off) or a number of seconds, got '
                   f'{args.hung_timeout}')
            raise LaunchError(msg)
        if args.resume:
            plan = plan_resumed_run(args)
        else:
            if args.confirm:
                msg = '--confirm: only with --resume'
                raise LaunchError(msg)
            plan, definition, _ = plan_new_run(args)
            plan.save()  # the run folder can be written: before a line says it is there
            for warning in definition.warnings:
                print(f'run_test: warning: {warning}', file=sys.stderr)
    except (PdIntegratorError, ResourceError, RigError, SpecimenError) as err:
        print(f'run_test: error: {err}', file=sys.stderr)
        return 2
    recorded = recorded_processes(plan.out).get('policy') if args.resume else None
    policy = args.on_child_exit or (recorded if recorded in POLICIES else None) or (
        'hold' if plan.physical else 'restart')
    env = {**os.environ, **plan.environment}
    env.update(discovery_profile(env))  # every process, the launcher's own node too
    key = load_key(plan.key_file) if plan.key_file is not None else None
    if key is not None:
        print(f'run_test: key {plan.key_file} (id {key.key_id})', flush=True)
    if 'ROS_DOMAIN_ID' in plan.environment:
        print(f'run_test: rig ROS_DOMAIN_ID={plan.environment["ROS_DOMAIN_ID"]}, discovery '
              f'{plan.environment.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").lower()}',
              flush=True)
    verb = 'resuming' if args.resume else 'run folder:'
    print(f'run_test: {plan.test_id} ({plan.n_steps} steps), site: {plan.site_mode}, '
          f'{verb} {plan.out}; on child exit: {policy}', flush=True)
    return _supervise(plan, policy, env, key, args)


def _supervise(plan: LaunchPlan, policy: str, env: dict[str, str], key: Key | None,
               args: argparse.Namespace) -> int:
    """Start the processes, supervise them until the integrator ends, stop everything."""
    stop = StopFlag()
    previous = stop_on_signals(stop)
    previous[signal.SIGHUP] = signal.signal(signal.SIGHUP, _on_hangup(plan.out / LOG_FILE))
    ros = _OperatorNode(env, key)
    reported: list[bool] = []

    def report() -> None:  # once the specimen side is stopped; the figures may still be due
        if not reported:
            reported.append(True)
            _report_faults(plan)
            _report_realtime(plan)
            print_summary(plan.out)
            sys.stdout.flush()
            ros.close()  # the test has ended: no control to send (its exit overlaps theirs)

    supervisor = Supervisor(plan, policy, env, ros.operator, ros.spin_checked(stop),
                            max_restarts=args.max_restarts,
                            log=lambda line: print(line, file=sys.stderr, flush=True),
                            on_outputs=report, hung_timeout=args.hung_timeout)
    code = 1
    try:
        supervisor.start(resume=bool(args.resume), confirm=args.confirm,
                         note='resumed by ./pd run --resume' if args.resume else '')
        code = supervisor.run()
    except _InterruptedError:
        print('run_test: interrupted; stopping the integrator first (the run stays '
              f'resumable: ./pd run --resume {plan.out})', file=sys.stderr)
    finally:
        supervisor.stop()
        ros.close()
        restore_handlers(previous)
    report()
    return code


class _InterruptedError(Exception):
    """The launcher got SIGINT or SIGTERM."""


def _on_hangup(log_file: Path) -> Any:
    """The SIGHUP handler: the terminal is gone (closed, an SSH link dropped), the test is not.

    run_test's output goes on in ``log_file`` (the nodes it started are in sessions of their own:
    the hang-up does not reach them).
    """
    def handler(number: int, frame: Any) -> None:
        try:
            descriptor = os.open(log_file, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
        except OSError:
            descriptor = os.open(os.devnull, os.O_WRONLY)
        os.dup2(descriptor, 1)
        os.dup2(descriptor, 2)
        os.close(descriptor)
        print(f'run_test: the terminal hung up (SIGHUP); the test goes on (its output: '
              f'{log_file})', file=sys.stderr, flush=True)

    return handler


class _OperatorNode:
    """The launcher's own rclpy node (its signed controls), in the test's domain."""

    def __init__(self, env: dict[str, str], key: Key | None) -> None:
        for name in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_STATIC_PEERS',
                     *DDS_PROFILE_VARIABLES):
            if name in env:
                os.environ[name] = env[name]
        rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node('run_test', namespace='pd')
        self.executor = events_executor(self.node)
        self.operator = Operator(self.node, key)
        self.closed = False

    def spin_checked(self, stop: StopFlag) -> Any:
        def spin(seconds: float) -> None:
            if stop.is_set():
                raise _InterruptedError
            if self.closed:
                stop.wait(seconds)
            else:
                self.executor.spin_once(timeout_sec=seconds)
            if stop.is_set():
                raise _InterruptedError

        return spin

    def close(self) -> None:
        """Shut the node down (once; later calls do nothing). Spinning then only waits."""
        if self.closed:
            return
        self.closed = True
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown()


def process_main() -> NoReturn:
    """The console entry point (``./pd run``, ``ros2 run pd_bringup run_test``).

    :func:`main`, then the process ends at once (:func:`pd_common.ros.exit_process`): every child
    is reaped and the launcher's node shut down by then.
    """
    exit_process(main)


if __name__ == '__main__':
    process_main()
