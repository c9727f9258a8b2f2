"""The actuator bridge's ``./pd`` subcommands (registered under ``pd.commands`` in setup.py).

Declarations only (no imports beyond :mod:`pd_common.cli`): ``./pd help`` reads them without
loading the tools. See :mod:`pd_common.cli`.
"""

from __future__ import annotations

from pd_common.cli import CliCommand

PACKAGE = 'pd_actuator_bridge'

SERVE = CliCommand(
    'serve', "serve an OpenSees model's genericClient element: each force it asks for is "
    'measured through the bridge (limits, journal, bag, run folder as ./pd run)',
    '[TEST_FILE] [--offline] [--out DIR] [--no-figures]', PACKAGE, 'element_server', order=5)
