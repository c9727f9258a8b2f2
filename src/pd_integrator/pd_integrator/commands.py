"""The integrator's ``./pd`` subcommands (registered under ``pd.commands`` in setup.py).

Declarations only (no imports beyond :mod:`pd_common.cli`): ``./pd help`` reads them without
loading the tools. See :mod:`pd_common.cli`.
"""

from __future__ import annotations

from pd_common.cli import CliCommand

PACKAGE = 'pd_integrator'

OFFLINE = CliCommand(
    'offline', 'the same test without ROS, in one process; each site\'s bridge limits hold it '
    'where the graph would (--past-limits: run on and report where)',
    '[TEST_FILE] [--bridge F] [--past-limits] [--out DIR]', PACKAGE, order=10)
REPLAY = CliCommand('replay', "rebuild a run's outputs from its record alone (its bag, or its "
                    'journal); --key checks every signature again',
                    'RUN|BAG|JOURNAL [--out DIR] [--key KEY] [--no-figures]', PACKAGE, order=20)
RECOVER = CliCommand('recover', "rebuild a stopped run's outputs from its journal (a crash, "
                     'a full disk)', 'RUN_FOLDER', PACKAGE, order=21)
JOURNAL = CliCommand('journal', "print a run's journal: one line per record (--json: one "
                     'JSON object), e.g. the last command a killed run sent',
                     'RUN [--tail N] [--kind cmd,fb] [--json]', PACKAGE, order=22)
