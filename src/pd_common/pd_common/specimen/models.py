"""The registry of hysteresis models by name (``model:`` of a specimen element).

An element of ``specimen.elements`` (or a column's ``lateral``, or a numerical spring) names
its model and gives the model's keys::

    - {model: bilinear, stiffness: 1.0e5, yield_force: 2.0e3, hardening_ratio: 0.02}

Each model is one :class:`HysteresisModelSpec`: its name, its keys (each a
:class:`~pd_common.registry.Parameter`; ``required=True`` for a key that must be given) and
a builder that gets an :class:`ElementReader` (the element's keys, its path for messages) and
returns the :class:`~.hysteresis.HysteresisModel`. The built-in models (``elastic``, ``epp``,
``bilinear``, ``pushover``, ``bouc_wen``) are registered by :mod:`.config`; a separate package
adds one through the ``pd.hysteresis`` entry-point group (the entry point's name is the
model's name, its value the :class:`HysteresisModelSpec`)::

    [project.entry-points."pd.hysteresis"]
    linear_spring = "pd_plugin_example.spring:LINEAR_SPRING"

A plug-in's builder usually validates every key by its declaration and passes them on::

    LINEAR_SPRING = HysteresisModelSpec(
        name='linear_spring',
        parameters=(Parameter('stiffness', None, 'spring stiffness, N/m', low=0.0,
                              low_open=True, required=True),),
        build=lambda reader: LinearSpring(**reader.values()),
    )
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import SpecimenConfigError, SpecimenError
from ..registry import GROUPS, Parameter, ParameterError, Registry, resolve_parameters
from .hysteresis import HysteresisModel

__all__ = ['HYSTERESIS_MODELS', 'ElementReader', 'HysteresisModelSpec',
           'register_hysteresis_model']


@dataclass(frozen=True)
class ElementReader:
    """What a hysteresis model's builder gets: one element mapping and where it is.

    Attributes:
        spec: The element's mapping (``model`` and the model's keys; unknown and missing keys
            have been refused already).
        path: Its dotted path in the file, e.g. ``specimen.elements[0]``.
        source: The file's name, for messages.
        base_dir: The directory relative file names resolve against.
        parameters: The model's declared keys.
    """

    spec: Mapping[str, Any]
    path: str
    source: str
    base_dir: Path
    parameters: tuple[Parameter, ...] = ()

    def error(self, message: str, key: str = '') -> SpecimenConfigError:
        """The one-line error ``<source>: <path>[.key]: <message>`` (to raise)."""
        where = f'{self.path}.{key}' if key else self.path
        return SpecimenConfigError(f'{self.source}: {where}: {message}')

    def values(self) -> dict[str, Any]:
        """Every declared key's value.

        Checked by its :class:`~pd_common.registry.Parameter` (the default where it is not given).

        Raises:
            SpecimenConfigError: One line naming the key.
        """
        given = {key: value for key, value in self.spec.items() if key != 'model'}
        try:
            return resolve_parameters(self.parameters, given)
        except ParameterError as err:
            raise self.error(err.reason, err.parameter) from None


HysteresisBuilder = Callable[[ElementReader], HysteresisModel]
"""``build(reader)``: the model of one element (one-line ``SpecimenConfigError`` on a bad
value; a :class:`~pd_common.errors.SpecimenError` it raises is reported with the element's
path)."""


@dataclass(frozen=True)
class HysteresisModelSpec:
    """The registration of one hysteresis model.

    Attributes:
        name: The value of an element's ``model`` key.
        build: Builds the model from an :class:`ElementReader`.
        parameters: The element's keys besides ``model``; ``required=True`` for those that must
            be given.
        description: One line for listings and documentation.
    """

    name: str
    build: HysteresisBuilder
    parameters: tuple[Parameter, ...] = ()
    description: str = ''

    @property
    def required_keys(self) -> set[str]:
        """The keys an element must give."""
        return {parameter.name for parameter in self.parameters if parameter.required}

    @property
    def optional_keys(self) -> set[str]:
        """The keys an element may give."""
        return {parameter.name for parameter in self.parameters if not parameter.required}

    def make(self, spec: Mapping[str, Any], *, path: str, source: str, base_dir: Path
             ) -> HysteresisModel:
        """Build the model of element ``spec`` (its keys already checked).

        Raises:
            SpecimenConfigError: One line naming ``source`` and the path.
        """
        reader = ElementReader(spec, path, source, base_dir, self.parameters)
        try:
            model = self.build(reader)
        except SpecimenConfigError:
            raise
        except SpecimenError as exc:
            raise reader.error(str(exc)) from None
        if not isinstance(model, HysteresisModel):
            msg = f'model {self.name} built {type(model).__name__}, not a HysteresisModel'
            raise reader.error(msg)
        return model


def _admit(name: str, spec: Any) -> HysteresisModelSpec:
    """A :class:`HysteresisModelSpec` named ``name``.

    Raises:
        SpecimenConfigError: Anything else.
    """
    if not isinstance(spec, HysteresisModelSpec) or spec.name != name:
        msg = (f'hysteresis model {name}: expected a HysteresisModelSpec named {name!r}, '
               f'got {spec!r}')
        raise SpecimenConfigError(msg)
    return spec


#: The hysteresis models by name, in registration order (the built-ins, then the installed
#: ``pd.hysteresis`` plug-ins).
HYSTERESIS_MODELS: Registry[HysteresisModelSpec] = Registry(
    'hysteresis model', GROUPS['hysteresis model'], admit=_admit, error=SpecimenConfigError)


def register_hysteresis_model(spec: HysteresisModelSpec) -> HysteresisModelSpec:
    """Register ``spec`` under its name and return it.

    Raises:
        SpecimenConfigError: Not a :class:`HysteresisModelSpec`, or a bad or taken name.
    """
    return HYSTERESIS_MODELS.register(spec.name, spec)
