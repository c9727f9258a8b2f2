"""What a microsecond of work costs a woken node: the raw ping-pong with work before each answer.

Run inside the sourced workspace (``. scripts/env.sh``)::

    python bench/bench_wakeup.py [--quick] [--rounds 5] [--pings 3000] [--domain-id 63]
                                 [--no-save]

or ``./pd bench``. A measurement, not a test: it asserts nothing. The floor of ``bench_loop``
(two processes, raw CDR bytes, reliable keep-all, EventsExecutor) is run with its echo doing
work before each answer (``bench/_echo_work.py``): nothing; a busy wait of 25, 50 and 100 µs
(time alone: the pinger sleeps longer); and one or two of a simulator's step work with the
nodes' own pieces (decode, admit, serve, encode and sign). The configurations alternate round
by round and each figure is the median over rounds of the ping-pong's median round trip. The
same work run back to back in this process gives its hot cost. Printed: what each added to
the round trip, and per µs of hot work.

The graph's step is this ping-pong with the two nodes' step work in it, so the figures say how
much step work a graph can carry within ``graph_direct_over_raw_floor`` ≤ 1.3: the budget is
0.3 of the floor over the cost per µs of hot work, beside both sides' step work in one process
(``bench/_wire_loop.py``).

Figures merged into ``bench/results.json`` (unless ``--no-save``): ``wakeup_floor_round_trip_us``
(no work), ``wakeup_spin_added_per_us`` (the busy waits' round-trip increase per µs waited, a
least-squares slope through zero), ``wakeup_step_work_hot_us`` (one simulator step in one
process), ``wakeup_step_work_added_us`` and ``wakeup_two_steps_added_us`` (round-trip
increase with one and two steps of work), ``wakeup_step_work_added_per_hot_us`` (the first
over the hot cost), ``wakeup_both_sides_work_hot_us`` (``_wire_loop``'s step),
``wakeup_raw_goal_work_budget_us`` (0.3 × floor / added per hot µs).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

from _echo_work import hot_cost_us
from _results import merge_results
from bench_loop import DEFAULT_TEST, _ping, machine_header, remove_stale_segments, shm_snapshot

CONFIGURATIONS = (('no work', None), ('busy wait 25 us', 'spin:25'),
                  ('busy wait 50 us', 'spin:50'), ('busy wait 100 us', 'spin:100'),
                  ('1 simulator step', 'steps:1'), ('2 simulator steps', 'steps:2'))
RAW_GOAL = 1.3  # graph_direct_over_raw_floor


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--rounds', type=int, default=5, help='rounds of every configuration')
    parser.add_argument('--pings', type=int, default=3000, help='round trips per ping-pong')
    parser.add_argument('--domain-id', type=int, default=63)
    parser.add_argument('--quick', action='store_true', help='2 rounds of 1000 round trips')
    parser.add_argument('--no-save', action='store_true', help='do not write results.json')
    args, _ = parser.parse_known_args(argv)  # (./pd bench passes every bench its options)
    if args.quick:
        args.rounds, args.pings = 2, 1000
    if args.rounds < 1 or args.pings < 100:
        parser.error('--rounds must be >= 1 and --pings >= 100')
    return args


def both_sides_work_us() -> float:
    """Both sides' step work in one process [µs], best of 3 (``_wire_loop``)."""
    from _wire_loop import wire_loop
    from pd_core.run.test_file import load_test_file

    definition = load_test_file(DEFAULT_TEST, {})
    best = float('inf')
    with tempfile.TemporaryDirectory() as folder:
        for index in range(3):
            seconds, steps = wire_loop(definition, Path(folder) / f'journal-{index}.pdj')
            best = min(best, seconds / max(steps, 1))
    return best * 1e6


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    print(machine_header(args.domain_id))
    medians: dict[str, list[float]] = {label: [] for label, _ in CONFIGURATIONS}
    before = shm_snapshot()
    try:
        for round_ in range(args.rounds):
            for label, work in CONFIGURATIONS:
                result = _ping('raw', args.domain_id, args.pings, 'demo', work=work)
                if result.samples_s:
                    medians[label].append(statistics.median(result.samples_s) * 1e6)
                print(f'  round {round_ + 1}: {label:<18} '
                      f'{medians[label][-1] if result.samples_s else float("nan"):7.1f} us'
                      + (f' ({result.lost} lost)' if result.lost else ''), flush=True)
    finally:
        remove_stale_segments(before, args.domain_id)
    if not all(medians.values()):
        print('bench_wakeup: a configuration got no answers; nothing saved', file=sys.stderr)
        return 1
    trip = {label: statistics.median(values) for label, values in medians.items()}
    floor = trip['no work']
    added = {label: value - floor for label, value in trip.items()}
    spins = [(float(work.split(':')[1]), added[label]) for label, work in CONFIGURATIONS
             if work and work.startswith('spin:')]
    spin_slope = sum(x * y for x, y in spins) / sum(x * x for x, _ in spins)
    step_hot = hot_cost_us('steps:1')
    per_hot = added['1 simulator step'] / step_hot
    both_sides = both_sides_work_us()
    budget = (RAW_GOAL - 1.0) * floor / per_hot if per_hot > 0 else float('inf')

    print(f'\nround trip, median over {args.rounds} rounds of {args.pings} (raw bytes, '
          'reliable keep-all, EventsExecutor):')
    for label, _ in CONFIGURATIONS:
        print(f'  {label:<18} {trip[label]:7.1f} us   added {added[label]:+7.1f} us')
    print(f'  busy waits: {spin_slope:.2f} us of round trip per us waited (slope through 0)')
    print(f'  one simulator step: {step_hot:.1f} us hot in one process, '
          f'{added["1 simulator step"]:+.1f} us of round trip ({per_hot:.2f} per hot us); '
          f'a second step adds {added["2 simulator steps"] - added["1 simulator step"]:+.1f} us')
    print(f'  both sides\' step work in one process (_wire_loop): {both_sides:.1f} us; '
          f'within graph_direct_over_raw_floor <= {RAW_GOAL} a graph carries about '
          f'{budget:.0f} us of hot step work at {per_hot:.2f} us per hot us')
    if not args.no_save:
        merge_results({
            'wakeup_floor_round_trip_us': round(floor, 1),
            'wakeup_spin_added_per_us': round(spin_slope, 3),
            'wakeup_step_work_hot_us': round(step_hot, 2),
            'wakeup_step_work_added_us': round(added['1 simulator step'], 1),
            'wakeup_two_steps_added_us': round(added['2 simulator steps'], 1),
            'wakeup_step_work_added_per_hot_us': round(per_hot, 3),
            'wakeup_both_sides_work_hot_us': round(both_sides, 1),
            'wakeup_raw_goal_work_budget_us': round(budget, 1),
        })
    return 0


if __name__ == '__main__':
    sys.exit(main())
