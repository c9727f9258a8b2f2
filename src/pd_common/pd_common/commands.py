"""The shared library's ``./pd`` subcommand (registered under ``pd.commands`` in setup.py).

See :mod:`pd_common.cli`.
"""

from __future__ import annotations

from .cli import CliCommand

SCHEMA = CliCommand(
    'schema', "the JSON Schema of a test file (--bridge: of the bridge's parameter file), or "
    'its key reference (--markdown); --write DIR writes the shipped schema files',
    '[--bridge] [--markdown] [--write DIR]', 'pd_common', order=75)
