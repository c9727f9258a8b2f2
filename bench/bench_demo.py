"""The demo's wall time: ``./pd run`` of the default test, as a user runs it, after setup.

Run inside the sourced workspace (``. scripts/env.sh``)::

    python bench/bench_demo.py [--repeats 3] [--domain-id 69] [--no-save]

or ``./pd bench`` (which passes its options to every bench: unknown ones are ignored here).

It is a measurement, not a test: it asserts nothing. ``scripts/setup.sh`` runs once first (so
nothing is built while timing), then ``./pd run --out DIR`` of the default test (bridge and
simulated specimen, figures on) runs ``--repeats`` times, each timed from the command's start
to its exit, ``./pd``'s own setup check included. Per run it prints the wall time, when the
summary line (``run_test: finished: ...``) appeared, the stepping loop's time
(``summary.json``: ``wall_time``), the start-up (the command's start to the first step, from
the integrator's ``running: step 0`` log line) and whether every figure was in the run folder
at exit. Figures merged into ``bench/results.json``: ``demo_wall_s`` (best of the repeats),
``demo_summary_line_s``, ``demo_loop_s``, ``demo_startup_s`` (of the same run) and
``demo_figures_complete``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from _results import merge_results
from bench_loop import stop_process

REPO = Path(__file__).resolve().parents[1]
FIGURES = ('displacement.png', 'velocity.png', 'acceleration.png', 'force_deformation.png',
           'energy.png', 'tracking.png')
TIMEOUT = 120.0
_SUMMARY = re.compile(r'^run_test: \w+.*: \d+ steps in ')
_FIRST_STEP = re.compile(r'running: step 0 of ')


@dataclass
class DemoRun:
    """One ``./pd run``."""

    wall_s: float
    summary_line_s: float | None
    startup_s: float | None
    loop_s: float | None
    figures_complete: bool
    code: int | None


def _watch(stream: IO[bytes], started: float, marks: dict[str, float], log: list[str]) -> None:
    """Read ``stream`` to its end; note when the first step and the summary line appeared."""
    for raw in iter(stream.readline, b''):
        now = time.perf_counter() - started
        line = raw.decode('utf-8', errors='replace').rstrip()
        log.append(line)
        if 'startup' not in marks and _FIRST_STEP.search(line):
            marks['startup'] = now
        if 'summary' not in marks and _SUMMARY.match(line):
            marks['summary'] = now


def demo_run(out: Path, domain_id: int) -> DemoRun:
    """``./pd run --out OUT`` of the default test, timed from start to exit."""
    env = {**os.environ, 'ROS_DOMAIN_ID': str(domain_id)}
    env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    marks: dict[str, float] = {}
    log: list[str] = []
    started = time.perf_counter()
    process = subprocess.Popen([str(REPO / 'pd'), 'run', '--out', str(out)], env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               start_new_session=True)
    reader = threading.Thread(target=_watch, args=(process.stdout, started, marks, log),
                              daemon=True)
    reader.start()
    try:
        code: int | None = process.wait(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        stop_process(process)
        code = None
    wall = time.perf_counter() - started
    figures = all((out / name).is_file() for name in FIGURES)
    reader.join(timeout=5.0)
    loop = None
    with contextlib.suppress(OSError, ValueError):
        loop = float(json.loads((out / 'summary.json').read_text(encoding='utf-8'))['wall_time'])
    if code != 0:
        print('\n'.join(log[-20:]), file=sys.stderr)
    return DemoRun(wall, marks.get('summary'), marks.get('startup'), loop, figures, code)


def _seconds(value: float | None) -> str:
    return f'{value:6.2f} s' if value is not None else '     n/a'


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """Command-line arguments (unknown ones, meant for the other benches, are ignored)."""
    parser = argparse.ArgumentParser(prog='bench_demo', description="./pd run's wall time "
                                     '(the default test, after setup): best of the repeats.')
    parser.add_argument('--repeats', type=int, default=3, help='runs (default 3)')
    parser.add_argument('--domain-id', type=int, default=69,
                        help='ROS_DOMAIN_ID of the runs (default 69)')
    parser.add_argument('--no-save', action='store_true',
                        help='print only, do not merge into bench/results.json')
    args, _unknown = parser.parse_known_args(argv)
    return args


def main(argv: list[str] | None = None) -> int:
    """Set up, run the demo ``--repeats`` times, print and save the figures."""
    args = parse_args(argv)
    subprocess.run(['bash', str(REPO / 'scripts' / 'setup.sh')], check=True)
    load = ', '.join(f'{value:.2f}' for value in os.getloadavg())
    print(f'pd bench_demo: ./pd run of the default test, {args.repeats} runs, '
          f'{os.cpu_count()} cores, load average before: {load}')
    print(f'{"run":>4} {"wall":>8} {"summary":>8} {"start-up":>8} {"loop":>8}  figures')
    runs: list[DemoRun] = []
    with tempfile.TemporaryDirectory(prefix='pd-demo-') as work:
        for number in range(1, args.repeats + 1):
            run = demo_run(Path(work) / f'run{number}', args.domain_id)
            runs.append(run)
            status = 'all' if run.figures_complete else 'MISSING'
            if run.code != 0:
                status += f' (exit {run.code})'
            print(f'{number:>4} {_seconds(run.wall_s)} {_seconds(run.summary_line_s)} '
                  f'{_seconds(run.startup_s)} {_seconds(run.loop_s)}  {status}', flush=True)
    good = [run for run in runs if run.code == 0] or runs
    best = min(good, key=lambda run: run.wall_s)
    print(f'demo_wall_s {best.wall_s:.2f} (best of {len(runs)}; summary line at '
          f'{_seconds(best.summary_line_s).strip()}, first step at '
          f'{_seconds(best.startup_s).strip()}, loop {_seconds(best.loop_s).strip()})')
    if not args.no_save:
        merge_results({'demo_wall_s': round(best.wall_s, 3),
                       'demo_summary_line_s': (round(best.summary_line_s, 3)
                                               if best.summary_line_s is not None else None),
                       'demo_startup_s': (round(best.startup_s, 3)
                                          if best.startup_s is not None else None),
                       'demo_loop_s': (round(best.loop_s, 3)
                                       if best.loop_s is not None else None),
                       'demo_figures_complete': all(run.figures_complete for run in good)})
    return 0 if all(run.code == 0 for run in runs) else 1


if __name__ == '__main__':
    sys.exit(main())
