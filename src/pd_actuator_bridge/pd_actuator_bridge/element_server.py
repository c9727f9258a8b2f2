"""Serve OpenSees's ``genericClient`` element: ``ros2 run pd_actuator_bridge element_server``.

``./pd serve [TEST_FILE]`` (default: the shipped ``serve_epp.yaml``) checks the test file's
``opensees_element`` scheme and its network settings (:func:`pd_common.opensees.check_bind`:
loopback only, unless ``allow_remote: true`` and an ``allow`` list, with a printed warning),
then starts the test as ``./pd run`` does (the node graph: the integrator serves the element,
the bridge drives the specimen with its limits, e-stop and lifecycle; signed messages, the
journal, the bag and the run folder) or, with ``--offline``, in one process as ``./pd
offline``. The element's model then runs unchanged but for its ``genericClient`` line; see
``docs/how-to/bring-your-opensees-model.md``.

``./pd serve --resume RUN_DIR`` continues a stopped served run (as ``./pd run --resume``): the
OpenSees model is started again from its beginning, its steps on record are checked against
the journal and answered from it (nothing moves), and the test goes on from the journal's last
committed step; a model whose trials differ from the record is refused.

This shell holds no protocol: the wire format and the trial/commit exchange are in
:mod:`pd_common.opensees`, the step mapping in the integrator's ``opensees_element`` scheme.
Bad input is one line naming the key, exit status 2.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from pd_common.config import SchemaError, read_test_file
from pd_common.opensees import ElementProtocolError, allow_list, bind_listener, check_bind
from pd_common.registry import ParameterError, resolve_parameters
from pd_common.resources import ResourceError, find_executable, share_file
from pd_common.specimen import HYSTERESIS_MODELS
from pd_core.errors import PdIntegratorError
from pd_core.run.resume import load_resumable
from pd_core.schemes.opensees_element import OpenSeesElement

PROG = 'element_server'
SCHEME = 'opensees_element'
DEFAULT_TEST = 'serve_epp.yaml'


class ServeError(Exception):
    """One line: why the element cannot be served."""


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    """Command-line options."""
    parser = argparse.ArgumentParser(
        prog=PROG, description="Serve an OpenSees model's genericClient element through the "
        'actuator bridge (the test file sets test.scheme: opensees_element).')
    parser.add_argument('test_file', nargs='?', help='YAML test file (default: '
                        f'pd_integrator config/{DEFAULT_TEST})')
    parser.add_argument('--offline', action='store_true', help='in one process, without ROS '
                        '(as ./pd offline): the bridge\'s limits are checked in-process')
    parser.add_argument('--out', help='run folder (default: runs/<test_id>-<UTC time>)')
    parser.add_argument('--no-figures', action='store_true', help='skip the PNG figures')
    parser.add_argument('--resume', metavar='RUN_DIR', help='continue a stopped served run from '
                        'its journal; then start the OpenSees model again, from its beginning: '
                        'its recorded steps are answered from the journal, nothing moves before '
                        'the first step past it')
    return parser.parse_args(argv)


def check_resumed_run(args: argparse.Namespace) -> Path:
    """The run folder of ``--resume``, checked to be a served run.

    Raises:
        ServeError: Options that do not go with it, or not a served run folder.
    """
    if args.test_file or args.out or args.offline:
        msg = '--resume: takes no test file, --out or --offline (the run folder has them)'
        raise ServeError(msg)
    run_dir = Path(args.resume)
    try:
        _, definition, _ = load_resumable(run_dir)
    except PdIntegratorError as err:
        msg = f'--resume: {err}'
        raise ServeError(msg) from None
    scheme = definition.scheme
    if scheme != SCHEME:
        msg = (f'--resume: {run_dir}: not a served run (scheme {scheme!r}): continue it with '
               f'./pd run --resume {run_dir}')
        raise ServeError(msg)
    return run_dir


def check_test_file(path: Path) -> tuple[str, list[str]]:
    """Check the scheme and the network settings; returns ``(served address, warnings)``.

    Raises:
        ServeError: The file cannot be read, is not served, or its address is refused.
    """
    try:  # the typed schema: one line with the dotted path of a refused value
        test = read_test_file(path, hysteresis_models=tuple(HYSTERESIS_MODELS),
                              broken_models=HYSTERESIS_MODELS.broken).model.test
    except SchemaError as err:
        raise ServeError(str(err)) from None
    if test.scheme != SCHEME:
        msg = (f'{path}: test.scheme: must be {SCHEME} to serve an element, got '
               f'{test.scheme!r}')
        raise ServeError(msg)
    try:  # the scheme's own declarations: its defaults and bounds
        parameters = resolve_parameters(OpenSeesElement.PARAMETERS, test.scheme_parameters or {})
        host = str(parameters['host'])
        warnings = check_bind(host, allow_list(str(parameters['allow'])),
                              parameters['allow_remote'] is True)
    except (ParameterError, ElementProtocolError) as err:
        msg = f'{path}: test.scheme_parameters.{err}'
        raise ServeError(msg) from None
    return f'{host}:{int(parameters["port"])}', warnings


def check_port_free(path: Path, address: str) -> None:
    """Bind the served address once, as the element's link will (a port of 0 always binds).

    Raises:
        ServeError: the port is taken: said now, before a run folder and its processes are
            made (the link's own bind would fail only inside the running test).
    """
    host, _, port = address.rpartition(':')
    try:
        bind_listener(host, int(port)).close()
    except ElementProtocolError as err:
        msg = f'{path}: test.scheme_parameters.{err}'
        raise ServeError(msg) from None


def main(argv: Sequence[str] | None = None) -> int:
    """Check, then run the served test (replaces this process)."""
    args = parse_args(argv)
    if args.resume:
        return resume(args)
    try:
        test_file = (Path(args.test_file) if args.test_file
                     else share_file('pd_integrator', 'config', DEFAULT_TEST))
        address, warnings = check_test_file(test_file)
        check_port_free(test_file, address)
        tool = find_executable('pd_integrator', 'offline') if args.offline else \
            find_executable('pd_bringup', 'run_test')
    except (ServeError, ResourceError) as err:
        print(f'{PROG}: error: {err}', file=sys.stderr)
        return 2
    for warning in warnings:
        print(f'{PROG}: {warning}', file=sys.stderr)
    print(f'{PROG}: serving the genericClient element of {test_file} on {address} '
          f'({"in one process" if args.offline else "through the node graph"})', flush=True)
    command = [str(tool), str(test_file)]
    if args.out:
        command += ['--out', args.out]
    if args.no_figures:
        command.append('--no-figures')
    os.execv(command[0], command)
    return 0  # not reached


def resume(args: argparse.Namespace) -> int:
    """Continue a stopped served run through ``run_test --resume`` (replaces this process)."""
    try:
        run_dir = check_resumed_run(args)
        tool = find_executable('pd_bringup', 'run_test')
    except (ServeError, ResourceError) as err:
        print(f'{PROG}: error: {err}', file=sys.stderr)
        return 2
    print(f'{PROG}: resuming the served run {run_dir}: start the OpenSees model again, from '
          'its beginning', flush=True)
    command = [str(tool), '--resume', str(run_dir)]
    if args.no_figures:
        command.append('--no-figures')
    os.execv(command[0], command)
    return 0  # not reached


if __name__ == '__main__':
    sys.exit(main())
