"""The registry of integration schemes by name (``test.scheme`` in a test file).

The built-in schemes are registered here; a separate package adds one through the
``pd.schemes`` entry-point group (the entry point's name is the scheme's :attr:`name`, its
value the :class:`~.base.Integrator` subclass)::

    [project.entry-points."pd.schemes"]
    my_scheme = "my_package.schemes:MyScheme"

Everything else about a scheme (its stability limit, order of accuracy, parameters, what it
assumes of a softening specimen) is an attribute of its class.
"""

from __future__ import annotations

import inspect
from typing import Any

from pd_common.registry import GROUPS, Registry

from ..errors import ConfigError
from .base import Integrator
from .explicit_alpha import ExplicitGeneralizedAlpha, ModifiedNewmark
from .implicit import AverageAcceleration, LinearAcceleration, NewmarkImplicit
from .model_based import ChenRicles, KRAlpha
from .newmark_explicit import NewmarkExplicit
from .opensees_element import OpenSeesElement
from .operator_splitting import AlphaOS, GeneralizedAlphaOS

__all__ = ['SCHEMES', 'make_integrator', 'numerical_schemes', 'register_scheme', 'scheme_class']


def _admit(name: str, entry: Any) -> type[Integrator]:
    """A concrete :class:`Integrator` subclass whose ``name`` is its registry name.

    Raises:
        ConfigError: Anything else.
    """
    if not (isinstance(entry, type) and issubclass(entry, Integrator)) or inspect.isabstract(
            entry):
        msg = f'scheme {name}: expected a concrete Integrator subclass, got {entry!r}'
        raise ConfigError(msg)
    if entry.name != name:
        msg = f'scheme {name}: its class {entry.__name__} is named {entry.name!r}'
        raise ConfigError(msg)
    return entry


#: The available schemes by registry name (a read-only mapping, in registration order: the
#: built-ins, then the installed ``pd.schemes`` plug-ins).
SCHEMES: Registry[type[Integrator]] = Registry(
    'scheme', GROUPS['scheme'], admit=_admit, error=ConfigError,
    unknown='scheme: unknown integration scheme {name!r}; valid: {known}')


def register_scheme(cls: type[Integrator]) -> type[Integrator]:
    """Register ``cls`` under its :attr:`~.base.Integrator.name` and return it.

    Raises:
        ConfigError: Not a concrete :class:`~.base.Integrator` subclass, or a taken name.
    """
    return SCHEMES.register(cls.name, cls)


for _builtin in (NewmarkExplicit, ExplicitGeneralizedAlpha, ModifiedNewmark, AlphaOS,
                 GeneralizedAlphaOS, ChenRicles, KRAlpha, NewmarkImplicit, AverageAcceleration,
                 LinearAcceleration, OpenSeesElement):
    register_scheme(_builtin)


def numerical_schemes() -> list[str]:
    """The names of the schemes that integrate by themselves (all but the ``external`` ones)."""
    return [name for name, cls in SCHEMES.items() if not cls.external]


def scheme_class(scheme: str | type[Integrator] | Integrator) -> type[Integrator]:
    """Resolve a scheme name, integrator class or instance to its class.

    Raises:
        ConfigError: On an unknown scheme name (the message lists the valid names).
    """
    if isinstance(scheme, Integrator):
        return type(scheme)
    if isinstance(scheme, type) and issubclass(scheme, Integrator):
        return scheme
    return SCHEMES.lookup(scheme)


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
