"""Run a complete test through the node graph: ``ros2 run pd_bringup run_test [TEST_FILE]``.

Starts each node as its own process, exactly as ``ros2 run`` would (the executable
``lib/<package>/main`` of the package's ament prefix):

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
direct`` too: the adapter's client is the bridge).

It waits for the integrator to finish, then stops the other nodes (SIGINT, then SIGKILL) and
prints where the run folder is. DDS discovery stays on this host unless
``ROS_AUTOMATIC_DISCOVERY_RANGE`` is already set.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import yaml

from pd_common.auth import KEY_FILE_ENV, AuthError, load_key
from pd_common.config import read_yaml_file
from pd_common.resources import ResourceError, find_executable, share_file
from pd_integrator.core.errors import PdIntegratorError
from pd_integrator.core.run.definition import TestDefinition
from pd_integrator.core.run.runner import default_run_directory
from pd_integrator.core.run.session import TestSession
from pd_integrator.core.run.test_file import load_test_file

from .rig import RigError, RigSettings, default_rig_key, load_rig, test_key_path

STOP_TIMEOUT = 10.0


class LaunchError(PdIntegratorError):
    """A node could not be found or started, or the launch options are wrong."""


def _stop(process: subprocess.Popen[bytes], name: str) -> None:
    if process.poll() is not None:
        return
    try:
        os.killpg(process.pid, signal.SIGINT)
        process.wait(timeout=STOP_TIMEOUT)
    except subprocess.TimeoutExpired:
        print(f'run_test: {name} did not stop on SIGINT; killing it', file=sys.stderr)
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    except ProcessLookupError:
        pass


def parse_overrides(items: list[str]) -> dict[str, object]:
    """``NAME:=VALUE`` items (YAML values, as ``ros2 run --ros-args -p`` reads them).

    Raises:
        LaunchError: an item is not ``NAME:=VALUE``.
    """
    overrides: dict[str, object] = {}
    for item in items:
        name, sep, value = item.partition(':=')
        if not sep or not name:
            msg = f'--param {item!r}: expected NAME:=VALUE'
            raise LaunchError(msg)
        overrides[name] = yaml.safe_load(value)
    return overrides


def site_commands(definition: TestDefinition, test_file: Path, mode: str,
                  bridge_params: Path | None) -> list[tuple[str, list[str]]]:
    """The processes of the specimen side: per site a simulator (and its bridge)."""
    if mode == 'none':
        return []
    params = bridge_params or share_file('pd_actuator_bridge', 'config', 'bridge.yaml')
    # Per site: name, namespace, actuator (DOF) names and extra bridge parameters.
    sites: list[tuple[str, str, list[str], dict[str, Any]]]
    if definition.model is None:
        sites = [('', '/pd', list(definition.dof_names), {})]
    else:
        settings = definition.sites or {}
        sites = []
        for site in definition.model.site_names:
            extra = settings.get(site, {}).get('bridge', {}) if isinstance(
                settings.get(site), dict) else {}
            if not isinstance(extra, dict):
                msg = f'{definition.source}: sites.{site}.bridge: must be a mapping of parameters'
                raise LaunchError(msg)
            sites.append((site, f'/pd/{site}', list(definition.model.actuator_names(site)),
                          extra))
    commands: list[tuple[str, list[str]]] = []
    for site, namespace, names, extra in sites:
        label = f'[{site}]' if site else ''
        opensees = (definition.sites or {}).get(site, {}).get('opensees') if site else None
        if opensees is not None:
            port = _free_port()
            commands.append((f'opensees_site{label}', opensees_command(
                opensees, port, definition, f'sites.{site}.opensees')))
            bridge = [str(find_executable('pd_actuator_bridge')), '--ros-args',
                      '--params-file', str(params), '-r', f'__ns:={namespace}',
                      '-p', f'dof_names:={json.dumps(names)}', '-p', 'driver:=opensees_adapter',
                      '-p', 'tcp_host:=127.0.0.1', '-p', f'tcp_port:={port}']
            for name, value in extra.items():
                bridge += ['-p', f'{name}:={json.dumps(value)}']
            commands.append((f'pd_actuator_bridge{label}', bridge))
            continue
        specimen_ns = f'{namespace}/specimen' if mode == 'bridge' else namespace
        simulator = [str(find_executable('pd_specimen_sim')), '--ros-args',
                     '-r', f'__ns:={specimen_ns}', '-p', f'test_file:={test_file}']
        if site:
            simulator += ['-p', f'site:={site}', '-p', f'dof_names:={json.dumps(names)}']
        commands.append((f'pd_specimen_sim{label}', simulator))
        if mode == 'bridge':
            bridge = [str(find_executable('pd_actuator_bridge')), '--ros-args',
                      '--params-file', str(params), '-r', f'__ns:={namespace}',
                      '-p', f'dof_names:={json.dumps(names)}']
            for name, value in extra.items():
                bridge += ['-p', f'{name}:={json.dumps(value)}']
            commands.append((f'pd_actuator_bridge{label}', bridge))
    return commands


def _free_port() -> int:
    """A TCP port free on loopback now (for a local OpenSees adapter element)."""
    with socket.socket() as sock:
        sock.bind(('127.0.0.1', 0))
        return int(sock.getsockname()[1])


#: ``sites.<site>.opensees`` keys -> ``opensees_site`` options.
_OPENSEES_OPTIONS = {'model': '--model', 'stiffness': '--stiffness',
                     'yield_force': '--yield-force', 'penalty': '--penalty',
                     'script': '--script', 'tolerance': '--tolerance'}


def opensees_command(settings: Any, port: int, definition: TestDefinition, where: str
                     ) -> list[str]:
    """The ``opensees_site`` command line of a site's ``opensees`` mapping.

    Raises:
        LaunchError: the mapping is not one, or has an unknown key.
    """
    if not isinstance(settings, dict):
        msg = f'{definition.source}: {where}: must be a mapping (model, stiffness, ...)'
        raise LaunchError(msg)
    command = [str(find_executable('pd_actuator_bridge', 'opensees_site')), '--port', str(port),
               '--quiet']
    if 'script' in settings and 'model' not in settings:
        settings = {**settings, 'model': 'script'}
    for key, value in settings.items():
        if key not in _OPENSEES_OPTIONS:
            msg = (f'{definition.source}: {where}.{key}: unknown (expected '
                   f'{", ".join(_OPENSEES_OPTIONS)})')
            raise LaunchError(msg)
        if key == 'script':
            value = (definition.base_dir / str(value)).resolve()
        command += [_OPENSEES_OPTIONS[key], str(value)]
    return command


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


def with_key(command: list[str], key_file: Path | None) -> list[str]:
    """A node's command line with its key parameter (unchanged for a non-ROS process)."""
    if '--ros-args' not in command:
        return command
    if key_file is None:
        return [*command, '-p', 'authentication:=false']
    return [*command, '-p', f'key_file:={key_file}']


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``ros2 run pd_bringup run_test``."""
    args = parse_args(argv)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    try:
        test_file = Path(args.test_file) if args.test_file else share_file(
            'pd_integrator', 'config', 'default_test.yaml')
        overrides = parse_overrides(args.param)
        definition = load_test_file(test_file, overrides)  # fail early, before any process
        if not definition.needs_probe:
            TestSession(definition)  # refuses an unstable test (omega*dt above the limit)
        out = Path(args.out) if args.out else default_run_directory('runs',
                                                                      definition.test_id)
        integrator = [str(find_executable('pd_integrator')), '--ros-args',
                      '-p', f'test_file:={test_file.resolve()}',
                      '-p', f'output_dir:={out.resolve()}',
                      '-p', f'figures:={"false" if args.no_figures else "true"}']
        for item in args.param:
            integrator += ['-p', item]
        commands = site_commands(definition, test_file.resolve(), args.site,
                                 Path(args.bridge_params) if args.bridge_params else None)
        rig = load_rig(read_yaml_file(test_file) or {}, test_file,
                       Path(args.rig) if args.rig else None)
        key_file = resolve_key(args, rig, definition.test_id)
    except (PdIntegratorError, ResourceError, RigError) as err:
        print(f'run_test: error: {err}', file=sys.stderr)
        return 2
    integrator = with_key(integrator, key_file)
    commands = [(name, with_key(command, key_file)) for name, command in commands]
    env = rig.environment(os.environ)
    if key_file is not None:
        print(f'run_test: key {key_file} (id {load_key(key_file).key_id})', flush=True)
    if rig.domain_id is not None:
        print(f'run_test: rig ROS_DOMAIN_ID={rig.domain_id}, discovery {rig.discovery}',
              flush=True)

    print(f'run_test: {definition.test_id} ({definition.n_steps} steps), site: {args.site}, '
          f'run folder: {out}', flush=True)
    processes: list[tuple[str, subprocess.Popen[bytes]]] = []
    code: int | None = 1
    try:
        for name, command in commands:
            processes.append((name, subprocess.Popen(command, start_new_session=True,
                                                     env=env)))
        process = subprocess.Popen(integrator, start_new_session=True, env=env)
        processes.append(('pd_integrator', process))
        while (code := process.poll()) is None:
            failed = [(name, other) for name, other in processes[:-1]
                      if other.poll() is not None]
            if failed:
                name, other = failed[0]
                print(f'run_test: {name} exited with code {other.returncode}; stopping the '
                      'test', file=sys.stderr)
                break
            time.sleep(0.1)
    except KeyboardInterrupt:
        print('run_test: interrupted; stopping the integrator first', file=sys.stderr)
    finally:
        for name, other in reversed(processes):  # integrator first: it writes the outputs
            _stop(other, name)
        if code is None:
            code = processes[-1][1].returncode if processes else 1
    summary = out / 'summary.json'
    if summary.is_file():
        data = json.loads(summary.read_text(encoding='utf-8'))
        for dof, values in data.get('dofs', {}).items():
            peak = values['peaks']['displacement']
            force = values['peaks']['restoring_force']
            print(f'run_test: {dof}: peak displacement {peak["value"]:.5f} m at '
                  f'{peak["time"]:.2f} s, peak force {force["value"] / 1e3:.3f} kN, residual '
                  f'{values["residual_displacement"]:.5f} m')
        print(f'run_test: {data.get("state")}: {data.get("steps")} steps in '
              f'{data.get("wall_time", 0):.2f} s; outputs in {out}')
    return int(code)


if __name__ == '__main__':
    sys.exit(main())
