"""The cost of authentication: per-message sign and verify times, and graph steps/s with and
without it, in one run (``./pd bench`` runs it after the loop and substructure benches).

    python bench/bench_security.py [--quick] [--domain-id 64] [--graph-runs 2]

Figures (printed, and merged into ``bench/results.json`` under the names in brackets):

* sign / verify of one SDOF ``StepCommand`` and one ``StepFeedback``: the canonical encoding
  plus HMAC-SHA256, as the nodes do them [``auth_sign_command_us``, ``auth_verify_command_us``,
  ``auth_sign_feedback_us``, ``auth_verify_feedback_us``], mean over 20,000 (5,000 with
  ``--quick``);
* the default test through integrator → bridge → simulator, ``run_test --site bridge``, best
  of ``--graph-runs``, with authentication (a per-test key) and with ``--no-authentication``
  [``graph_bridge_steps_per_s_auth``, ``graph_bridge_steps_per_s_no_auth``].

A measurement, not a test: it asserts nothing.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from _message_costs import message_costs
from _results import RESULTS, merge_results
from bench_loop import graph_run


def main(argv: list[str] | None = None) -> int:
    """Entry point."""
    parser = argparse.ArgumentParser(prog='bench_security', description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='fewer calls, a 5 s test')
    parser.add_argument('--domain-id', type=int, default=64)
    parser.add_argument('--graph-runs', type=int, default=None)
    args = parser.parse_args(argv)
    count = 5000 if args.quick else 20000
    runs = args.graph_runs or (1 if args.quick else 2)
    figures: dict[str, float | None] = dict(message_costs(count))
    print('authentication cost (HMAC-SHA256 over the canonical fields):')
    for name, value in figures.items():
        print(f'  {name:<28} {value:8.2f} us')
    duration = ['-p', 'duration:=5.0'] if args.quick else []
    with tempfile.TemporaryDirectory(prefix='pd-bench-auth-') as tmp:
        for label, extra in (('auth', []), ('no_auth', ['--no-authentication'])):
            rows = [graph_run('bridge', [*duration, *extra], args.domain_id,
                              Path(tmp) / f'{label}-{index}', timeout=300.0)
                    for index in range(runs)]
            rates = [row.rate for row in rows if row.rate is not None]
            best = max(rates) if rates else None
            figures[f'graph_bridge_steps_per_s_{label}'] = best
            text = f'{best:,.0f} steps/s' if best else f'FAILED: {rows[-1].note}'
            print(f'  graph --site bridge, {label:<8} {text} (best of {runs}; {rows[-1].note})')
    auth, plain = (figures['graph_bridge_steps_per_s_auth'],
                   figures['graph_bridge_steps_per_s_no_auth'])
    if auth and plain:
        print(f'  authentication costs {100.0 * (1.0 - auth / plain):.1f} % of the graph rate '
              f'({1e6 / auth - 1e6 / plain:.0f} us per step)')
    merge_results(figures)
    print(f'  written to {RESULTS}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
