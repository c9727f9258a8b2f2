"""The registry of integration schemes by name (``test.scheme`` in a test file)."""

from __future__ import annotations

from typing import Any

from ..errors import ConfigError
from .base import Integrator
from .explicit_alpha import ExplicitGeneralizedAlpha, ModifiedNewmark
from .implicit import AverageAcceleration, LinearAcceleration, NewmarkImplicit
from .model_based import ChenRicles, KRAlpha
from .newmark_explicit import NewmarkExplicit
from .operator_splitting import AlphaOS, GeneralizedAlphaOS

__all__ = ['SCHEMES', 'make_integrator', 'scheme_class']

#: The available schemes by registry name.
SCHEMES: dict[str, type[Integrator]] = {
    cls.name: cls
    for cls in (
        NewmarkExplicit,
        ExplicitGeneralizedAlpha,
        ModifiedNewmark,
        AlphaOS,
        GeneralizedAlphaOS,
        ChenRicles,
        KRAlpha,
        NewmarkImplicit,
        AverageAcceleration,
        LinearAcceleration,
    )
}


def scheme_class(scheme: str | type[Integrator] | Integrator) -> type[Integrator]:
    """Resolve a scheme name, integrator class or instance to its class.

    Raises:
        ConfigError: On an unknown scheme name (the message lists the valid names).
    """
    if isinstance(scheme, Integrator):
        return type(scheme)
    if isinstance(scheme, type) and issubclass(scheme, Integrator):
        return scheme
    try:
        return SCHEMES[scheme]
    except (KeyError, TypeError):
        valid = ', '.join(sorted(SCHEMES))
        msg = f'scheme: unknown integration scheme {scheme!r}; valid: {valid}'
        raise ConfigError(msg) from None


def make_integrator(name: str, **kwargs: Any) -> Integrator:
    """Create an integrator by registry name.

    Args:
        name: Scheme name, a key of :data:`SCHEMES` (e.g. ``'newmark_explicit'``).
        **kwargs: Passed to the scheme's constructor (``mass``, ``damping``, ``dt``,
            ``initial_stiffness`` and the scheme's parameters, e.g. ``rho_inf``).

    Returns:
        The new integrator.

    Raises:
        ConfigError: If the name is unknown (the message lists the valid names) or the
            constructor arguments are invalid.
    """
    return scheme_class(name)(**kwargs)
