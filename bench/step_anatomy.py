"""Where a step's wall time goes through the graph: each node's work before and after its answer,
and the publish call itself, beside the same figures of the raw ping-pong floor.

Run inside the sourced workspace (``. scripts/env.sh``)::

    python bench/step_anatomy.py [--site direct|bridge] [--runs 2] [--pings 3000] [--no-save]

A measurement, not a test: it asserts nothing. The processes it starts (``run_test --site SITE
--no-figures`` on the default test, and the ping-pong's echo) load the probe in
``bench/_anatomy`` (``sitecustomize``: it times ``rclpy``'s publish and the nodes' raw
callbacks; see that file). Per node it prints the medians and 90th percentiles of: the work
from the arrival of a message to the publish of the answer (``before``), the publish call
(``publish``), and the work after it (``after``, done while the other side works). The step's
critical path is roughly the integrator's and the specimen side's ``before`` + ``publish``,
plus the wake-ups the publishes cause: on this machine a publish costs more the longer the
receiving process has been idle (a virtual CPU that has halted is slow to wake), so the
ping-pong's echo, which answers at once, publishes faster than a node that first works.

Figures merged into ``bench/results.json`` (unless ``--no-save``): ``anatomy_<node>_before_us``,
``anatomy_<node>_publish_us``, ``anatomy_<node>_after_us`` (medians, µs; node:
``integrator``, ``specimen``, ``bridge``), ``anatomy_graph_us_per_step`` (the run's wall time
per step), ``anatomy_floor_round_trip_us`` and ``anatomy_floor_publish_us`` (the raw
ping-pong's median round trip and its echo's median publish).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

from _results import merge_results
from bench_loop import DEFAULT_TEST, REPO, _ping, graph_run, machine_header, percentile

PROBE = Path(__file__).resolve().parent / '_anatomy'
PROCESSES = {'pd_integrator': 'integrator', 'pd_specimen_sim': 'specimen',
             'pd_actuator_bridge': 'bridge', '-c': 'floor echo'}
PARTS = ('before_publish', 'publish', 'after_publish')


def _quantile(values: list[int], q: float) -> float:
    """The ``q`` quantile (0..1) of ns samples, in µs (0 for none)."""
    return percentile(values, q * 100.0) / 1e3 if values else 0.0


def read_samples(folder: Path) -> dict[str, dict[str, list[int]]]:
    """The probe's samples per process (named as :data:`PROCESSES` names them)."""
    found: dict[str, dict[str, list[int]]] = {}
    for path in sorted(folder.glob('*.json')):
        name = path.stem.rsplit('-', 1)[0]
        found[PROCESSES.get(name, name)] = json.loads(path.read_text(encoding='utf-8'))
    return found


def _probe_environment(folder: Path) -> None:
    """Make the processes started from here load the probe and write into ``folder``."""
    os.environ['PD_ANATOMY_DIR'] = str(folder)
    os.environ['PYTHONPATH'] = os.pathsep.join(
        part for part in (str(PROBE), os.environ.get('PYTHONPATH', '')) if part)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """Command-line arguments."""
    parser = argparse.ArgumentParser(prog='step_anatomy', description=__doc__.splitlines()[0])
    parser.add_argument('--site', choices=('direct', 'bridge'), default='direct')
    parser.add_argument('--runs', type=int, default=2, help='graph runs, the fastest kept')
    parser.add_argument('--pings', type=int, default=3000, help='ping-pong round trips')
    parser.add_argument('--domain-id', type=int, default=78)
    parser.add_argument('--no-save', action='store_true', help='do not touch results.json')
    args = parser.parse_args(argv)
    if args.runs < 1 or args.pings < 100:
        parser.error('--runs: at least 1; --pings: at least 100')
    return args


def main(argv: list[str] | None = None) -> int:
    """Measure and print the table."""
    args = parse_args(argv)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    print(machine_header(args.domain_id))
    print(f'test: {DEFAULT_TEST.relative_to(REPO)} through run_test --site {args.site}\n')
    figures: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix='pd-anatomy-') as name:
        work = Path(name)
        best: tuple[float, dict[str, dict[str, list[int]]]] | None = None
        for index in range(args.runs):
            probe = work / f'graph-{index}'
            probe.mkdir()
            _probe_environment(probe)
            out = work / f'run-{index}'
            row = graph_run(args.site, [], args.domain_id, out, timeout=300.0)
            if row.rate is None:
                print(f'run {index + 1}: {row.note}')
                continue
            if best is None or 1e6 / row.rate < best[0]:
                best = (1e6 / row.rate, read_samples(probe))
        probe = work / 'floor'
        probe.mkdir()
        _probe_environment(probe)
        ping = _ping('raw', args.domain_id, args.pings, 'thesis-5.1-elcentro')
        floor = read_samples(probe).get('floor echo', {})
    if best is None:
        print('step_anatomy: error: no graph run finished', file=sys.stderr)
        return 1
    per_step, nodes = best
    rows = [*[(node, samples) for node, samples in nodes.items()], ('floor echo', floor)]
    print(f'{"process":<12} {"answers":>8}   ' + '   '.join(
        f'{part.replace("_publish", ""):>16}' for part in PARTS) + '   (median / p90, us)')
    for node, samples in rows:
        if not samples:
            continue
        cells = [f'{_quantile(samples[part], 0.5):7.1f} /{_quantile(samples[part], 0.9):7.1f}'
                 for part in PARTS]
        print(f'{node:<12} {len(samples["publish"]):>8,}   ' + '   '.join(
            f'{cell:>16}' for cell in cells))
        if node != 'floor echo':
            for part in PARTS:
                key = part.replace('_publish', '') if part != 'publish' else 'publish'
                figures[f'anatomy_{node}_{key}_us'] = round(_quantile(samples[part], 0.5), 1)
    rt = percentile(ping.samples_s, 50.0) * 1e6 if ping.samples_s else 0.0
    critical = sum(_quantile(samples[part], 0.5) for samples in nodes.values()
                   for part in ('before_publish', 'publish'))
    print(f'\ngraph: {per_step:.0f} us a step (wall time / steps, the fastest of {args.runs}); '
          f'the nodes\' before + publish medians add up to {critical:.0f} us')
    print(f'floor: raw ping-pong median round trip {rt:.0f} us; its echo publishes in '
          f'{_quantile(floor.get("publish", []), 0.5):.0f} us (median)')
    figures.update(anatomy_graph_us_per_step=round(per_step, 1),
                   anatomy_floor_round_trip_us=round(rt, 1),
                   anatomy_floor_publish_us=round(_quantile(floor.get('publish', []), 0.5), 1))
    if not args.no_save:
        merge_results(figures, drop_prefixes=('anatomy_',))
        print(f'written to {REPO / "bench" / "results.json"}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
