"""Exception classes of pd_common.

Specimen models, their configuration, experimental errors, the actuator bridge's safety limits.
"""

from __future__ import annotations


class SpecimenError(ValueError):
    """Base class of the errors of the specimen models and their configuration."""


class BackboneError(SpecimenError):
    """A backbone (pushover) curve or its file is invalid."""


class HysteresisError(SpecimenError):
    """A hysteresis model got an invalid argument or left its defined range."""


class SpecimenConfigError(SpecimenError):
    """The ``specimen:`` section of a test configuration is invalid."""


class StateFileError(SpecimenError):
    """A simulator's state file could not take a served move (a full disk, a failed ``fsync``).

    The move is not on record, so it must not be answered: the simulator ends with this one
    line, and its restart replays the file up to the last move that is.
    """


class SetupError(ValueError):
    """An experimental setup (basic DOFs ↔ actuator strokes) or its configuration is invalid."""


class RthsError(ValueError):
    """A real-time hybrid simulation piece or its configuration is invalid.

    A real-time hybrid simulation piece (transfer system, compensator, continuous actuator)
    or its configuration is invalid.
    """


class BridgeError(Exception):
    """Base class of every actuator bridge error (``pd_actuator_bridge.core`` re-exports it)."""


class BridgeConfigError(BridgeError, ValueError):
    """Invalid bridge configuration (safety limits, DOF names, options).

    Raised by the safety limits of :mod:`pd_common.experimental.limits` wherever they are applied
    (the bridge, the ROS-free rehearsals).
    """


class ElementProtocolError(ValueError):
    """A ``genericClient`` element sent a malformed or out-of-order message, or was refused."""
