"""The test definition: what a test is, whatever it was read from (file, parameters, bag).

:class:`TestDefinition` is built by :mod:`.test_file` from a YAML test file (with node
parameter overrides) or from the resolved JSON stored in a bag.

A definition can be *resolved* (:meth:`TestDefinition.to_resolved_dict`): the ground motion is
inlined at its record step (exact floats), the matrices are written out and the measured initial
stiffness is filled in. The resolved form is stored in the run's bag, so that the bag alone is
enough to reproduce and analyse the run.
"""

from __future__ import annotations

import copy
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..dynamics.structure import Structure, damping_from_ratio
from ..errors import ConfigError
from ..model.damping import modal_damping, rayleigh_damping
from ..model.modes import modal_properties
from .collapse import CollapseSettings

if TYPE_CHECKING:
    from pd_common.config.schema_test_file import Element, SiteSettings

    from ..dynamics.ground_motion import GroundMotion
    from ..model.substructure import StructuralModel

__all__ = ['SCHEMA_VERSION', 'GroundComponent', 'ProbeSettings', 'ProtocolSettings',
           'TestDefinition', 'damping_matrix']

#: Version of the resolved form stored in bags.
SCHEMA_VERSION = 1


@dataclass(frozen=True)
class ProtocolSettings:
    """Step protocol settings.

    Attributes:
        feedback_timeout: seconds without feedback before the command is re-sent.
        max_retries: re-sends before the integrator holds.
        start_timeout: seconds to wait for the specimen side to appear before giving up.
        tracking_tolerance: largest |measured - commanded| displacement [m] of any DOF
            before the test holds (the actuator did not get where it was sent: a feedback
            that is not plausible is never committed); 0 = off. The default, 5 mm, is well
            above a servo-hydraulic actuator's tracking error in a pseudo-dynamic test (a
            fraction of a millimetre) and below the default test's largest step (8 mm); a
            resumed run also checks the specimen's position against its record with it.
    """

    feedback_timeout: float = 2.0
    max_retries: int = 3
    start_timeout: float = 30.0
    tracking_tolerance: float = 0.005


@dataclass(frozen=True)
class ProbeSettings:
    """Initial-stiffness probe: each DOF is pushed by ``amplitude`` and brought back."""

    amplitude: float = 1.0e-3


@dataclass(frozen=True)
class GroundComponent:
    """One component of the ground motion (bi-directional tests have two).

    Attributes:
        name: component name (e.g. ``H1``), for reports.
        motion: the record at its own step, in m/s², scale and direction applied.
        acceleration: the record resampled to the test ``dt``, padded to ``n_steps + 1``.
        influence: influence vector over the session's DOFs.
        influence_raw: the influence as given (over ``structure.dof_names``), for the bag.
        info: description of the record (file, format, units, scale, direction).
    """

    name: str
    motion: GroundMotion
    acceleration: np.ndarray
    influence: np.ndarray
    influence_raw: list[float] | None
    info: dict[str, Any]


@dataclass(frozen=True)
class TestDefinition:
    """A complete, validated pseudo-dynamic test.

    Attributes:
        test_id: identifier carried by every command and feedback of the test.
        scheme: integration scheme name (see ``schemes.SCHEMES``).
        scheme_parameters: the scheme's parameters (e.g. ``rho_inf``), passed to it.
        dt: integration time step [s].
        n_steps: number of integration steps (the record, plus free vibration if asked).
        dof_names: specimen DOF names, one per actuator.
        mass: mass matrix [kg].
        damping: viscous damping matrix [N·s/m] (``None`` until the stiffness is known when a
            ratio is given and the stiffness is probed).
        damping_ratio: the ratio the damping was derived from, if any.
        initial_stiffness: initial stiffness matrix [N/m], or ``None`` to probe it.
        influence: influence vector ι.
        ground_motion: the record at its own step, in m/s², scale and direction applied.
        ground_acceleration: the record resampled to ``dt`` and padded to ``n_steps + 1``.
        specimen: the raw ``specimen`` section (for the simulator and the ROS-free runner).
        protocol: step protocol settings.
        probe: probe settings.
        source: where the definition came from (file name), for messages.
        base_dir: directory that relative paths are resolved against.
        record_info: description of the record (file, format, units, scale, direction).
        warnings: one-line warnings about the test as given (e.g. an initial stiffness that is
            not the specimen's), for the user to read; not part of the resolved form.
        collapse: the ``collapse`` section (``None``: not checked), see :mod:`.collapse`.
        sites: the ``sites`` section as written (plain mappings; the resolved form stores it so).
        site_settings: the same, typed: per site its
            :class:`~pd_common.config.SiteSettings` (a site given as ``null``: empty
            settings); what the readers of a site's settings use.
        elements: the typed ``structure.elements`` (``()``: a test without elements).
    """

    test_id: str
    scheme: str
    dt: float
    n_steps: int
    dof_names: tuple[str, ...]
    mass: np.ndarray
    damping: np.ndarray | None
    damping_ratio: float | None
    initial_stiffness: np.ndarray | None
    influence: np.ndarray
    ground_motion: GroundMotion
    ground_acceleration: np.ndarray
    specimen: dict[str, Any] | None
    protocol: ProtocolSettings = field(default_factory=ProtocolSettings)
    probe: ProbeSettings = field(default_factory=ProbeSettings)
    source: str = '<memory>'
    base_dir: Path = field(default_factory=Path.cwd)
    record_info: dict[str, Any] = field(default_factory=dict)
    scheme_parameters: dict[str, float | bool | str] = field(default_factory=dict)
    damping_spec: dict[str, Any] | None = None
    components: tuple[GroundComponent, ...] = ()
    model: StructuralModel | None = None
    structure_raw: dict[str, Any] | None = None
    sites: dict[str, Any] | None = None
    warnings: tuple[str, ...] = ()
    collapse: CollapseSettings | None = None
    site_settings: dict[str, SiteSettings] = field(default_factory=dict)
    elements: tuple[Element, ...] = ()

    @property
    def n_dof(self) -> int:
        """Number of DOFs."""
        return len(self.dof_names)

    @property
    def needs_probe(self) -> bool:
        """Whether the initial stiffness must be measured before the test."""
        return self.initial_stiffness is None

    @property
    def may_soften(self) -> bool:
        """Whether the test expects a negative tangent (it states a ``collapse`` drift)."""
        return self.collapse is not None

    @property
    def duration(self) -> float:
        """Simulated duration of the test [s]."""
        return self.n_steps * self.dt

    def time(self, step: int) -> float:
        """Simulated time of ``step`` [s]."""
        return step * self.dt

    def load(self, step: int) -> NDArray[np.float64]:
        """External load p = −M Σ ι_c a_gc at ``step`` [N]."""
        load: NDArray[np.float64] = self.loads(step, step + 1)[0]  # the one row of (1, n)
        return load

    def loads(self, start: int = 0, stop: int | None = None) -> NDArray[np.float64]:
        """External loads p_k = −M Σ_c ι_c a_gc(t_k) for steps ``start..stop-1`` [N]."""
        components = self.components or (GroundComponent(
            'ground', self.ground_motion, self.ground_acceleration, self.influence, None, {}),)
        stop = self.n_steps + 1 if stop is None else stop
        total = np.zeros((max(stop - start, 0), self.n_dof))
        for component in components:
            total -= np.outer(component.acceleration[start:stop], self.mass @ component.influence)
        return total

    def modal_report(self) -> str:
        """Periods, participation and mode shapes of the initial-stiffness model (MDOF).

        Empty when the stiffness is not known yet (probe) or the structure is an SDOF.
        """
        if self.initial_stiffness is None or self.n_dof < 2:
            return ''
        components = self.components or ()
        influences = (np.array([c.influence for c in components]) if components
                      else self.influence.reshape(1, -1))
        names = [c.name for c in components] if components else ['ground']
        properties = modal_properties(self.mass, self.initial_stiffness, influences)
        return properties.report(list(self.dof_names), names)

    @property
    def site_names(self) -> tuple[str, ...]:
        """The sites of a substructured test (``()``: the whole structure is one specimen)."""
        return self.model.site_names if self.model is not None else ()

    def structure(self, initial_stiffness: np.ndarray | None = None) -> Structure:
        """The structure, with ``initial_stiffness`` (measured) if the definition has none.

        Raises:
            ConfigError: no stiffness is known yet.
        """
        stiffness = self.initial_stiffness if initial_stiffness is None else initial_stiffness
        if stiffness is None:
            msg = f'{self.source}: structure.initial_stiffness: not known yet (probe first)'
            raise ConfigError(msg)
        damping = self.damping
        if damping is None:
            damping = damping_matrix(self.mass, stiffness, self.damping_ratio, self.damping_spec,
                                     self.source)
        return Structure(dof_names=self.dof_names, mass=self.mass, damping=damping,
                         initial_stiffness=stiffness, influence=self.influence)

    def with_initial_stiffness(self, stiffness: np.ndarray) -> TestDefinition:
        """A copy with a measured initial stiffness (and the damping that follows from it)."""
        structure = self.structure(stiffness)
        return TestDefinition(**{**self.__dict__, 'initial_stiffness': structure.initial_stiffness,
                                 'damping': structure.damping})

    def to_resolved_dict(self) -> dict[str, Any]:
        """A self-contained plain-data form (exact floats) that :func:`from_dict` reads back."""
        if self.structure_raw is not None:
            return self._resolved_with_model(self.structure_raw)
        structure: dict[str, Any] = {
            'dof_names': list(self.dof_names),
            'mass': self.mass.tolist(),
            'influence': self.influence.tolist(),
            'initial_stiffness': (None if self.initial_stiffness is None
                                  else self.initial_stiffness.tolist()),
        }
        if self.damping is not None:
            structure['damping'] = {'coefficient': self.damping.tolist()}
        else:
            structure['damping'] = {'ratio': self.damping_ratio}
        if self.initial_stiffness is None:
            structure['initial_stiffness'] = 'probe'
        if len(self.components) > 1:
            structure.pop('influence')
        return self._resolved(structure, self._resolved_ground_motion())

    def _resolved(self, structure: dict[str, Any], ground: Any) -> dict[str, Any]:
        """The resolved form around a resolved structure and ground motion section."""
        resolved = {
            'schema_version': SCHEMA_VERSION,
            'test': {'id': self.test_id, 'scheme': self.scheme, 'dt': self.dt,
                     'duration': self.duration,
                     'scheme_parameters': dict(self.scheme_parameters)},
            'structure': structure,
            'ground_motion': ground,
            'protocol': {'feedback_timeout': self.protocol.feedback_timeout,
                         'max_retries': self.protocol.max_retries,
                         'start_timeout': self.protocol.start_timeout,
                         'tracking_tolerance': self.protocol.tracking_tolerance},
            'probe': {'amplitude': self.probe.amplitude},
            'specimen': self.specimen,
        }
        if self.sites is not None:
            resolved['sites'] = self.sites
        if self.collapse is not None:
            resolved['collapse'] = self.collapse.as_dict()
        return resolved

    def _resolved_ground_motion(self) -> Any:
        if len(self.components) <= 1:
            return {'inline': {'dt': self.ground_motion.dt,
                               'acceleration': self.ground_motion.acceleration.tolist()},
                    'units': 'm/s2', 'record': dict(self.record_info)}
        return [{'name': component.name,
                 'inline': {'dt': component.motion.dt,
                            'acceleration': component.motion.acceleration.tolist()},
                 'units': 'm/s2', 'record': dict(component.info),
                 'influence': (component.influence_raw if component.influence_raw is not None
                               else component.influence.tolist())}
                for component in self.components]

    def _resolved_with_model(self, structure_raw: dict[str, Any]) -> dict[str, Any]:
        """Resolved form of a test with ``structure.elements`` (the structure as given)."""
        structure = copy.deepcopy(structure_raw)
        ground = self._resolved_ground_motion()
        if isinstance(ground, dict) and self.components:
            ground_influence = self.components[0].influence_raw
            if ground_influence is not None:
                structure['influence'] = ground_influence
        return self._resolved(structure, ground)

    def to_json(self) -> str:
        """The resolved definition as JSON (floats round-trip exactly)."""
        return json.dumps(self.to_resolved_dict(), allow_nan=False)


def damping_matrix(mass: np.ndarray, stiffness: np.ndarray, ratio: float | None,
                   spec: dict[str, Any] | None, source: str = '<memory>') -> np.ndarray:
    """The viscous damping matrix of a ratio (thesis / Rayleigh modes 1-2) or a spec.

    Raises:
        ConfigError: the modes requested do not exist or cannot be matched; the message names
            the test file's key (``structure.mass`` for a mass that is not positive definite,
            ``structure.initial_stiffness`` for a stiffness that is not positive semi-definite).
    """
    try:
        if spec is None:
            return damping_from_ratio(mass, stiffness, ratio if ratio is not None else 0.0)
        if 'rayleigh' in spec:
            rayleigh = spec['rayleigh']
            if mass.shape[0] < max(rayleigh['modes']):
                msg = (f'modes: {rayleigh["modes"]} asked, the structure has {mass.shape[0]} '
                       'modes')
                raise ConfigError(msg)
            return rayleigh_damping(mass, stiffness, tuple(rayleigh['modes']),
                                    tuple(rayleigh['ratios']))
        ratios = spec['modal']
        if len(ratios) > mass.shape[0]:
            msg = f'modal: {len(ratios)} ratios for {mass.shape[0]} modes'
            raise ConfigError(msg)
        return modal_damping(mass, stiffness, ratios)
    except ConfigError as err:
        name, _, what = str(err).partition(': ')
        key = _DAMPING_ERROR_KEYS.get(name)
        msg = f'{source}: {key}: {what}' if key else f'{source}: structure.damping: {err}'
        raise ConfigError(msg) from None


#: The test file key of a matrix named in an error of the damping functions (the other errors
#: are about ``structure.damping``).
_DAMPING_ERROR_KEYS = {'mass': 'structure.mass', 'stiffness': 'structure.initial_stiffness'}


