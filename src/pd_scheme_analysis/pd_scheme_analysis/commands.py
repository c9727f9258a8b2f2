"""The scheme analysis's ``./pd`` subcommands (registered under ``pd.commands`` in setup.py).

Declarations only (no imports beyond :mod:`pd_common.cli`): ``./pd help`` reads them without
loading the tools. See :mod:`pd_common.cli`.
"""

from __future__ import annotations

from pd_common.cli import CliCommand

PACKAGE = 'pd_scheme_analysis'

ANALYZE = CliCommand('analyze', 'stability and accuracy of the integration schemes',
                     '[options]', PACKAGE, order=60)
