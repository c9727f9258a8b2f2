"""Reading the actuator bridge's files once, typed: its ROS parameter file, a driver's settings.

:func:`read_bridge_parameter_file` reads the bridge's ROS parameter file
(``<node>: {ros__parameters: {...}}``) into a :class:`~.schema_bridge.BridgeParameterFile`, and
:func:`read_driver_config` the file its ``driver_config`` parameter names into a
:class:`~.schema_driver.DriverConfigFile`. A file that cannot be read or is refused is one
:class:`~.schema_base.SchemaError` of one line naming the file and the dotted path::

    bridge.yaml: /**.ros__parameters.max_force: must be > 0, got -1
    daqmx.yaml: daqmx.channels.0.command_scale: must not be 0, got 0.0
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..resources import ResourceError, share_file
from .document import read_document

if TYPE_CHECKING:
    from .schema_bridge import BridgeParameterFile
    from .schema_driver import DriverConfigFile

__all__ = ['default_bridge_parameter_file', 'read_bridge_parameter_file', 'read_driver_config']


def default_bridge_parameter_file() -> Path:
    """The actuator bridge's shipped parameter file (installed share, or the source tree).

    As ``run_test`` finds it: the file every rehearsal (``./pd offline``, ``./pd pretest``) and
    the console read when they are given none.
    """
    try:
        path = share_file('pd_actuator_bridge', 'config', 'bridge.yaml')
        if path.is_file():
            return path
    except ResourceError:
        pass
    return Path(__file__).resolve().parents[3] / 'pd_actuator_bridge' / 'config' / 'bridge.yaml'


def read_bridge_parameter_file(path: str | Path) -> BridgeParameterFile:
    """The bridge's ROS parameter file ``path``, typed.

    Raises:
        SchemaError: one line naming the file (and the dotted path of a refused value).
    """
    from .schema import validate_bridge_parameters  # noqa: PLC0415 (its models: on first use)

    path = Path(path)
    return validate_bridge_parameters(read_document(path, what='bridge parameter file'),
                                      path.name)


def read_driver_config(path: str | Path) -> DriverConfigFile:
    """A driver's settings file ``path`` (the bridge's ``driver_config``), typed.

    Raises:
        SchemaError: one line naming the file (and the dotted path of a refused value).
    """
    from .schema import validate_model  # noqa: PLC0415 (its models: on first use)
    from .schema_driver import DriverConfigFile  # noqa: PLC0415 (likewise)

    path = Path(path)
    data: Any = read_document(path, what='driver settings file')
    return validate_model(DriverConfigFile, data, path.name)
