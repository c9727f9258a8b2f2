"""Exceptions raised by the actuator bridge core.

:class:`BridgeError` and :class:`BridgeConfigError` are defined in :mod:`pd_common.errors`
(the safety limits, shared with the ROS-free rehearsals, raise them) and re-exported here.
"""

from __future__ import annotations

from pd_common.errors import BridgeConfigError, BridgeError

__all__ = ['BridgeConfigError', 'BridgeError', 'DriverError', 'LimitError']


class LimitError(BridgeError):
    """A command or a measurement is outside the bridge's safety limits."""


class DriverError(BridgeError):
    """The actuator driver failed (hardware, communication or a specimen model)."""
