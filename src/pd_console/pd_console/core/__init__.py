"""The live test console's pure part: histories, decimation, gauges, access, run folders.

No ROS and no web server here: the console node (``pd_console.console``) feeds
:class:`ConsoleModel` what it hears and pushes :meth:`ConsoleModel.frame` to the page.
"""

from __future__ import annotations

from .access import (
    BRIDGE_CONTROLS,
    SESSION_COOKIE,
    TEST_CONTROLS,
    ConsoleAccess,
    ControlRequest,
    parse_control,
)
from .foxglove import (
    RESPONSE_FIELDS,
    STATUS_TOPIC,
    foxglove_layout,
    gauges_message,
    gauges_topic,
    response_message,
    response_topic,
)
from .model import (
    BRIDGE_LIMITS,
    DEFAULT_MAX_POINTS,
    ConsoleModel,
    Gauge,
    SiteView,
    sites_of_definition,
)
from .run_folder import FIGURE_SUFFIXES, load_run_folder, run_directory
from .series import DecimatedRows, rounded
from .witness import DEFINITIONS_KEPT, DefinitionWitness

__all__ = [
    'BRIDGE_CONTROLS',
    'BRIDGE_LIMITS',
    'DEFAULT_MAX_POINTS',
    'DEFINITIONS_KEPT',
    'FIGURE_SUFFIXES',
    'RESPONSE_FIELDS',
    'SESSION_COOKIE',
    'STATUS_TOPIC',
    'TEST_CONTROLS',
    'ConsoleAccess',
    'ConsoleModel',
    'ControlRequest',
    'DecimatedRows',
    'DefinitionWitness',
    'Gauge',
    'SiteView',
    'foxglove_layout',
    'gauges_message',
    'gauges_topic',
    'load_run_folder',
    'parse_control',
    'response_message',
    'response_topic',
    'rounded',
    'run_directory',
    'sites_of_definition',
]
