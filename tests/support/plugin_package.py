"""The example plug-in package (``tests/plugins/pd_plugin_example``), installed for a test."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

#: The plug-in project: its ``pyproject.toml`` declares the entry points.
PLUGIN_PROJECT = Path(__file__).resolve().parents[1] / 'plugins' / 'pd_plugin_example'


def install_example_plugin(root: Path) -> Path:
    """Install the plug-in into ``root/site`` and return that folder (put it on PYTHONPATH).

    setuptools writes the package's metadata from its ``pyproject.toml`` (the entry points
    included) into the folder, next to a copy of the package: what ``pip install --target``
    leaves, without needing the ``wheel`` package (which the workspace does not install).
    """
    project = root / 'project'
    shutil.copytree(PLUGIN_PROJECT, project,
                    ignore=shutil.ignore_patterns('__pycache__', '*.egg-info'))
    target = root / 'site'
    target.mkdir(parents=True)
    subprocess.run([sys.executable, '-c', 'import setuptools; setuptools.setup()', '-q',
                    'egg_info', '--egg-base', str(target)],
                   cwd=project, check=True, capture_output=True, timeout=120)
    shutil.copytree(project / 'pd_plugin_example', target / 'pd_plugin_example')
    return target
