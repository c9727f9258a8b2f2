"""A finished run in the console: its bag (or journal) through the same model, its figures."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pd_common.config import existing_path
from pd_common.protocol import Command, Feedback
from pd_core.errors import BagError
from pd_core.run.record.outputs import ENERGY_CSV, read_response_csv
from pd_core.run.runner import BAG_DIRECTORY, load_run

from .model import ConsoleModel

__all__ = ['FIGURE_SUFFIXES', 'load_run_folder', 'run_directory']

#: The files of a run folder the page shows as figures.
FIGURE_SUFFIXES = ('.png',)


def run_directory(path: str | Path) -> Path:
    """The run folder of ``path`` (a run folder, its bag folder or its journal).

    Raises:
        OSError: ``path`` does not exist, or is a symbolic link loop (one line naming it).
    """
    path = existing_path(path)
    if path.is_file() or path.name == BAG_DIRECTORY:
        return path.parent
    return path


def load_run_folder(path: str | Path, model: ConsoleModel) -> Path:
    """Feed ``model`` a finished run: definition, every site's stream, statuses, energy.

    Returns:
        The run folder (its figures are the ``*.png`` files there).

    Raises:
        BagError: neither a complete bag nor a journal is there, or the record (or the
            folder's ``energy.csv``) is not one (one line naming the file and the line).
        OSError: ``path`` does not exist, or is a symbolic link loop (one line naming it).
    """
    record = load_run(path)
    directory = run_directory(path)
    model.mode = 'run'
    model.source = str(directory)
    model.on_definition(record.definition_json)
    streams = record.site_events or {'': record.events}
    for site, events in streams.items():
        for _, item in events:
            if isinstance(item, Command):
                model.on_command(site, item)
            elif isinstance(item, Feedback):
                model.on_feedback(site, item)
    for t_ns, status in record.statuses:
        model.on_status(status, at=t_ns * 1e-9)
    bridges = [site for site in streams if site] or ['']
    for _, status in record.bridge_statuses:
        model.on_bridge_status(bridges[0], status)
    energy = directory / ENERGY_CSV
    if energy.is_file():
        try:
            columns = read_response_csv(energy)
        except (ValueError, OSError) as err:  # (a UnicodeDecodeError is a ValueError)
            msg = f'{energy}: not an energy table ({str(err).splitlines()[0]})'
            raise BagError(msg) from None
        if 'time' in columns and 'E_error' in columns:
            model.set_energy([float(x) for x in np.asarray(columns['time'])],
                             [float(x) for x in np.asarray(columns['E_error'])])
    model.figures = sorted(p.name for p in directory.iterdir()
                           if p.suffix in FIGURE_SUFFIXES and p.is_file())
    return directory
