"""Rebuild a run's outputs from its bag alone: ``ros2 run pd_integrator replay BAG``.

Reads the bag with ``rosbags``, re-runs the recorded commands and feedback through the same
step protocol and integrator (checking every recomputed command against the recorded one) and
writes ``response.csv``, ``summary.json`` and the figures.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .core.errors import PdIntegratorError
from .core.run.runner import rebuild_outputs


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns 0 on success, 2 if the bag cannot be replayed."""
    parser = argparse.ArgumentParser(prog='replay', description=__doc__.splitlines()[0])
    parser.add_argument('bag', help="the run's bag folder (e.g. runs/<run>/bag)")
    parser.add_argument('--out', help='output folder (default: <bag>/../replay)')
    parser.add_argument('--no-figures', action='store_true', help='skip the PNG figures')
    args = parser.parse_args(argv)
    bag = Path(args.bag)
    out = Path(args.out) if args.out else bag.resolve().parent / 'replay'
    try:
        result = rebuild_outputs(bag, out, figures=not args.no_figures)
    except (PdIntegratorError, ValueError) as err:
        print(f'replay: error: {err}', file=sys.stderr)
        return 2
    print(f'replayed {result.summary["steps"]} steps ({result.summary["state"]}); outputs in '
          f'{result.directory}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
