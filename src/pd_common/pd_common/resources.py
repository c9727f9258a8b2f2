"""Finding installed packages, executables and shared files (as ``ros2 run`` does).

Pure: it reads the ament index of the prefixes in ``AMENT_PREFIX_PATH``; no ROS import.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ['ResourceError', 'find_executable', 'package_prefix', 'share_file']


class ResourceError(LookupError):
    """A package, executable or shared file is not installed."""


def package_prefix(package: str) -> Path:
    """The install prefix of ``package`` from the ament index (as ``ros2 run`` finds it).

    Raises:
        ResourceError: the package is not in any prefix of ``AMENT_PREFIX_PATH``.
    """
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix and (Path(prefix) / 'share' / 'ament_index' / 'resource_index' / 'packages'
                       / package).is_file():
            return Path(prefix)
    msg = (f'package {package!r} not found in AMENT_PREFIX_PATH (source scripts/env.sh or the '
           'workspace install/setup.sh)')
    raise ResourceError(msg)


def find_executable(package: str, executable: str = 'main') -> Path:
    """``<prefix>/lib/<package>/<executable>``, the file ``ros2 run`` would run.

    Raises:
        ResourceError: it does not exist.
    """
    path = package_prefix(package) / 'lib' / package / executable
    if not path.is_file():
        msg = f'{path}: executable not found (is {package} built?)'
        raise ResourceError(msg)
    return path


def share_file(package: str, *parts: str) -> Path:
    """A file installed in ``share/<package>`` (it may not exist).

    Raises:
        ResourceError: the package is not installed.
    """
    return package_prefix(package) / 'share' / package / Path(*parts)
