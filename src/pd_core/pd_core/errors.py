"""Exception classes of the pure core (pd_core)."""

from __future__ import annotations


class PdIntegratorError(Exception):
    """Base class of every error raised by the pure core (pd_core)."""


class ConfigError(PdIntegratorError, ValueError):
    """A configuration file or parameter is missing, malformed or out of range."""


class GroundMotionError(PdIntegratorError, ValueError):
    """A ground-motion record cannot be read or is not a valid acceleration history."""


class IntegratorError(PdIntegratorError):
    """The time-integration scheme cannot proceed."""


class StabilityError(IntegratorError, ValueError):
    """The chosen time step violates the stability limit of the integration scheme."""


class ProtocolError(PdIntegratorError):
    """A step command or feedback violates the integrator/actuator step protocol."""


class BagError(PdIntegratorError):
    """A test bag cannot be written, read or replayed."""


class NothingToRecoverError(BagError):
    """A run folder asked to be recovered is whole already: its run ended and wrote its outputs.

    Not a fault: nothing was written (``./pd recover`` says so and exits 0).
    """


class AnalysisEndedError(IntegratorError):
    """An external integrator (OpenSees's ``genericClient``) ended the analysis: not a fault."""


class ElementLinkError(IntegratorError):
    """A served OpenSees element's connection failed or broke the protocol.

    The listener is closed: the test goes on only from its record, with the model started
    again (``./pd serve --resume RUN_DIR``).
    """
