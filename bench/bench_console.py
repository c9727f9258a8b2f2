"""The live console's cost to a running test: steps/s with and without it.

Run inside the sourced workspace (``. scripts/env.sh``)::

    python bench/bench_console.py [--quick] [--repeats 3] [--domain-id 189] [--duration S]

or ``./pd bench`` (which passes its options to every bench: unknown ones are ignored here).

It is a measurement, not a test: it asserts nothing. The default test runs through the graph
(``run_test --no-figures``, bridge + simulator) in three set-ups, interleaved run by run so that
the machine's load drifts alike for all: (a) no console; (b) ``./pd console`` subscribed to the
test, no page open; (c) the console with a page open in headless Chromium (Debian's
``chromium`` and ``chromium-driver``; skipped without them) drawing every frame. Steps/s are
``steps / wall_time`` of ``summary.json``; the best of ``--repeats`` runs per set-up is kept,
and the slowdown of (b) and (c) against (a) is printed and merged into ``bench/results.json``
(``console_*``).
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
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from _results import merge_results
from bench_loop import stop_process

REPO = Path(__file__).resolve().parents[1]
INSTALL = REPO / 'ros2_ws' / 'install'
CHROMIUM = Path('/usr/bin/chromium')
CHROMEDRIVER = Path('/usr/bin/chromedriver')
MODES = ('none', 'console', 'page')


@contextlib.contextmanager
def browser(work: Path) -> Iterator[Any]:
    """Headless Chromium, or ``None`` without it."""
    if not (CHROMIUM.is_file() and CHROMEDRIVER.is_file()):
        yield None
        return
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for argument in ('--headless', '--no-sandbox', '--disable-gpu', '--disable-quic',
                     '--no-first-run', '--disable-background-networking',
                     '--disable-component-update', '--disable-sync',
                     f'--user-data-dir={work / "chromium"}', '--window-size=1400,1500'):
        options.add_argument(argument)
    driver = webdriver.Chrome(options=options, service=Service(str(CHROMEDRIVER)))
    try:
        yield driver
    finally:
        driver.quit()


def one_run(mode: str, test_file: Path, env: dict[str, str], work: Path, index: int,
            driver: Any) -> tuple[float, int]:
    """One test with ``mode``'s set-up; (steps/s, frames the page drew)."""
    out = work / f'{mode}-{index}'
    console = None
    frames = 0
    cpu_s = cpu_start = 0.0
    try:
        if mode != 'none':
            log = (work / f'console-{mode}-{index}.log').open('wb')
            console = subprocess.Popen(
                [str(INSTALL / 'pd_console' / 'lib' / 'pd_console' / 'console'),
                 '--port', '0'], env=env, stdout=log, stderr=subprocess.STDOUT,
                start_new_session=True)
            deadline = time.monotonic() + 20.0
            url = ''
            while not url and time.monotonic() < deadline:
                time.sleep(0.1)
                found = re.search(r'serving (http://\S+)', Path(log.name).read_text())
                url = found.group(1) if found else ''
            if not url:
                msg = f'the console did not start: {Path(log.name).read_text()[-500:]}'
                raise RuntimeError(msg)
            if mode == 'page':
                driver.get(url)
            time.sleep(1.0)
            cpu_start = cpu_seconds(console.pid)
        launcher = subprocess.run(
            [str(INSTALL / 'pd_bringup' / 'lib' / 'pd_bringup' / 'run_test'), str(test_file),
             '--out', str(out), '--no-figures'], env=env, stdout=subprocess.DEVNULL,
            stderr=subprocess.STDOUT, start_new_session=True, timeout=300, check=False)
        if mode == 'page':
            frames = int(driver.execute_script('return Number(document.body.dataset.frames)'))
        if console is not None:
            cpu_s = cpu_seconds(console.pid) - cpu_start
    finally:
        if console is not None:
            stop_process(console)
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    if launcher.returncode != 0 or summary.get('state') != 'finished':
        msg = f'{mode}: run_test exited {launcher.returncode} ({summary.get("state")})'
        raise RuntimeError(msg)
    rate = float(summary['steps']) / float(summary['wall_time'])
    if console is not None:
        print(f'    console process: {cpu_s:.2f} s CPU for {summary["steps"]} steps', flush=True)
    return rate, frames


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of process ``pid`` so far (Linux ``/proc``)."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='one run per set-up, 10 s tests')
    parser.add_argument('--repeats', type=int, default=None, help='runs per set-up (3)')
    parser.add_argument('--domain-id', type=int, default=189)
    parser.add_argument('--duration', type=float, default=None,
                        help='s of simulated test (default: the whole record)')
    args, _ = parser.parse_known_args()
    if args.repeats is None:
        args.repeats = 1 if args.quick else 3
    if args.quick and args.duration is None:
        args.duration = 10.0
    import yaml

    raw = yaml.safe_load((REPO / 'src' / 'pd_integrator' / 'config' / 'default_test.yaml')
                         .read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(REPO / 'src' / 'pd_integrator' / 'data'
                                       / 'ground_motions' / 'elcentro_1940_ns_chopra.csv')
    if args.duration is not None:
        raw['test']['duration'] = args.duration
    rates: dict[str, list[float]] = {mode: [] for mode in MODES}
    frames: list[int] = []
    with tempfile.TemporaryDirectory(prefix='bench-console-') as name:
        work = Path(name)
        test_file = work / 'test.yaml'
        test_file.write_text(yaml.safe_dump(raw), encoding='utf-8')
        env = dict(os.environ, ROS_DOMAIN_ID=str(args.domain_id),
                   XDG_STATE_HOME=str(work / 'state'))
        env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
        key = work / 'keys' / 'bench.key'
        from pd_common.auth import generate_key

        generate_key(key)
        env['PD_KEY_FILE'] = str(key)
        with browser(work) as driver:
            modes = MODES if driver is not None else MODES[:2]
            for index in range(args.repeats):
                for mode in modes:
                    rate, drawn = one_run(mode, test_file, env, work, index, driver)
                    rates[mode].append(rate)
                    if mode == 'page':
                        frames.append(drawn)
                    print(f'  run {index + 1} {mode:8s} {rate:8.1f} steps/s', flush=True)
        subprocess.run([sys.executable, str(REPO / 'scripts' / 'clean_shm.py')], check=False)
    best = {mode: max(values) for mode, values in rates.items() if values}
    print('console cost to the test (default test through the graph, best of '
          f'{args.repeats}):')
    figures: dict[str, object] = {}
    for mode, rate in best.items():
        slower = 100.0 * (1.0 - rate / best['none'])
        label = {'none': 'no console', 'console': 'console, no page',
                 'page': 'console + page in Chromium'}[mode]
        extra = f', {max(frames)} frames drawn' if mode == 'page' and frames else ''
        print(f'  {label:28s} {rate:8.1f} steps/s  {slower:+6.1f} % slower{extra}')
        figures[f'console_{mode}_steps_per_s'] = round(rate, 1)
        if mode != 'none':
            figures[f'console_{mode}_slowdown_percent'] = round(slower, 2)
    merge_results(figures)
    return 0


if __name__ == '__main__':
    sys.exit(main())
