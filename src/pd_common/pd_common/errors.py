"""Exception classes of pd_common (specimen models, their configuration, experimental errors)."""

from __future__ import annotations


class SpecimenError(ValueError):
    """Base class of the errors of the specimen models and their configuration."""


class BackboneError(SpecimenError):
    """A backbone (pushover) curve or its file is invalid."""


class HysteresisError(SpecimenError):
    """A hysteresis model got an invalid argument or left its defined range."""


class SpecimenConfigError(SpecimenError):
    """The ``specimen:`` section of a test configuration is invalid."""


class SetupError(ValueError):
    """An experimental setup (basic DOFs ↔ actuator strokes) or its configuration is invalid."""


class RthsError(ValueError):
    """A real-time hybrid simulation piece (transfer system, compensator, continuous actuator)
    or its configuration is invalid."""
