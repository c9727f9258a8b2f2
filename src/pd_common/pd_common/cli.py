"""The ``./pd`` command line: one registry of subcommands, from which its help is generated.

Every subcommand of ``./pd`` that runs a package's executable is a :class:`CliCommand`
registered under the entry-point group ``pd.commands`` (the plug-in pattern of
:mod:`pd_common.registry`): the package that owns the executable declares it next to its code
(``<package>/commands.py``) and lists it in its ``setup.py``::

    entry_points={'pd.commands': ['offline = pd_integrator.commands:OFFLINE']}

so a lab's own package adds ``./pd <its command>`` the same way, without editing ours. The
executable runs as ``ros2 run <package> <executable>`` would (``lib/<package>/<executable>``
of the workspace's install). The few commands that act on the workspace itself (``test``,
``lint``, ``docs``, ``bench``, ``setup``, ``shell``) are the script's own
(:data:`WORKSPACE_COMMANDS`: listed here, run by the script).

``python -m pd_common.cli help`` prints the help (``./pd help``; the documentation site's
command reference embeds it), ``which NAME INSTALL_DIR`` the executable of a command (the
script execs it; an unknown name is one line listing the known ones, exit 2).
"""

from __future__ import annotations

import os
import sys
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from .registry import GROUPS, Registry, RegistryError

__all__ = ['COMMANDS', 'GROUP', 'WORKSPACE_COMMANDS', 'CliCommand', 'executable',
           'help_text', 'main']

#: The entry-point group of ``./pd``'s subcommands.
GROUP = GROUPS['./pd command']
_USAGE_WIDTH = 40
_SUMMARY_WIDTH = 54


@dataclass(frozen=True)
class CliCommand:
    """One subcommand of ``./pd``.

    Attributes:
        name: What follows ``./pd`` (lower case, digits, underscores), e.g. ``offline``.
        summary: What it does, one or two sentences (wrapped in the help).
        usage: Its arguments as the help shows them, e.g. ``[TEST_FILE] [options]``.
        package: The ROS package of its executable (``None``: one of the script's own).
        executable: The executable in ``lib/<package>/`` (default: :attr:`name`).
        order: Where it is listed (lower first; then by name).
    """

    name: str
    summary: str
    usage: str = ''
    package: str | None = None
    executable: str = ''
    order: int = 50

    def __post_init__(self) -> None:
        """Default the executable to the name; refuse an empty summary."""
        if not self.summary.strip():
            msg = f'./pd command {self.name}: summary must not be empty'
            raise ValueError(msg)
        if not self.executable:
            object.__setattr__(self, 'executable', self.name)


def _admit(name: str, entry: object) -> CliCommand:
    if not isinstance(entry, CliCommand):
        msg = f'./pd command {name}: a CliCommand is required, got {type(entry).__name__}'
        raise RegistryError(msg)
    if entry.name != name:
        msg = f'./pd command {name}: the entry point names {entry.name!r}'
        raise RegistryError(msg)
    return entry


#: The commands that run a package's executable (built-ins and plug-ins, by entry point).
COMMANDS: Registry[CliCommand] = Registry(
    './pd command', GROUP, admit=_admit,
    unknown="unknown command {name!r} (known: {known}); ./pd help describes each")

#: The script's own commands (run by ``./pd`` itself: they act on the workspace).
WORKSPACE_COMMANDS: tuple[CliCommand, ...] = (
    CliCommand('test', 'the whole test suite: lint, types, import contracts (scripts/lint.sh), '
               'then pytest', '[pytest options]', order=1),
    CliCommand('lint', 'only the lint, type and import-contract checks', order=2),
    CliCommand('docs', 'the documentation site (mkdocs.yml): serve it at '
               'http://127.0.0.1:8000/; build: into site/, warnings as errors', '[build]',
               order=80),
    CliCommand('bench', 'benchmarks: steps/s, round-trip times (bench/results.json)',
               order=90),
    CliCommand('setup', 'only install and build (every command does it first)', order=95),
    CliCommand('shell', 'a shell with the workspace sourced', order=96),
)


def _commands() -> list[CliCommand]:
    every = [*WORKSPACE_COMMANDS, *(COMMANDS[name] for name in COMMANDS.names())]
    return sorted(every, key=lambda command: (command.order, command.name))


def _columns(left: str, right: str) -> list[str]:
    lefts = textwrap.wrap(left, _USAGE_WIDTH, subsequent_indent='             ',
                          break_on_hyphens=False, break_long_words=False) or ['']
    rights = textwrap.wrap(right, _SUMMARY_WIDTH, break_on_hyphens=False,
                           break_long_words=False) or ['']
    lines = []
    for index in range(max(len(lefts), len(rights))):
        first = lefts[index] if index < len(lefts) else ''
        second = rights[index] if index < len(rights) else ''
        lines.append(f'  {first:<{_USAGE_WIDTH}}  {second}'.rstrip())
    return lines


def help_text() -> str:
    """``./pd help``: every command, its arguments and what it does."""
    lines = ['Pseudo-dynamic testing workspace: one entry point for users and CI.', '',
             'usage: ./pd COMMAND [arguments]   (./pd COMMAND --help: its own options)', '']
    for command in _commands():
        lines += _columns(f'./pd {command.name} {command.usage}'.rstrip(), command.summary)
    broken = COMMANDS.broken
    if broken:
        lines += ['', 'plug-in commands that did not load:']
        lines += [f'  {name}: {reason}' for name, reason in sorted(broken.items())]
    return '\n'.join(lines) + '\n'


def executable(name: str, install: Path) -> Path:
    """The executable ``./pd <name>`` runs (``install/<package>/lib/<package>/<executable>``).

    Raises:
        RegistryError: An unknown command (one line, the known ones listed), a workspace
            command (the script runs those), or an executable that is not installed.
    """
    command = COMMANDS.lookup(name.replace('-', '_'))
    assert command.package is not None  # registered commands name their package
    path = install / command.package / 'lib' / command.package / command.executable
    if not os.access(path, os.X_OK):
        msg = (f'./pd {name}: {path} is not installed (./pd setup builds the workspace; '
               f'is {command.package} in src/?)')
        raise RegistryError(msg)
    return path


def main(argv: Sequence[str] | None = None) -> int:
    """``help`` | ``which NAME INSTALL_DIR``; 0, or 2 with one line on stderr."""
    args = list(sys.argv[1:] if argv is None else argv)
    if args in (['help'], []):
        sys.stdout.write(help_text())
        return 0
    if len(args) == 3 and args[0] == 'which':
        try:
            print(executable(args[1], Path(args[2])))
        except RegistryError as err:
            print(f'pd: {err}', file=sys.stderr)
            return 2
        return 0
    print('usage: python -m pd_common.cli help | which NAME INSTALL_DIR',
          file=sys.stderr)
    return 2


if __name__ == '__main__':  # run as pd_common.cli, not __main__: one CliCommand class
    import importlib
    import logging

    # A broken plug-in is named by the help (or the unknown command's line), not logged too.
    logging.getLogger('pd_common.registry').addHandler(logging.NullHandler())
    sys.exit(importlib.import_module('pd_common.cli').main())
