"""The typed schema of a test file: every section, key, type, default and bound.

Taken from the parsers that read the file today (the integrator's
``pd_core.run.test_file`` and ``core.model``, :mod:`pd_common.specimen.config`,
:mod:`pd_common.experimental.setups`, :mod:`pd_common.rths.continuous`, ``pd_bringup.rig``);
they still run after it and check what a schema cannot (matrix shapes against the DOF count,
symmetry, definiteness, DOF names of elements, records). ``./pd schema`` prints its JSON Schema.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, Self

from pydantic import ConfigDict, Field, Tag, model_validator

from .schema_base import (
    ConfigModel,
    Finite,
    FloatMatrix,
    NonNegative,
    NonPositive,
    Positive,
    by_shape,
    check,
    either,
)
from .schema_bridge import SiteBridgeParameters
from .schema_specimen import HysteresisModel, SpecimenSection

__all__ = ['SITE_NAME_PATTERN', 'BeamColumnElement', 'CollapseSection', 'ControlSpec',
           'DampingSection', 'ExperimentalElement', 'GroundMotionComponent', 'GroundMotionSection',
           'InlineRecord', 'LinearElement', 'NonlinearSpringElement', 'OpenSeesSite', 'PDelta',
           'ProbeSection', 'ProtocolSection', 'RayleighDamping', 'RigSection', 'SetupSpec',
           'SiteSettings', 'SpringElement', 'StructureSection', 'TestFileModel', 'TestSection',
           'TransferSystemSection']

#: A DOF name of ``structure.dof_names``.
DofName = Annotated[str, Field(min_length=1)]
#: A DOF name, or null (the ground; a free basic DOF of an experimental element).
DofOrGround = DofName | None
#: What a site name is (it becomes a ROS namespace): the pattern a site name matches.
SITE_NAME_PATTERN = r'^[A-Za-z][A-Za-z0-9_]{0,63}$'
#: A site name: it becomes a ROS namespace.
SiteName = Annotated[str, Field(pattern=SITE_NAME_PATTERN)]
#: A damping ratio, in [0, 1).
DampingRatio = Annotated[float, Field(ge=0.0, lt=1.0, allow_inf_nan=False)]


class TestSection(ConfigModel):
    """The test: its name, integration scheme and time step."""

    __test__ = False  # (not a pytest test class)

    id: Annotated[str, Field(pattern=r'^[A-Za-z0-9_.\-]{1,64}$')] = 'pd-test'
    """The test's name: 1-64 letters, digits, ``_``, ``-`` or ``.`` (names the run folder)."""
    scheme: Annotated[str, Field(pattern=r'^[a-z][a-z0-9_]*$')] = 'newmark_explicit'
    """The integration scheme, one of the registered schemes (``newmark_explicit``,
    ``alpha_os``, ``average_acceleration``, ``cr``, ``explicit_generalized_alpha``,
    ``generalized_alpha_os``, ``kr_alpha``, ``linear_acceleration``, ``modified_newmark``,
    ``newmark_implicit``, ``opensees_element``)."""
    scheme_parameters: dict[str, Finite | bool | str] | None = None
    """The scheme's parameters by name (finite numbers, true/false or text, e.g.
    ``opensees_element``'s ``host``; the scheme's defaults otherwise)."""
    dt: Positive
    """The integration time step [s]."""
    duration: Positive | None = None
    """The test's duration [s] (null: the record's)."""


class RayleighDamping(ConfigModel):
    """Rayleigh damping fitted to the ratios of two modes."""

    modes: Annotated[list[Annotated[int, Field(ge=1)]], Field(min_length=2, max_length=2),
                     check(lambda modes: modes[0] != modes[1],
                           'must be two distinct mode numbers')] = [1, 2]  # noqa: RUF012 (copied)
    """Two distinct mode numbers (1-based)."""
    ratios: Annotated[DampingRatio | list[DampingRatio],
                      either('a damping ratio in [0, 1) or a list of two')]
    """The damping ratio of each of the two modes (or one for both)."""


class DampingSection(ConfigModel):
    """Viscous damping: exactly one of ``ratio``, ``coefficient``, ``rayleigh``, ``modal``."""

    ratio: DampingRatio | None = None
    """Ratio of critical damping of the first mode (c = 2 m omega zeta for an SDOF)."""
    coefficient: FloatMatrix | None = None
    """The damping matrix [N s/m] (a number for an SDOF)."""
    rayleigh: RayleighDamping | None = None
    """Rayleigh damping."""
    modal: Annotated[DampingRatio | list[DampingRatio],
                     either('a damping ratio in [0, 1) or a list of them')] | None = None
    """Modal damping ratios (one per mode, or one for all)."""

    @model_validator(mode='after')
    def _one(self) -> Self:
        given = [key for key in ('ratio', 'coefficient', 'rayleigh', 'modal')
                 if getattr(self, key) is not None]
        if len(given) != 1:
            msg = ('give exactly one of ratio, coefficient, rayleigh or modal, got '
                   f'{", ".join(given) or "none"}')
            raise ValueError(msg)
        return self


class PDelta(ConfigModel):
    """A leaning column's P-Δ on a spring: the force becomes k d − P d / L."""

    axial_load: Positive
    """The axial load P [N]."""
    height: Positive
    """The height L [m]."""


class SpringElement(ConfigModel):
    """A linear spring between two DOFs (deformation x_j − x_i) or a DOF and the ground."""

    type: Literal['spring', 'story']
    """``spring`` (alias ``story``)."""
    name: Annotated[str, Field(min_length=1)] | None = None
    """A unique name (default: the type and the element's number)."""
    dofs: Annotated[list[DofOrGround], Field(min_length=1, max_length=2)]
    """``[i, j]`` or ``[j]`` (to the ground)."""
    stiffness: Positive
    """Stiffness [N/m]."""
    pdelta: PDelta | None = None
    """A leaning column's P-Δ."""


class BeamColumnElement(ConfigModel):
    """A linear 2-D Euler–Bernoulli frame element."""

    type: Literal['beam_column']
    """``beam_column``."""
    name: Annotated[str, Field(min_length=1)] | None = None
    """A unique name (default: the type and the element's number)."""
    dofs: Annotated[list[DofOrGround], Field(min_length=6, max_length=6)]
    """The six end DOFs ``[ux_i, uy_i, rz_i, ux_j, uy_j, rz_j]`` (null: the ground)."""
    coordinates: Annotated[list[Annotated[list[Finite], Field(min_length=2, max_length=2)]],
                           Field(min_length=2, max_length=2)]
    """The ends ``[[x_i, y_i], [x_j, y_j]]`` [m]."""
    E: Positive
    """Young's modulus [Pa]."""
    A: Positive
    """Cross-section area [m^2]."""
    I: Positive  # noqa: E741
    """Second moment of area [m^4]."""
    geometry: Literal['linear', 'pdelta', 'pdelta_consistent'] = 'linear'
    """``linear``, ``pdelta`` (the chord's geometric stiffness) or ``pdelta_consistent``."""
    axial_load: Finite | None = None
    """The axial load P [N] (compression positive), with a P-Δ geometry only."""


class LinearElement(ConfigModel):
    """A linear numerical substructure given by its symmetric stiffness matrix."""

    type: Literal['linear']
    """``linear``."""
    name: Annotated[str, Field(min_length=1)] | None = None
    """A unique name (default: the type and the element's number)."""
    dofs: Annotated[list[DofName], Field(min_length=1)]
    """The structure DOFs it connects (each once, no ground)."""
    stiffness: FloatMatrix
    """Its stiffness matrix [N/m] on ``dofs``."""


class NonlinearSpringElement(ConfigModel):
    """A numerical spring with a hysteresis model (as an element of a specimen section)."""

    type: Literal['nonlinear_spring']
    """``nonlinear_spring``."""
    name: Annotated[str, Field(min_length=1)] | None = None
    """A unique name (default: the type and the element's number)."""
    dofs: Annotated[list[DofOrGround], Field(min_length=1, max_length=2)]
    """``[i, j]`` or ``[j]`` (to the ground)."""
    model: HysteresisModel
    """The hysteresis model."""
    pdelta: PDelta | None = None
    """A leaning column's P-Δ."""


class SetupSpec(ConfigModel):
    """The geometry between an experimental element's basic DOFs and its actuators."""

    type: Literal['one_to_one', 'rigid_link_2', 'planar', 'column', 'planar_3'] = 'one_to_one'
    """The setup: one actuator per basic DOF, or a geometry."""
    geometry: Literal['linear', 'nonlinear'] | None = None
    """Linearised or exact geometry."""
    offsets: list[Finite] | None = None
    """rigid_link_2: the two actuators' offsets [m]."""
    actuator_length: Finite | None = None
    """rigid_link_2: the actuators' length [m]."""
    basic: list[str] | None = None
    """planar: the basic DOFs, ``[u, v]`` or ``[u, v, theta]``."""
    actuators: list[dict[str, Any]] | None = None
    """planar: each actuator's ``{pin: [x, y], attach: [x, y]}`` [m]."""
    horizontal_length: Positive | None = None
    """column, planar_3: the horizontal actuator's length [m]."""
    vertical_length: Positive | None = None
    """column, planar_3: the vertical actuators' length [m]."""
    offset: Positive | None = None
    """planar_3: the vertical actuators' offset [m]."""

    @model_validator(mode='after')
    def _keys(self) -> Self:
        allowed = {
            'one_to_one': {'type'},
            'rigid_link_2': {'type', 'offsets', 'geometry', 'actuator_length'},
            'planar': {'type', 'basic', 'actuators', 'geometry'},
            'column': {'type', 'horizontal_length', 'vertical_length', 'geometry'},
            'planar_3': {'type', 'offset', 'vertical_length', 'horizontal_length', 'geometry'},
        }[self.type]
        extra = sorted(self.model_fields_set - allowed)
        if extra:
            msg = (f'unknown key {extra[0]!r} for a {self.type} setup (keys: '
                   f'{", ".join(sorted(allowed))})')
            raise ValueError(msg)
        return self


class ControlSpec(ConfigModel):
    """How one actuator is controlled."""

    mode: Literal['displacement', 'force'] = 'displacement'
    """``displacement`` (follows the integrator) or ``force`` (holds ``force``)."""
    force: Annotated[Finite | list[list[Finite]],
                     either('a force [N] or a table [[t, F], ...]')] | None = None
    """With force control: the force [N], or a table ``[[t, F], ...]`` (s, N)."""


class ExperimentalElement(ConfigModel):
    """An element measured at a site (a physical substructure)."""

    type: Literal['experimental']
    """``experimental``."""
    name: Annotated[str, Field(min_length=1)] | None = None
    """A unique name (default: the type and the element's number)."""
    site: SiteName
    """The site (a ROS namespace: letters, digits and ``_``, starting with a letter)."""
    dofs: Annotated[list[DofOrGround], Field(min_length=1)]
    """Its basic DOFs (null: a free basic DOF, held by a force-controlled actuator)."""
    relative_to: list[DofOrGround] | None = None
    """DOFs subtracted from ``dofs`` (same length; null: the ground)."""
    setup: SetupSpec | None = None
    """The setup (default: one_to_one)."""
    actuators: list[Annotated[str, Field(min_length=1)]] | None = None
    """The names of the site's actuator DOFs (default from the element)."""
    control: dict[str, ControlSpec | None] | None = None
    """Per actuator name: its control (default: displacement)."""
    initial_stiffness: FloatMatrix
    """The initial stiffness in basic DOFs [N/m]: a scalar, a diagonal or a matrix."""


#: One element of ``structure.elements``, chosen by its ``type`` key.
Element = Annotated[SpringElement | BeamColumnElement | LinearElement | NonlinearSpringElement
                    | ExperimentalElement, Field(discriminator='type')]


class StructureSection(ConfigModel):
    """The structure: DOFs, mass, damping, stiffness or elements, influence of the ground."""

    dof_names: Annotated[list[DofName], Field(min_length=1),
                         check(lambda names: len(set(names)) == len(names),
                               'names must be unique')] | None = None
    """The DOF names (unique; default ``u1, u2, ...`` one per mass)."""
    mass: FloatMatrix
    """The mass [kg]: a number (SDOF), a diagonal, or a matrix; 0 makes a massless, condensed
    DOF (with elements)."""
    damping: Annotated[Annotated[DampingRatio, Tag('number')]
                       | Annotated[DampingSection, Tag('mapping')],
                       by_shape('mapping', number='number')] = 0.0
    """Viscous damping (a bare number is a ratio)."""
    initial_stiffness: Annotated[Annotated[Literal['probe'], Tag('string')]
                                 | Annotated[FloatMatrix, Tag('values')],
                                 by_shape('values', string='string')] | None = None
    """The initial stiffness [N/m] (a matrix for an MDOF), or ``probe`` (measured before the
    test); not with ``elements``."""
    elements: Annotated[list[Element], Field(min_length=1)] | None = None
    """The numerical and experimental elements (instead of ``initial_stiffness``)."""
    influence: list[Finite] | None = None
    """The ground motion's influence vector (one value per DOF; default all 1)."""

    @model_validator(mode='after')
    def _stiffness_or_elements(self) -> Self:
        if self.elements is not None and self.initial_stiffness is not None:
            msg = 'give initial_stiffness or elements, not both'
            raise ValueError(msg)
        if self.elements is None and self.initial_stiffness is None:
            msg = "give initial_stiffness (a value or 'probe') or elements"
            raise ValueError(msg)
        return self


class InlineRecord(ConfigModel):
    """A record written in the test file."""

    dt: Positive
    """The record's time step [s]."""
    acceleration: list[Finite]
    """The accelerations (in ``units``)."""


class GroundMotionSection(ConfigModel):
    """The ground motion: a record file or an inline record, scaled."""

    file: Annotated[str, Field(min_length=1)] | None = None
    """The record file (relative to the test file's folder); or ``inline``."""
    format: Literal['auto', 'two_column', 'single_column', 'multi_column', 'at2',
                    'mat'] | None = 'auto'
    """The file's format (null: auto)."""
    units: Literal['g', 'm/s2', 'm/s^2'] | None = 'g'
    """The accelerations' units (null: g)."""
    g: Positive | None = 9.81
    """The acceleration of gravity [m/s2] for units g (null: 9.81)."""
    dt: Positive | None = None
    """The record's time step [s] (files without one)."""
    scale: Finite = 1.0
    """Factor on the record."""
    direction: Annotated[float, check(lambda value: value in (1.0, -1.0), 'must be 1 or -1'),
                         Field(json_schema_extra={'enum': [1, -1]})] = 1.0
    """1 or -1: the record's sign."""
    inline: InlineRecord | None = None
    """A record written here instead of ``file``."""
    record: dict[str, Any] | None = None
    """What an inline record is (its origin), kept with the run."""

    @model_validator(mode='after')
    def _check(self) -> Self:
        if (self.file is None) == (self.inline is None):
            msg = 'give exactly one of file or inline'
            raise ValueError(msg)
        return self


class GroundMotionComponent(GroundMotionSection):
    """One component of a multi-directional ground motion."""

    name: str | int | None = None
    """The component's name (default ``component<k>``)."""
    influence: list[Finite]
    """The component's influence vector (one value per DOF)."""


class ProtocolSection(ConfigModel):
    """The step protocol between the integrator and the sites."""

    feedback_timeout: Positive | None = 2.0
    """How long the integrator waits for a site's feedback [s] before it retries (null: 2)."""
    max_retries: Annotated[int, Field(ge=0)] = 3
    """Retries of a command before the test holds."""
    start_timeout: Positive | None = 30.0
    """How long the integrator waits for the sites at the start [s] (null: 30)."""
    tracking_tolerance: NonNegative = 0.005
    """|measured − commanded| [m] above which the step is flagged (0: off)."""


class ProbeSection(ConfigModel):
    """The probe that measures the initial stiffness (``initial_stiffness: probe``)."""

    amplitude: Positive | None = 1.0e-3
    """The probe's displacement [m] (null: 1e-3)."""


class CollapseSection(ConfigModel):
    """When the structure has collapsed, and what the test then does."""

    drift: Annotated[Positive | list[Positive],
                     either('a positive number or a list of positive numbers (one per DOF)')]
    """The drift [m] beyond which a DOF has collapsed (one value, or one per DOF)."""
    action: Literal['stop', 'hold', 'continue'] | None = 'stop'
    """What the test does on collapse (null: stop)."""
    window: Annotated[int, Field(ge=1)] = 5
    """Steps the tangent must stay below ``tangent_ratio``."""
    tangent_ratio: NonPositive | None = 0.0
    """Tangent over initial stiffness at or below which a DOF is collapsing (<= 0; null:
    0)."""


class RigSection(ConfigModel):
    """The rig the test runs on: its ROS domain, discovery range and key."""

    domain_id: Annotated[int, Field(json_schema_extra={'minimum': 0, 'maximum': 232}),
                         check(lambda value: 0 <= value <= 101 or 215 <= value <= 232,
                               'must be an integer in 0-101 or 215-232')] | None = None
    """ROS_DOMAIN_ID of the rig (0-101 or 215-232)."""
    discovery: Literal['localhost', 'subnet'] = 'localhost'
    """``localhost`` or ``subnet`` (a multi-host test)."""
    static_peers: list[str] | None = None
    """With subnet: the other hosts (ROS_STATIC_PEERS)."""
    key_file: Annotated[str, Field(min_length=1)] | None = None
    """The rig's key file."""


class NamedSection(ConfigModel):
    """A plug-in chosen by name, with its own parameters (checked by the plug-in)."""

    model_config = ConfigDict(extra='allow')


class PlantSection(NamedSection):
    """The plant model of a transfer system, ``{model: NAME, ...its parameters}``."""

    model: Annotated[str, Field(min_length=1)]
    """The registered plant model (``benchmark``, ``ideal``, ...)."""


class CompensatorSection(NamedSection):
    """The compensator of a transfer system, ``{name: NAME, ...its parameters}``."""

    name: Annotated[str, Field(min_length=1)]
    """The registered compensator."""


class PhysicalSpecimen(ConfigModel):
    """The physical specimen whose force the load cell reads."""

    mass: NonNegative
    """Its mass m_e [kg]."""
    stiffness: Positive
    """Its stiffness k_e [N/m]."""
    damping_ratio: NonNegative
    """Its damping ratio."""


class NoiseSection(ConfigModel):
    """Sensor noise of a transfer system."""

    displacement_power: NonNegative = 0.0
    """Power spectral density of the displacement noise [m2 s]."""
    force_power: NonNegative = 0.0
    """Power spectral density of the force noise [N2 s]."""
    seed: Annotated[int, Field(ge=0)] = 0
    """Seed of the noise generator."""


class RealtimeSection(ConfigModel):
    """Real-time options of a transfer system."""

    hold_at: Positive = 0.8
    """The farthest phase, as a fraction of the step, the predictor goes while the next target
    is missing."""
    slowdown_samples: Positive = 2.0
    """Controller samples to brake from full rate to the hold (and to recover)."""
    cpu_latency: Annotated[float, Field(ge=0.0, le=2000.0)] | None = 0.0
    """The CPUs' wake-up latency asked of Linux while the actuator ticks against the wall clock
    [s] (PM QoS, ``/dev/cpu_dma_latency``; needs root or a udev rule): 0 keeps idle CPUs
    polling, awake for the next message; null asks nothing (idle CPUs sleep, saving power)."""


class TransferSystemSection(ConfigModel):
    """A site's continuous (real-time) transfer system: plant, compensator, specimen."""

    controller_rate: Positive = 4096.0
    """The controller's rate [Hz] (the integration step a whole multiple of its period)."""
    plant: PlantSection
    """The plant model: ``{model: NAME, ...}``."""
    compensator: CompensatorSection | None = None
    """The compensator: ``{name: NAME, ...its parameters}`` (default: none)."""
    specimen: PhysicalSpecimen | None = None
    """The physical specimen (default: the plant's own)."""
    noise: NoiseSection | None = None
    """Sensor noise (default: none)."""
    quantum: NonNegative = 0.0
    """Quantisation step of command and measured displacement [m] (0: none)."""
    capacity: Positive | None = None
    """Actuator force capacity [N] (null: none)."""
    interpolation: Literal['linear', 'cubic'] = 'linear'
    """The predictor-corrector polynomials."""
    inertia: Literal['measured', 'subtract'] = 'measured'
    """``measured`` (the load cell's force) or ``subtract`` (minus m_e times the plant's
    acceleration)."""
    realtime: RealtimeSection | None = None
    """Real-time options."""


class OpenSeesSite(ConfigModel):
    """A numerical substructure run by OpenSees behind an adapter element at the site."""

    model: Annotated[str, Field(min_length=1)] | None = None
    """The OpenSees model of opensees_site (``script`` when a script is given)."""
    stiffness: Positive | None = None
    """Its stiffness [N/m]."""
    yield_force: Positive | None = None
    """Its yield force [N]."""
    penalty: Positive | None = None
    """The adapter element's penalty stiffness [N/m]."""
    script: Annotated[str, Field(min_length=1)] | None = None
    """An OpenSees Tcl script (relative to the test file's folder)."""
    tolerance: Positive | None = None
    """The tolerance of the OpenSees analysis."""


class SiteSettings(ConfigModel):
    """What a site's simulator simulates and the site's own bridge parameters."""

    specimen: SpecimenSection | None = None
    """The site's simulated specimen (ignored for a physical site)."""
    bridge: SiteBridgeParameters | None = None
    """The site's bridge parameters (override the bridge's parameter file for this site)."""
    transfer_system: TransferSystemSection | None = None
    """A continuous (real-time) transfer system simulated at the site."""
    opensees: OpenSeesSite | None = None
    """A numerical substructure in OpenSees served at the site (opensees_site)."""


class TestFileModel(ConfigModel):
    """A test file.

    The test, the structure, the ground motion, and optionally the protocol, the probe, the
    simulated specimen, the sites, collapse and the rig.
    """

    __test__ = False  # (not a pytest test class)

    schema_version: Any = None
    """The schema's version (ignored)."""
    test: TestSection
    """The test."""
    structure: StructureSection
    """The structure."""
    ground_motion: Annotated[
        Annotated[GroundMotionSection, Tag('mapping')]
        | Annotated[list[GroundMotionComponent], Field(min_length=1, max_length=3), Tag('list')],
        by_shape('mapping', list='list')]
    """The ground motion: one record, or 1-3 components each with its influence."""
    protocol: ProtocolSection = ProtocolSection()
    """The step protocol."""
    probe: ProbeSection = ProbeSection()
    """The initial-stiffness probe."""
    specimen: SpecimenSection | None = None
    """The simulated specimen (read by the specimen simulator and the ROS-free runner)."""
    sites: dict[SiteName, SiteSettings | None] | None = None
    """Per site of a substructured test: its simulator and bridge settings."""
    collapse: CollapseSection | None = None
    """Collapse detection."""
    rig: RigSection | None = None
    """The rig (read by run_test only)."""
