"""Exceptions raised by the actuator bridge core."""

from __future__ import annotations


class BridgeError(Exception):
    """Base class of every actuator bridge error."""


class LimitError(BridgeError):
    """A command or a measurement is outside the bridge's safety limits."""


class DriverError(BridgeError):
    """The actuator driver failed (hardware, communication or a specimen model)."""


class BridgeConfigError(BridgeError, ValueError):
    """Invalid bridge configuration (safety limits, DOF names, options)."""
