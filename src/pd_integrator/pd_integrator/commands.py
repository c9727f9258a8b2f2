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
REPLAY = CliCommand('replay', "rebuild a run's outputs from its bag alone", 'BAG [--out DIR]',
                    PACKAGE, order=20)
RECOVER = CliCommand('recover', "rebuild a stopped run's outputs from its journal (a crash, "
                     'a full disk)', 'RUN_FOLDER', PACKAGE, order=21)
CONSOLE = CliCommand(
    'console', 'the live test console in the browser (watch, log in with the printed token, '
    'steer, e-stop); RUN: a finished run folder or bag',
    '[RUN] [--host H] [--port P] [--key FILE]', PACKAGE, order=30)
PRETEST = CliCommand(
    'pretest', "the test's model under many records, scales and parameters at once: strokes, "
    "velocities, forces against the bridge's limits, response spectra",
    'TEST_FILE [--records ...] [--scales A:B:S] [--vary ...]', PACKAGE, order=40)
ANALYZE = CliCommand('analyze', 'stability and accuracy of the integration schemes',
                     '[options]', PACKAGE, order=60)
STUDY_CH5 = CliCommand('study_ch5', "the thesis's chapter 5 comparison", '[--records ...]',
                       PACKAGE, order=61)
STUDY_ERRORS = CliCommand('study_errors', 'growth of experimental errors (Shing & Mahin)',
                          '[options]', PACKAGE, order=62)
RTHS_BENCHMARK = CliCommand(
    'rths_benchmark', 'the vRTHS benchmark: J1-J9, figures',
    '[--case N] [--controller NAME] [--loop benchmark|native] [--record F] '
    '[--perturbed N --seed S] [--out DIR]', PACKAGE, order=63)
