"""Where a step's time goes in each node: py-spy samples of a run through the graph.

Run inside the sourced workspace (``. scripts/env.sh``)::

    python bench/profile_graph.py [--site direct|bridge] [--steps 20000] [--seconds 8]

A measurement, not a test: it asserts nothing and writes nothing but its table. It starts
``run_test --site SITE --no-figures`` on the default test with ``dt`` 1 ms for ``--steps``
steps (its own process group, ``ROS_DOMAIN_ID`` ``--domain-id``), waits until the test runs,
then samples every node process with ``py-spy record --format raw --nonblocking`` (500 Hz,
``--seconds`` s, all at once) and prints per node the frames with the most samples: their own
(the function's line itself) and inclusive (anywhere on the stack). A node's samples include
its idle ``spin_once`` waits, so the shares are of the node's wall time.

py-spy reads the processes' memory from outside (``ptrace``): run it as their user with
``/proc/sys/kernel/yama/ptrace_scope`` 0, or as root.
"""

from __future__ import annotations

import argparse
import collections
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_loop import REPO, machine_header, remove_stale_segments, shm_snapshot, stop_process

NODES = {'integrator': 'lib/pd_integrator/main', 'bridge': 'lib/pd_actuator_bridge/main',
         'specimen': 'lib/pd_specimen_sim/main'}
RATE_HZ = 500


def node_pids(launcher_pid: int) -> dict[str, int]:
    """The node processes the launcher started (by their executables), name -> pid."""
    found: dict[str, int] = {}
    for entry in Path('/proc').iterdir():
        if not entry.name.isdigit():
            continue
        try:
            command = (entry / 'cmdline').read_bytes().replace(b'\0', b' ').decode()
            stat = (entry / 'stat').read_text().rsplit(')', 1)[1].split()
        except OSError:
            continue
        if int(stat[1]) != launcher_pid:  # (its parent)
            continue
        for name, executable in NODES.items():
            if executable in command:
                found[name] = int(entry.name)
    return found


Frames = list[tuple[str, int]]


def top_frames(path: Path, count: int) -> tuple[int, Frames, Frames]:
    """Samples, the ``count`` frames with most own samples and with most inclusive samples."""
    own: collections.Counter[str] = collections.Counter()
    inclusive: collections.Counter[str] = collections.Counter()
    total = 0
    for line in path.read_text(encoding='utf-8', errors='replace').splitlines():
        stack, _, number = line.rpartition(' ')
        if not stack or not number.isdigit():
            continue
        samples = int(number)
        total += samples
        frames = stack.split(';')
        own[frames[-1]] += samples
        for frame in set(frames):
            inclusive[frame] += samples
    return total, own.most_common(count), inclusive.most_common(count)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """Command-line arguments."""
    parser = argparse.ArgumentParser(prog='profile_graph', description=__doc__.splitlines()[0])
    parser.add_argument('--site', choices=('direct', 'bridge'), default='direct')
    parser.add_argument('--steps', type=int, default=20_000,
                        help='steps of the test (dt 1 ms; default 20,000)')
    parser.add_argument('--seconds', type=int, default=8, help='seconds sampled (whole)')
    parser.add_argument('--top', type=int, default=15, help='frames listed per node')
    parser.add_argument('--domain-id', type=int, default=77)
    parser.add_argument('--no-authentication', action='store_true',
                        help="run_test's --no-authentication (what signing costs, by difference)")
    args = parser.parse_args(argv)
    if args.steps < 1000 or not 1 <= args.seconds <= 120:
        parser.error('--steps: at least 1000; --seconds: 1 to 120')
    return args


def main(argv: list[str] | None = None) -> int:
    """Profile one run and print the table."""
    args = parse_args(argv)
    py_spy = shutil.which('py-spy')
    if py_spy is None:
        print('profile_graph: error: py-spy not found (./pd setup installs it)', file=sys.stderr)
        return 2
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    os.environ['ROS_DOMAIN_ID'] = str(args.domain_id)
    print(machine_header(args.domain_id))
    launcher = REPO / 'ros2_ws' / 'install' / 'pd_bringup' / 'lib' / 'pd_bringup' / 'run_test'
    before = shm_snapshot()
    with tempfile.TemporaryDirectory(prefix='pd-profile-') as name:
        work = Path(name)
        run = subprocess.Popen(
            [sys.executable, str(launcher), '--site', args.site, '--out', str(work / 'run'),
             '--no-figures', '-p', 'dt:=0.001', '-p', f'duration:={args.steps / 1000.0}',
             *(['--no-authentication'] if args.no_authentication else [])],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            start_new_session=True)
        try:
            assert run.stdout is not None
            for line in run.stdout:  # the integrator logs 'running' when the test starts
                if 'running: step' in line:
                    break
            time.sleep(1.0)
            pids = node_pids(run.pid)
            samplers = {node: subprocess.Popen(
                [py_spy, 'record', '--format', 'raw', '--nonblocking', '-r', str(RATE_HZ),
                 '-d', str(args.seconds), '-p', str(pid), '-o', str(work / f'{node}.txt')],
                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                for node, pid in pids.items()}
            for node, sampler in samplers.items():
                _, error = sampler.communicate(timeout=args.seconds + 30)
                if sampler.returncode != 0:
                    print(f'{node}: py-spy failed: {error.strip().splitlines()[:1]}')
            run.stdout.read()
            run.wait(timeout=600)
        finally:
            stop_process(run)
            remove_stale_segments(before, args.domain_id)
        plain = ', --no-authentication' if args.no_authentication else ''
        print(f'run_test --site {args.site}{plain}: {args.steps:,} steps of 1 ms; '
              f'{args.seconds:g} s sampled at {RATE_HZ} Hz\n')
        for node in pids:
            path = work / f'{node}.txt'
            if not path.is_file():
                continue
            total, own, inclusive = top_frames(path, args.top)
            print(f'{node} ({total} samples): own | inclusive')
            for (frame, samples), (frame_in, samples_in) in zip(own, inclusive, strict=False):
                print(f'  {100 * samples / total:5.1f} % {frame[:70]:<70} | '
                      f'{100 * samples_in / total:5.1f} % {frame_in[:70]}')
            print()
    return 0


if __name__ == '__main__':
    sys.exit(main())
