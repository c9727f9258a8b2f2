"""The pre-test's ``./pd`` subcommands (registered under ``pd.commands`` in setup.py).

Declarations only (no imports beyond :mod:`pd_common.cli`): ``./pd help`` reads them without
loading the tools. See :mod:`pd_common.cli`.
"""

from __future__ import annotations

from pd_common.cli import CliCommand

PACKAGE = 'pd_pretest'

PRETEST = CliCommand(
    'pretest', "the test's model under many records, scales and parameters at once: strokes, "
    "velocities, forces against the bridge's limits, response spectra",
    'TEST_FILE [--records ...] [--scales A:B:S] [--vary ...]', PACKAGE, order=40)
