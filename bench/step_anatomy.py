"""Where a step's wall time goes through the graph: each node's work before and after its answer,
and the publish call itself, beside the same figures of the raw ping-pong floor.

Run inside the sourced workspace (``. scripts/env.sh``)::

    python bench/step_anatomy.py [--site direct|bridge|rths] [--runs 2] [--pings 3000] [--no-save]

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

``--site rths``: the real-time run instead (``bench_rths.py``'s quick vRTHS case 1 against the
wall clock through the graph, placed as there), split along the round trip the actuator waits
for: from a step's measurement (the end of its tick) to the answer's publish, the publish, DDS
to the integrator, the integrator's work to its command's publish, that publish, DDS to the
bridge, and the bridge's work to the target handed to the ticking loop; medians, p90 and p99
of each, matched step by step on the machine's monotonic clock. Figures:
``rths_anatomy_<part>_p50_us`` and ``_p90_us``, ``rths_anatomy_slowdown_fraction`` (the
probed run's).

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

import numpy as np

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


#: The parts of the real-time round trip, in order (``--site rths``).
CHAIN = ('measurement to answer', 'answer publish', 'DDS to the integrator', 'integrator work',
         'command publish', 'DDS to the bridge', 'bridge to target', 'measurement to target')


def _before(times: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Index of the last of ``times`` (sorted) at or before each ``at`` (-1: none)."""
    return np.searchsorted(times, at, side='right') - 1


def real_time_chain(nodes: dict[str, dict[str, list]]) -> dict[str, np.ndarray]:
    """The round trip's parts per step, µs: each target matched backwards along its chain.

    For a target handed to the bridge's loop: the bridge's last command callback before it, the
    integrator's last command publish ending before that, the integrator's last feedback
    callback before that publish, the bridge's last answer publish ending before that, and the
    step's measurement (kept with the target). Steps whose chain is not in order are left out.
    """
    bridge, integrator = nodes.get('bridge', {}), nodes.get('integrator', {})
    targets = np.array(bridge.get('chain_target', []), dtype=np.int64).reshape(-1, 2)

    def publishes(samples: dict[str, list], which: str) -> tuple[np.ndarray, np.ndarray]:
        rows = sorted((start, end) for start, end, kind in samples.get('chain_publish', [])
                      if kind == which)
        data = np.array(rows, dtype=np.int64).reshape(-1, 2)
        return data[:, 0], data[:, 1]

    def callbacks(samples: dict[str, list], which: str) -> np.ndarray:
        return np.array(sorted(t for t, kind in samples.get('chain_callback', [])
                               if kind == which), dtype=np.int64)

    answer_start, answer_end = publishes(bridge, 'feedback')
    command_start, command_end = publishes(integrator, 'command')
    bridge_in, integrator_in = callbacks(bridge, 'command'), callbacks(integrator, 'feedback')
    if not (len(targets) and len(answer_end) and len(command_end) and len(bridge_in)
            and len(integrator_in)):
        return {}
    target, measured = targets[:, 0], targets[:, 1]
    b_in = _before(bridge_in, target)
    c_pub = _before(command_end, bridge_in[b_in])
    i_in = _before(integrator_in, command_start[c_pub])
    a_pub = _before(answer_end, integrator_in[i_in])
    valid = (b_in >= 0) & (c_pub >= 0) & (i_in >= 0) & (a_pub >= 0)
    times = [measured, answer_start[a_pub], answer_end[a_pub], integrator_in[i_in],
             command_start[c_pub], command_end[c_pub], bridge_in[b_in], target]
    steps = np.diff(np.array(times), axis=0)  # one row per part, one column per step
    valid &= (steps >= 0).all(axis=0)
    parts = {name: steps[index][valid] / 1e3 for index, name in enumerate(CHAIN[:-1])}
    parts[CHAIN[-1]] = (target - measured)[valid] / 1e3
    return parts


def rths_main(args: argparse.Namespace) -> int:
    """``--site rths``: the real-time round trip, part by part."""
    from bench_rths import PLACED, benchmark_file, graph

    print(machine_header(args.domain_id))
    print('test: bench_rths.py --quick (vRTHS case 1, 4096 Hz ticks, 1024 Hz steps) in real '
          f'time through the graph, --cpus {" --cpus ".join(PLACED)}\n')
    with tempfile.TemporaryDirectory(prefix='pd-anatomy-') as name:
        work = Path(name)
        _probe_environment(work)
        report, _, tail = graph(benchmark_file(True, clock='realtime'), args.domain_id, work,
                                timeout=300.0, cpus=PLACED)
        parts = real_time_chain(read_samples(work))
    if report is None or not parts:
        print(f'step_anatomy: error: the real-time run left no time line; it said:\n{tail}',
              file=sys.stderr)
        return 1
    figures: dict[str, float] = {}
    print(f'{"part of the round trip":<24} {"p50":>8} {"p90":>8} {"p99":>8}   (us, '
          f'{len(parts[CHAIN[-1]]):,} steps)')
    for part in CHAIN:
        p50, p90, p99 = np.percentile(parts[part], [50.0, 90.0, 99.0])
        print(f'{part:<24} {p50:8.1f} {p90:8.1f} {p99:8.1f}')
        key = part.replace(' ', '_')
        figures[f'rths_anatomy_{key}_p50_us'] = round(float(p50), 1)
        figures[f'rths_anatomy_{key}_p90_us'] = round(float(p90), 1)
    slowed = float(report['slowdown_fraction'])
    print(f'\nthe probed run: slowed {100 * slowed:.2f} % of its ticks, target latency p50 / '
          f'p99 {report.get("target_latency_p50_us", float("nan")):.0f} / '
          f'{report.get("target_latency_p99_us", float("nan")):.0f} us (its own count); the '
          'actuator brakes when a target comes later than about 700 us after the measurement')
    figures['rths_anatomy_slowdown_fraction'] = round(slowed, 6)
    if not args.no_save:
        merge_results(figures, drop_prefixes=('rths_anatomy_',))
        print(f'written to {REPO / "bench" / "results.json"}')
    return 0


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """Command-line arguments."""
    parser = argparse.ArgumentParser(prog='step_anatomy', description=__doc__.splitlines()[0])
    parser.add_argument('--site', choices=('direct', 'bridge', 'rths'), default='direct')
    parser.add_argument('--runs', type=int, default=2, help='graph runs, the fastest kept')
    parser.add_argument('--pings', type=int, default=3000, help='ping-pong round trips')
    parser.add_argument('--domain-id', type=int, default=78)
    parser.add_argument('--no-save', action='store_true', help='do not touch results.json')
    parser.add_argument('--no-authentication', action='store_true',
                        help="run_test's --no-authentication (what signing costs, by "
                             'difference; implies --no-save)')
    args = parser.parse_args(argv)
    args.no_save = args.no_save or args.no_authentication
    if args.runs < 1 or args.pings < 100:
        parser.error('--runs: at least 1; --pings: at least 100')
    if args.no_authentication and args.site == 'rths':
        parser.error('--no-authentication: for --site direct or bridge (the real-time run is '
                     "bench_rths.py's, signed)")
    return args


def main(argv: list[str] | None = None) -> int:
    """Measure and print the table."""
    args = parse_args(argv)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    if args.site == 'rths':
        return rths_main(args)
    print(machine_header(args.domain_id))
    extra = ['--no-authentication'] if args.no_authentication else []
    print(f'test: {DEFAULT_TEST.relative_to(REPO)} through run_test --site {args.site} '
          f'{" ".join(extra)}\n')
    figures: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix='pd-anatomy-') as name:
        work = Path(name)
        best: tuple[float, dict[str, dict[str, list[int]]]] | None = None
        for index in range(args.runs):
            probe = work / f'graph-{index}'
            probe.mkdir()
            _probe_environment(probe)
            out = work / f'run-{index}'
            row = graph_run(args.site, extra, args.domain_id, out, timeout=300.0)
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
