"""Exceptions of the specimen simulator core."""

from __future__ import annotations


class SpecimenError(ValueError):
    """Base class of every error raised by the specimen simulator core."""


class BackboneError(SpecimenError):
    """A backbone (pushover) curve or its file is invalid."""


class HysteresisError(SpecimenError):
    """A hysteresis model got an invalid argument or left its defined range."""


class SpecimenConfigError(SpecimenError):
    """The ``specimen:`` section of a test configuration is invalid."""
