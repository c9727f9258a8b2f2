"""Stability and accuracy of the integration schemes: ``ros2 run pd_scheme_analysis analyze``.

For each scheme (and parameter set) and each viscous damping ratio, sweeps ``Ω = ωΔt`` and
writes ``spectral_<scheme>.csv`` (spectral radius, numerical damping ratio, relative period
error), the figures ``spectral_radius.png``, ``numerical_damping.png`` and
``period_error.png``, and the thesis's Figure 3.2 (``figure_3_2_newmark_explicit.png``).
Example::

    analyze --schemes newmark_explicit,alpha_os --param alpha_os:alpha=-0.1,-0.3 --out spectra
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path
from typing import Any

from pd_core.dynamics.analysis import (
    default_parameters,
    has_amplification_matrix,
    omega_grid,
    spectral_properties,
    sweep,
)
from pd_core.errors import ConfigError, PdIntegratorError
from pd_core.schemes import SCHEMES, scheme_class

from .figures import plot_figure_3_2, plot_sweeps, write_sweep_csv

DEFAULT_OUT = 'spectral_analysis'
FIGURE_3_2 = 'figure_3_2_newmark_explicit.png'


def _value(text: str) -> Any:
    """A parameter value: int, float, ``true``/``false``, or the text itself."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    lowered = text.strip().lower()
    if lowered in ('true', 'false'):
        return lowered == 'true'
    return text.strip()


def parse_parameters(items: list[str]) -> dict[str, dict[str, list[Any]]]:
    """Parse ``scheme:name=value[,value...]`` items into values per scheme and name.

    Repeating a ``scheme:name`` adds values; every combination of the values of one scheme
    is analysed.

    Raises:
        ConfigError: On a malformed item.
    """
    parsed: dict[str, dict[str, list[Any]]] = {}
    for item in items:
        head, equals, values = item.partition('=')
        scheme, colon, name = head.partition(':')
        if not (equals and colon and scheme.strip() and name.strip() and values.strip()):
            msg = f'--param {item!r}: expected scheme:name=value[,value...]'
            raise ConfigError(msg)
        parsed.setdefault(scheme.strip(), {}).setdefault(name.strip(), []).extend(
            _value(text) for text in values.split(',') if text.strip())
    return parsed


def parameter_sets(values: dict[str, list[Any]]) -> list[dict[str, Any]]:
    """Every combination of the given values (``[{}]`` if none)."""
    names = list(values)
    return [dict(zip(names, combination))
            for combination in itertools.product(*(values[name] for name in names))]


def _with_defaults(scheme: str, parameters: dict[str, Any]) -> dict[str, Any]:
    """The given parameters completed with the scheme's defaults (for the CSV columns)."""
    defaults = {name: value for name, value in default_parameters(scheme).items()
                if value is not None}
    return {**defaults, **parameters}


def _label(scheme: str, parameters: dict[str, Any]) -> str:
    if not parameters:
        return scheme
    values = ', '.join(f'{name}={value}' for name, value in parameters.items())
    return f'{scheme} ({values})'


def _select_schemes(text: str | None, params: dict[str, dict[str, list[Any]]]) -> list[str]:
    if text is None:
        numerical = [name for name, cls in SCHEMES.items() if not cls.external]
        names = [name for name in numerical if has_amplification_matrix(name)]
        for name in numerical:
            if name not in names:
                print(f'analyze: skipping {name}: it has no amplification matrix',
                      file=sys.stderr)
    else:
        names = [name.strip() for name in text.split(',') if name.strip()]
        if not names:
            msg = '--schemes: no scheme given'
            raise ConfigError(msg)
        for name in names:
            scheme_class(name)  # unknown: ConfigError naming it
            if not has_amplification_matrix(name):
                msg = f'--schemes: scheme {name!r} has no amplification matrix'
                raise ConfigError(msg)
    for name in params:
        scheme_class(name)
        if name not in names:
            msg = f'--param: scheme {name!r} is not among the analysed schemes'
            raise ConfigError(msg)
    if not names:
        msg = 'no registered scheme has an amplification matrix'
        raise ConfigError(msg)
    return list(dict.fromkeys(names))


#: Most values of Ω in one sweep (the figures resolve a few hundred).
MAX_POINTS = 100_000


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns 0 on success, 2 on invalid input."""
    parser = argparse.ArgumentParser(prog='analyze', description=__doc__.splitlines()[0])
    parser.add_argument('--schemes', help='comma-separated scheme names (default: every '
                        'registered scheme with an amplification matrix)')
    parser.add_argument('--param', action='append', default=[], metavar='SCHEME:NAME=VALUE',
                        help='a scheme parameter; comma-separated values and repeated options '
                        'give one line per combination (default: the scheme defaults)')
    parser.add_argument('--omega-max', type=float, default=4.0,
                        help='largest Ω = ωΔt of the sweep (default: 4)')
    parser.add_argument('--points', type=int, default=400,
                        help='number of Ω values in (0, omega-max] (default: 400)')
    parser.add_argument('--xi', type=float, nargs='+', default=[0.0, 0.05],
                        help='viscous damping ratios (default: 0 0.05)')
    parser.add_argument('--out', default=DEFAULT_OUT,
                        help=f'output folder (default: {DEFAULT_OUT})')
    parser.add_argument('--no-figures', action='store_true', help='write the CSV files only')
    args = parser.parse_args(argv)
    try:
        if args.points > MAX_POINTS:  # (a typo's extra zeros would compute for hours)
            msg = f'--points: at most {MAX_POINTS:,} values of Ω, got {args.points:,}'
            raise ConfigError(msg)
        omegas = omega_grid(args.omega_max, args.points)
        for xi in args.xi:
            if not 0.0 <= xi < 1.0:
                msg = f'--xi: viscous damping ratio must be in [0, 1), got {xi:g}'
                raise ConfigError(msg)
        params = parse_parameters(args.param)
        schemes = _select_schemes(args.schemes, params)
        plan: list[tuple[str, dict[str, Any]]] = []
        for scheme in schemes:
            for parameters in parameter_sets(params.get(scheme, {})):
                spectral_properties(scheme, float(omegas[0]), args.xi[0], **parameters)
                plan.append((scheme, parameters))
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        curves: list[tuple[str, dict[str, Any]]] = []
        written: list[Path] = []
        for scheme in schemes:
            sweeps, tags = [], []
            for name, parameters in plan:
                if name != scheme:
                    continue
                for xi in dict.fromkeys(args.xi):
                    result = sweep(scheme, omegas, xi, **parameters)
                    sweeps.append(result)
                    tags.append(_with_defaults(scheme, parameters))
                    curves.append((_label(scheme, parameters), result))
            written.append(write_sweep_csv(sweeps, out / f'spectral_{scheme}.csv',
                                           parameters=tags))
        if not args.no_figures:
            written += plot_sweeps(curves, out)
            written.append(plot_figure_3_2(out / FIGURE_3_2))
    except (PdIntegratorError, ValueError, OSError) as err:
        print(f'analyze: error: {err}', file=sys.stderr)
        return 2
    xis = ', '.join(f'{xi:g}' for xi in dict.fromkeys(args.xi))
    print(f'analyze: {len(plan)} scheme/parameter set(s), ξ = {xis}, Ω in (0, '
          f'{args.omega_max:g}] ({args.points} points):')
    for path in written:
        print(f'  {path}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
