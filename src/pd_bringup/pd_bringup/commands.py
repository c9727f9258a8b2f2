"""The bring-up's ``./pd`` subcommands (registered under ``pd.commands`` in setup.py).

Declarations only: ``./pd help`` reads them without loading the tools. See
:mod:`pd_common.cli`.
"""

from __future__ import annotations

from pd_common.cli import CliCommand

PACKAGE = 'pd_bringup'

RUN = CliCommand(
    'run', 'the main job: a complete test through the node graph (bag, response.csv, '
    'summary, figures); --resume RUN continues a stopped one',
    '[TEST_FILE] [run_test options]', PACKAGE, 'run_test', order=0)
CONTROL = CliCommand(
    'control', 'a signed control, confirmed by its receiver: pause, resume, hold, abort; '
    'bridge: reset, reset_emergency_stop, hold, configure, activate, deactivate, cleanup; '
    'estop (no key)', 'COMMAND [--bridge] [--site S]', PACKAGE, order=31)
KEYGEN = CliCommand('keygen', 'make a key file (owner-only) for a rig', '[--out FILE]',
                    PACKAGE, order=70)
