"""The console's ``./pd`` subcommands (registered under ``pd.commands`` in setup.py).

Declarations only (no imports beyond :mod:`pd_common.cli`): ``./pd help`` reads them without
loading the tools. See :mod:`pd_common.cli`.
"""

from __future__ import annotations

from pd_common.cli import CliCommand

PACKAGE = 'pd_console'

CONSOLE = CliCommand(
    'console', 'the live test console in the browser (watch, log in with the printed token, '
    'steer, e-stop); RUN: a finished run folder or bag',
    '[RUN] [--host H] [--port P] [--key FILE]', PACKAGE, order=30)
