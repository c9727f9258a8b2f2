"""The studies' ``./pd`` subcommands (registered under ``pd.commands`` in setup.py).

Declarations only (no imports beyond :mod:`pd_common.cli`): ``./pd help`` reads them without
loading the tools. See :mod:`pd_common.cli`.
"""

from __future__ import annotations

from pd_common.cli import CliCommand

PACKAGE = 'pd_studies'

STUDY_CH5 = CliCommand('study_ch5', "the thesis's chapter 5 comparison", '[--records ...]',
                       PACKAGE, order=61)
STUDY_ERRORS = CliCommand('study_errors', 'growth of experimental errors (Shing & Mahin)',
                          '[options]', PACKAGE, order=62)
