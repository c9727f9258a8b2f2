"""What ``run_test`` starts: the processes of a test, and the plan kept in its run folder.

Every node is its own process, started exactly as ``ros2 run`` would (the executable
``lib/<package>/main`` of the package's ament prefix). The plan (:class:`LaunchPlan`) is written
to ``launch.json`` in the run folder before anything starts, so ``./pd run --resume RUN_DIR``
starts the same graph again (the integrator continuing from its journal, every simulator from
its state file) without the original command line. The plan is read back for the folder it is
in: a run folder moved or copied elsewhere resumes there, its processes' files (state files,
records, reports) taken from it, not from where the run started.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from pd_common.config import (
    SchemaError,
    default_bridge_parameter_file,
    read_bridge_parameter_file,
    read_text,
)
from pd_common.config.schema_test_file import OpenSeesSite, SiteSettings
from pd_common.resources import find_executable
from pd_core.errors import PdIntegratorError
from pd_core.run.definition import TestDefinition
from pd_core.run.record.continuations import RESTART_NOTE

from .faults import FaultPlanError, attach_reports, proxy_command
from .reports import add_to_summary, read_reports

__all__ = ['BEHIND', 'CPU_KINDS', 'LAUNCH_FILE', 'RESTART_NOTE',
           'SIMULATED_DRIVERS',
           'Child', 'LaunchError', 'LaunchPlan', 'attach_fault_reports',
           'attach_realtime_reports', 'bridge_driver', 'bridge_record_file',
           'fault_report_name', 'insert_fault_proxies', 'opensees_command',
           'parse_cpus', 'realtime_report_name', 'site_commands', 'with_key']


#: The plan's file name in a run folder.
LAUNCH_FILE = 'launch.json'
_VERSION = 1
#: Bridge drivers whose actuator and specimen are simulated (anything else is physical).
SIMULATED_DRIVERS = ('sim_servo', 'emulator', 'opensees_adapter', 'transfer_system')
#: Simulated drivers whose specimen lives in the bridge itself (no simulator process; the
#: bridge gets the test file and its site).
IN_BRIDGE_DRIVERS = ('transfer_system',)
#: Where a step receiver's step-protocol topics go behind a fault proxy: ``<namespace>/behind``.
BEHIND = 'behind'
#: A step receiver's step-protocol topics (relative to its namespace).
_RECEIVER_TOPICS = ('step_command', 'step_feedback', 'session/offer', 'session/start')


class LaunchError(PdIntegratorError):
    """A node could not be found or started, or the launch options are wrong."""


@dataclass
class Child:
    """One process of the test.

    Attributes:
        name: its name in messages (``pd_actuator_bridge[lab1]``).
        kind: ``integrator``, ``simulator``, ``bridge``, ``opensees`` or ``proxy``.
        site: its site ('' for the test's single site).
        namespace: the namespace of the step receiver it is (its session offer), if any.
        command: its command line.
        state_file: a simulator's own state file (restored from when it restarts); a fault
            proxy's report file (its counters, continued when it restarts).
        dof_names: a site simulator's DOF names (the site's actuators).
    """

    name: str
    kind: str
    site: str
    namespace: str
    command: list[str]
    state_file: str = ''
    dof_names: list[str] = field(default_factory=list)

    @property
    def restorable(self) -> bool:
        """Whether restarting it gives back the same state (else the test holds for the operator).

        The integrator (journal), a simulator (state file), a bridge (its state is the actuator's,
        read back when it configures). An OpenSees site restarts fresh.
        """
        return self.kind in ('integrator', 'bridge', 'proxy') or bool(self.state_file)


@dataclass
class LaunchPlan:
    """The processes of a test and how they were started.

    Attributes:
        test_id: the test.
        n_steps: its steps.
        out: the run folder (read back: the folder the plan was read from, see
            :meth:`load`).
        site_mode: ``bridge``, ``direct`` or ``none``.
        physical: whether a physical specimen is driven (a bridge with a hardware driver, or
            the specimen side started elsewhere).
        key_file: the key every node has (``None``: authentication off).
        environment: the rig's environment settings (domain, discovery).
        children: the specimen side's processes, in start order.
        integrator: the integrator's command line for a new run (its ``resume_from`` form is
            made from it).
        figures: whether figures are written.
        cpus: the CPUs each kind of process runs on (``run_test --cpus``): a kind
            (``integrator``, ``bridge``, ...) and its CPU numbers; a kind not named runs on any.
    """

    test_id: str
    n_steps: int
    out: Path
    site_mode: str
    physical: bool
    key_file: Path | None
    environment: dict[str, str]
    children: list[Child]
    integrator: list[str]
    figures: bool = True
    extra: dict[str, Any] = field(default_factory=dict)
    cpus: dict[str, list[int]] = field(default_factory=dict)

    def save(self) -> Path:
        """Write ``launch.json`` into the run folder (created); its path.

        Raises:
            LaunchError: the folder or the file cannot be written (a read-only file system,
                a full disk): one line, and no ``launch.json`` left behind.
        """
        data = asdict(self)
        data['out'] = str(self.out)
        data['key_file'] = str(self.key_file) if self.key_file is not None else None
        data['version'] = _VERSION
        path = self.out / LAUNCH_FILE
        try:
            self.out.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(data, indent=1) + '\n', encoding='utf-8')
        except OSError as err:
            with contextlib.suppress(OSError):  # a file cut short by a full disk
                path.unlink(missing_ok=True)
            msg = (f'--out {self.out}: cannot write the run folder '
                   f'({err.strerror or type(err).__name__})')
            raise LaunchError(msg) from None
        return path

    @classmethod
    def load(cls, run_dir: Path) -> LaunchPlan:
        """The plan of a run folder, for that folder.

        ``out`` is ``run_dir``, and every path of the plan that pointed into the folder the run
        started in (a moved or copied folder) points into ``run_dir`` (:meth:`rebased`).

        Raises:
            LaunchError: no readable ``launch.json`` there.
        """
        path = run_dir / LAUNCH_FILE
        try:
            text = read_text(path, what='a launch plan')
            data = json.loads(text)
            if not isinstance(data, dict):
                msg = f'a JSON {type(data).__name__}, not an object'
                raise TypeError(msg)
            data.pop('version', None)
            data['out'] = Path(data['out'])
            data['key_file'] = Path(data['key_file']) if data['key_file'] else None
            data['children'] = [Child(**child) for child in data['children']]
            plan = cls(**data)
            _check_types(plan)
        except FileNotFoundError:
            msg = (f'{run_dir}: no {LAUNCH_FILE}: not a run folder of run_test (an integrator '
                   'run alone resumes with: ros2 run pd_integrator main --ros-args -p '
                   'resume_from:=RUN_DIR)')
            raise LaunchError(msg) from None
        except RecursionError:
            msg = f'{path}: unreadable launch plan (JSON nested too deep)'
            raise LaunchError(msg) from None
        except (OSError, ValueError, KeyError, TypeError) as err:
            reason = (err.strerror if isinstance(err, OSError)
                      else f'no {err}' if isinstance(err, KeyError) else err)
            msg = f'{path}: unreadable launch plan ({reason})'
            raise LaunchError(msg) from None
        return plan.rebased(run_dir)

    def started_in(self) -> str | None:
        """The absolute run folder the plan's paths were made in (the integrator's ``output_dir``).

        Or ``None`` if the plan does not say.
        """
        for item in self.integrator:
            if item.startswith('output_dir:='):
                return item.removeprefix('output_dir:=')
        return str(self.out) if self.out.is_absolute() else None

    def rebased(self, run_dir: Path) -> LaunchPlan:
        """This plan for the folder ``run_dir``.

        ``out`` is ``run_dir``, and every path in a command line, state file or report that was in
        the folder the run started in is in ``run_dir`` now (the integrator's journal and output
        folder, simulators' state files, bridges' records and real-time reports, fault proxies'
        reports). Paths elsewhere (the test file, the key, executables) are kept.
        """
        old = self.started_in()
        new = str(run_dir.resolve())
        plan = replace(self, out=run_dir)
        if old is None or old == new:
            return plan
        plan.integrator = [_rebase(item, old, new) for item in self.integrator]
        plan.children = [replace(child, command=[_rebase(item, old, new)
                                                 for item in child.command],
                                 state_file=_rebase(child.state_file, old, new))
                         for child in self.children]
        return plan

    def integrator_command(self, *, resume: bool, note: str = '',
                           confirm: bool = False, held: bool = False) -> list[str]:
        """The integrator's command line.

        A new run, or continuing this folder's run (held: it moves nothing before a person's signed
        resume).
        """
        if not resume:
            return list(self.integrator)
        command: list[str] = []
        skip = False
        for item in self.integrator:  # the same node without test_file/output_dir
            if skip:
                skip = False
                if item.startswith(('test_file:=', 'output_dir:=')):
                    command.pop()  # the '-p' before it
                    continue
            command.append(item)
            skip = item == '-p'
        command += ['-p', f'resume_from:={self.out.resolve()}']
        if note:
            command += ['-p', f'resume_note:={json.dumps(note)}']
        if confirm:
            command += ['-p', 'confirm_resume:=true']
        if held:
            command += ['-p', 'hold_on_resume:=true']
        return command


def _rebase(item: str, old: str, new: str) -> str:
    """``item`` with the folder ``old`` replaced by ``new``.

    ``item`` (a path, or a ``name:=path`` parameter) with the folder ``old`` replaced by
    ``new``; anything else unchanged.
    """
    name, sep, value = item.partition(':=')
    if not sep:
        name, value = '', item
    root = old.rstrip('/')
    if value == root or value.startswith(root + '/'):
        return f'{name}{sep}{new}{value[len(root):]}'
    return item


def _check_types(plan: LaunchPlan) -> None:
    """Refuse a plan whose command lines are not lists of strings (a damaged file).

    Raises:
        TypeError: naming the field.
    """
    commands = {'integrator': plan.integrator,
                **{f'children.{child.name}': child.command for child in plan.children}}
    for name, command in commands.items():
        if not isinstance(command, list) or not all(isinstance(item, str) for item in command):
            msg = f'{name}: not a command line'
            raise TypeError(msg)
    if not all(isinstance(child.state_file, str) for child in plan.children):
        msg = 'children: a state_file is not a path'
        raise TypeError(msg)
    if not isinstance(plan.cpus, dict) or not all(
            isinstance(kind, str) and isinstance(cpus, list)
            and all(isinstance(cpu, int) and not isinstance(cpu, bool) for cpu in cpus)
            for kind, cpus in plan.cpus.items()):
        msg = 'cpus: not CPU numbers per kind of process'
        raise TypeError(msg)


#: The kinds of process ``--cpus`` places.
CPU_KINDS = ('integrator', 'bridge', 'simulator', 'opensees', 'proxy')


def parse_cpus(items: list[str], available: set[int] | None = None) -> dict[str, list[int]]:
    """``--cpus KIND=CPUS`` options: the CPUs of each kind of process (``0``, ``0,2``, ``1-3``).

    Args:
        items: the options' values.
        available: the CPUs this process may use (default: its affinity).

    Raises:
        LaunchError: an unknown kind, a kind named twice, or CPUs that are not numbers this
            machine lets the test use (one line naming the option).
    """
    if available is None:
        available = os.sched_getaffinity(0)
    placed: dict[str, list[int]] = {}
    for item in items:
        kind, _, text = item.partition('=')
        kind = kind.strip()
        if kind not in CPU_KINDS:
            msg = f'--cpus {item}: {kind!r} is not a kind of process ({", ".join(CPU_KINDS)})'
            raise LaunchError(msg)
        if kind in placed:
            msg = f'--cpus {item}: {kind} is placed twice'
            raise LaunchError(msg)
        cpus: set[int] = set()
        try:
            for part in text.split(','):
                first, _, last = part.strip().partition('-')
                cpus.update(range(int(first), int(last or first) + 1))
        except ValueError:
            cpus.clear()
        if not cpus:
            msg = f'--cpus {item}: {text!r} is not a list of CPUs (e.g. 0, 0,2 or 1-3)'
            raise LaunchError(msg)
        missing = sorted(cpus - available)
        if missing:
            msg = (f'--cpus {item}: CPU {", ".join(map(str, missing))} not available (this '
                   f'test may use {", ".join(map(str, sorted(available)))})')
            raise LaunchError(msg)
        placed[kind] = sorted(cpus)
    return placed


def bridge_driver(params: Path | None, extra: dict[str, Any]) -> str:
    """The driver a bridge will use: its site's override, its parameter file's, or sim_servo.

    The parameter file is read once, typed (:func:`pd_common.config.read_bridge_parameter_file`):
    a bad one is refused here, before any process starts.

    Raises:
        LaunchError: the parameter file cannot be read or is refused (one line naming the file
            and the dotted path, ``bridge.yaml: /**.ros__parameters.max_force: must be > 0,
            got -1``).
    """
    if 'driver' in extra:
        return str(extra['driver'])
    if params is not None:
        try:
            parameters = read_bridge_parameter_file(params)
        except SchemaError as err:
            raise LaunchError(str(err)) from None
        if not parameters.root:  # (the bridge would start unconfigured: no test, a 30 s wait)
            msg = (f'{params}: no bridge parameters in it (an empty file?); start from '
                   f'{default_bridge_parameter_file()}')
            raise LaunchError(msg)
        for section in parameters.root.values():
            if section.ros__parameters.driver is not None:
                return section.ros__parameters.driver
    return 'sim_servo'


def _state_file(out: Path, site: str) -> str:
    return str((out / (f'specimen-{site}.state.jsonl' if site else 'specimen.state.jsonl'))
               .resolve())


def bridge_record_file(out: Path, site: str) -> str:
    """A bridge's durable record in the run folder (emergency stops, holds, controls)."""
    return str((out / (f'bridge-{site}.record.jsonl' if site else 'bridge.record.jsonl'))
               .resolve())


def site_commands(definition: TestDefinition, test_file: Path, mode: str,
                  bridge_params: Path | None, out: Path) -> tuple[list[Child], bool]:
    """The processes of the specimen side: per site a simulator (and its bridge).

    Whether a physical specimen is driven. A site's settings are the typed ones
    (``definition.site_settings``): its ``bridge`` parameters the user set (each passed to its
    bridge as a ROS parameter, with the schema's type: a limit is a double), its ``opensees``
    substructure and its ``transfer_system``.
    """
    if mode == 'none':
        return [], True
    params = bridge_params or default_bridge_parameter_file()
    # Per site: name, namespace, actuator (DOF) names and its typed settings.
    sites: list[tuple[str, str, list[str], SiteSettings]]
    if definition.model is None:
        sites = [('', '/pd', list(definition.dof_names), SiteSettings())]
    else:
        sites = [(site, f'/pd/{site}', list(definition.model.actuator_names(site)),
                  definition.site_settings.get(site) or SiteSettings())
                 for site in definition.model.site_names]
    children: list[Child] = []
    physical = False
    for site, namespace, names, settings in sites:
        label = f'[{site}]' if site else ''
        extra = (settings.bridge.model_dump(exclude_unset=True) if settings.bridge is not None
                 else {})
        bridge = [str(find_executable('pd_actuator_bridge')), '--ros-args',
                  '--params-file', str(params), '-r', f'__ns:={namespace}',
                  '-p', f'dof_names:={json.dumps(names)}',
                  '-p', f'record_file:={bridge_record_file(out, site)}']
        if settings.opensees is not None:
            port = _free_port()
            children.append(Child(f'opensees_site{label}', 'opensees', site, '',
                                  opensees_command(settings.opensees, port, definition)))
            bridge += ['-p', 'driver:=opensees_adapter', '-p', 'tcp_host:=127.0.0.1',
                       '-p', f'tcp_port:={port}']
            for name, value in extra.items():
                bridge += ['-p', f'{name}:={json.dumps(value)}']
            children.append(Child(f'pd_actuator_bridge{label}', 'bridge', site, namespace,
                                  bridge))
            continue
        specimen_ns = f'{namespace}/specimen' if mode == 'bridge' else namespace
        state_file = _state_file(out, site)
        simulator = [str(find_executable('pd_specimen_sim')), '--ros-args',
                     '-r', f'__ns:={specimen_ns}', '-p', f'test_file:={test_file}',
                     '-p', f'state_file:={state_file}']
        if site:
            simulator += ['-p', f'site:={site}', '-p', f'dof_names:={json.dumps(names)}']
        driver = bridge_driver(params, extra) if mode == 'bridge' else ''
        if settings.transfer_system is not None and driver not in IN_BRIDGE_DRIVERS:
            msg = (f'{definition.source}: sites.{site}.transfer_system: a continuous site runs '
                   'in its bridge: use --site bridge with sites.'
                   f'{site}.bridge: {{driver: transfer_system}}')
            raise LaunchError(msg)
        if mode == 'bridge' and driver in IN_BRIDGE_DRIVERS:
            bridge += ['-p', f'test_file:={test_file}', '-p', f'site:={site}',
                       '-p', f'realtime_report:={(out / realtime_report_name(site)).resolve()}']
        elif mode == 'bridge' and driver not in SIMULATED_DRIVERS:
            physical = True  # the bridge drives hardware: no simulator for this site
        else:
            children.append(Child(f'pd_specimen_sim{label}', 'simulator', site, specimen_ns,
                                  simulator, state_file=state_file,
                                  dof_names=names if site else []))
        if mode == 'bridge':
            for name, value in extra.items():
                bridge += ['-p', f'{name}:={json.dumps(value)}']
            children.append(Child(f'pd_actuator_bridge{label}', 'bridge', site, namespace,
                                  bridge))
    return children, physical


def _free_port() -> int:
    """A TCP port free on loopback now (for a local OpenSees adapter element)."""
    with socket.socket() as sock:
        sock.bind(('127.0.0.1', 0))
        return int(sock.getsockname()[1])


#: ``sites.<site>.opensees`` keys -> ``opensees_site`` options.
_OPENSEES_OPTIONS = {'model': '--model', 'stiffness': '--stiffness',
                     'yield_force': '--yield-force', 'penalty': '--penalty',
                     'script': '--script', 'tolerance': '--tolerance'}


def opensees_command(settings: OpenSeesSite, port: int, definition: TestDefinition
                     ) -> list[str]:
    """The ``opensees_site`` command line of a site's typed ``opensees`` settings.

    Each value given becomes its option (a ``script`` without a ``model`` is
    ``--model script``; a relative script resolves against the test file's folder).
    """
    command = [str(find_executable('pd_actuator_bridge', 'opensees_site')), '--port', str(port),
               '--quiet']
    given = settings.model_dump(exclude_none=True)
    if 'script' in given and 'model' not in given:
        given = {'model': 'script', **given}
    for key, value in given.items():
        if key == 'script':
            value = (definition.base_dir / str(value)).resolve()
        command += [_OPENSEES_OPTIONS[key], str(value)]
    return command


def fault_report_name(site: str) -> str:
    """The file name of a site's fault proxy report in the run folder."""
    return f'faults-{site}.json' if site else 'faults.json'


def insert_fault_proxies(children: list[Child], faults: str, out: Path) -> list[Child]:
    """The processes with a fault proxy (``fault_proxy``) in front of each site's step receiver.

    A site's receiver (the process in the namespace the integrator talks to: ``/pd`` or
    ``/pd/<site>``; a bridge, or a simulator with ``--site direct``) keeps its namespace (its
    controls, status and name) but its step-protocol topics (commands, feedback, session offer
    and start) are remapped to ``<namespace>/behind``; the proxy (kind ``proxy``, right after
    it) forwards between the two with the faults of the plan, and writes its counters to
    :func:`fault_report_name` in the run folder (its ``state_file``: a restarted proxy
    continues them). The receiver's ``namespace`` stays the integrator's side: its offer as
    the integrator sees it, through the proxy.

    Raises:
        LaunchError: the plan is invalid, or no step receiver is started (``--site none``).
        pd_common.resources.ResourceError: the proxy is not built.
    """
    proxied: list[Child] = []
    found = False
    for child in children:
        proxied.append(child)
        front = f'/pd/{child.site}' if child.site else '/pd'
        if child.kind not in ('simulator', 'bridge') or child.namespace != front:
            continue
        found = True
        back = f'{front}/{BEHIND}'
        for topic in _RECEIVER_TOPICS:
            child.command = [*child.command, '-r', f'{topic}:={back}/{topic}']
        report = str((out / fault_report_name(child.site)).resolve())
        try:
            command = proxy_command(front, back, faults, Path(report))
        except FaultPlanError as err:
            msg = f'--faults: {err}'
            raise LaunchError(msg) from None
        label = f'[{child.site}]' if child.site else ''
        proxied.append(Child(f'fault_proxy{label}', 'proxy', child.site, front, command,
                             state_file=report))
    if not found:
        msg = ('--faults: no step receiver is started here to put a proxy in front of '
               '(--site none: start the fault proxy with the specimen side)')
        raise LaunchError(msg)
    return proxied


def attach_fault_reports(plan: LaunchPlan) -> dict[str, Any] | None:
    """Add the fault proxies' counters to the run's ``summary.json`` (``faults``).

    The block (``None``: no proxy, or none wrote its report).
    """
    files = {child.name: Path(child.state_file) for child in plan.children
             if child.kind == 'proxy' and child.state_file}
    if not files:
        return None
    try:
        return attach_reports(plan.out / 'summary.json', files)
    except (OSError, ValueError) as err:
        msg = f'{plan.out / "summary.json"}: cannot add the fault counters ({err})'
        raise LaunchError(msg) from None


def realtime_report_name(site: str) -> str:
    """The file name of a continuous site's wall-clock statistics in the run folder."""
    return f'rths-{site}.json'


def attach_realtime_reports(plan: LaunchPlan) -> dict[str, Any] | None:
    """Add the continuous sites' wall-clock statistics to the run's ``summary.json``.

    Add the continuous sites' wall-clock statistics (their bridges' ``rths-<site>.json``)
    to the run's ``summary.json`` as ``realtime`` (per site); the block (``None``: no report:
    no site ran on the wall clock).

    Raises:
        LaunchError: ``summary.json`` cannot be rewritten.
    """
    files = {child.site: plan.out / realtime_report_name(child.site)
             for child in plan.children if child.kind == 'bridge' and child.site}
    block = read_reports(files)
    if not block:
        return None
    summary_file = plan.out / 'summary.json'
    try:
        add_to_summary(summary_file, 'realtime', block)
    except (OSError, ValueError) as err:
        msg = f'{summary_file}: cannot add the wall-clock statistics ({err})'
        raise LaunchError(msg) from None
    return block


def with_key(command: list[str], key_file: Path | None) -> list[str]:
    """A node's command line with its key parameter (unchanged for a non-ROS process)."""
    if '--ros-args' not in command:
        return command
    if key_file is None:
        return [*command, '-p', 'authentication:=false']
    return [*command, '-p', f'key_file:={key_file}']
