"""The vRTHS benchmark's ``./pd`` subcommands (registered under ``pd.commands`` in setup.py).

Declarations only (no imports beyond :mod:`pd_common.cli`): ``./pd help`` reads them without
loading the tools. See :mod:`pd_common.cli`.
"""

from __future__ import annotations

from pd_common.cli import CliCommand

PACKAGE = 'pd_rths_benchmark'

RTHS_BENCHMARK = CliCommand(
    'rths_benchmark', 'the vRTHS benchmark: J1-J9, figures',
    '[--case N] [--controller NAME] [--loop benchmark|native] [--record F] '
    '[--perturbed N --seed S] [--out DIR]', PACKAGE, order=63)
