"""The typed schema of a ``specimen`` section (the simulated specimen, or one site's).

Its hysteresis models, backbones, column and injected experimental errors.

Mirrors :mod:`pd_common.specimen.config` (the builder of the models) and
:class:`pd_common.experimental.ErrorModel`; the keys, bounds and defaults are theirs.
"""

from __future__ import annotations

import re
from typing import Annotated, Literal, Self

from pydantic import (
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    ValidationInfo,
    field_validator,
    model_validator,
)

from .schema_base import ConfigModel, Finite, NonNegative, Positive, check

__all__ = ['BilinearBackbone', 'BilinearModel', 'BoucWenModel', 'ColumnSpecimen',
           'ElasticModel', 'EppModel', 'ErrorsSection', 'HysteresisModel', 'OpenSeesBackbone',
           'PushoverBackbone', 'PushoverModel', 'SpecimenSection']

#: A hardening ratio: the post-yield slope over the elastic one, in (-1, 1) (negative:
#: softening).
HardeningRatio = Annotated[float, Field(gt=-1.0, lt=1.0, allow_inf_nan=False)]
#: A non-empty file name (relative names resolve against the test file's folder).
FileName = Annotated[str, Field(min_length=1)]


class ElasticModel(ConfigModel):
    """A linear elastic spring."""

    model: Literal['elastic']
    """The hysteresis model."""
    stiffness: Positive
    """Stiffness [N/m]."""


class EppModel(ConfigModel):
    """An elastic-perfectly-plastic spring."""

    model: Literal['epp']
    """The hysteresis model."""
    stiffness: Positive
    """Elastic stiffness [N/m]."""
    yield_force: Positive
    """Yield force [N]."""


class BilinearModel(ConfigModel):
    """A bilinear spring with kinematic hardening (or softening to a strength floor)."""

    model: Literal['bilinear']
    """The hysteresis model."""
    stiffness: Positive
    """Elastic stiffness [N/m]."""
    yield_force: Positive
    """Yield force [N]."""
    hardening_ratio: HardeningRatio
    """Post-yield over elastic stiffness, in (-1, 1); negative: softening."""
    residual_force: NonNegative | None = None
    """Strength floor [N] of a softening spring, in [0, yield_force] (softening only)."""


class BilinearBackbone(ConfigModel):
    """A bilinear backbone curve."""

    stiffness: Positive
    """Initial stiffness [N/m]."""
    yield_force: Positive
    """Yield force [N]."""
    hardening_ratio: HardeningRatio = 0.0
    """Post-yield over elastic stiffness, in (-1, 1)."""
    max_displacement: Positive | None = None
    """Last point of the curve [m] (default: the model's)."""
    residual_force: NonNegative | None = None
    """Strength floor [N] of a softening backbone."""


class OpenSeesBackbone(ConfigModel):
    """A backbone read from an OpenSees pushover's recorder files."""

    displacement_file: FileName
    """The displacement recorder's file."""
    reaction_file: FileName
    """The base reaction recorder's file."""
    skip_rows: Annotated[int, Field(ge=0)] = 10
    """Rows skipped at the top of both files."""
    column: Annotated[int, Field(ge=0)] = 1
    """The column read (0-based)."""
    force_sign: Annotated[float, Field(allow_inf_nan=False),
                          check(lambda value: value != 0.0, 'must be non-zero')] = -1.0
    """Factor on the reactions' sign (non-zero): the reaction is opposite to the force."""
    force_scale: Positive = 1.0
    """Factor on the forces."""


class PushoverBackbone(ConfigModel):
    """The backbone of a pushover element: exactly one of ``bilinear``, ``csv``, ``opensees``."""

    bilinear: BilinearBackbone | None = None
    """A bilinear backbone."""
    csv: FileName | None = None
    """A CSV file of (displacement [m], force [N]) points."""
    opensees: OpenSeesBackbone | None = None
    """An OpenSees pushover's recorder files."""

    @model_validator(mode='after')
    def _one(self) -> Self:
        given = [key for key in ('bilinear', 'csv', 'opensees') if getattr(self, key) is not None]
        if len(given) != 1:
            msg = f'needs exactly one of bilinear, csv, opensees, got {len(given)}'
            raise ValueError(msg)
        return self


class PushoverModel(ConfigModel):
    """A spring following a pushover (backbone) curve, with the thesis's unloading rule."""

    model: Literal['pushover']
    """The hysteresis model."""
    backbone: PushoverBackbone
    """The backbone curve."""
    unloading_stiffness: Positive | None = None
    """Unloading stiffness [N/m] (default: the backbone's initial stiffness)."""
    beyond_last_point: Literal['extrapolate', 'plateau', 'error'] = 'extrapolate'
    """What happens past the backbone's last point."""
    memory: Literal['none', 'kinematic'] = 'none'
    """``none``: the thesis's rule; ``kinematic``: each direction continues along its backbone
    from the furthest point it reached."""


class BoucWenModel(ConfigModel):
    """A Bouc–Wen smooth hysteretic spring (with optional degradation)."""

    model: Literal['bouc_wen']
    """The hysteresis model."""
    stiffness: Positive
    """Initial stiffness [N/m]."""
    post_yield_ratio: Finite
    """Post-yield over initial stiffness."""
    exponent: Positive
    """Smoothness exponent n."""
    beta: Finite
    """Shape parameter beta [1/m^n]."""
    gamma: Finite
    """Shape parameter gamma [1/m^n]."""
    a0: Positive | None = None
    """Initial value of A (default 1)."""
    delta_a: Finite | None = None
    """Degradation of A per unit of dissipated energy [1/J]."""
    delta_nu: Finite | None = None
    """Strength degradation per unit of dissipated energy [1/J]."""
    delta_eta: Finite | None = None
    """Stiffness degradation per unit of dissipated energy [1/J]."""
    tolerance: Positive | None = None
    """Tolerance of the implicit update."""
    max_iterations: Annotated[int, Field(ge=0)] | None = None
    """Most iterations of the implicit update."""


#: A registry name (of a plug-in's model).
_NAME = re.compile(r'^[a-z][a-z0-9_]*$')

#: The models of this package (the others are plug-ins' ``pd.hysteresis`` entry points).
BUILT_IN_MODELS = ('elastic', 'epp', 'bilinear', 'pushover', 'bouc_wen')


class PluginModel(ConfigModel):
    """A plug-in package's hysteresis model.

    Its keys are checked by its own declarations (``pd_common.specimen.HYSTERESIS_MODELS``) when
    the specimen is built.
    """

    model_config = ConfigDict(extra='allow')
    model: Annotated[str, Field(json_schema_extra={'pattern': _NAME.pattern})]
    """The model's registry name (its entry point's name)."""

    @field_validator('model')
    @classmethod
    def _registered(cls, value: str, info: ValidationInfo) -> str:
        """A name the registry knows.

        When the caller gives the registered names (the ``hysteresis_models`` of
        :func:`~pd_common.config.schema.validate_test_file`).
        """
        context = info.context or {}
        known = context.get('hysteresis_models')
        if known is None and not _NAME.fullmatch(value):
            msg = f'must match {_NAME.pattern}'
            raise ValueError(msg)
        if known is not None and value not in known:
            msg = 'must be one of ' + ', '.join(repr(name) for name in known)
            broken = context.get('hysteresis_broken', {}).get(value)
            if broken is not None:
                msg += f' (its plug-in did not load: {broken})'
            raise ValueError(msg)
        return value


def _model_tag(value: object) -> str:
    model = value.get('model') if isinstance(value, dict) else getattr(value, 'model', None)
    return model if isinstance(model, str) and model in BUILT_IN_MODELS else 'plugin'


#: One hysteresis model, chosen by its ``model`` key.
HysteresisModel = Annotated[
    Annotated[ElasticModel, Tag('elastic')] | Annotated[EppModel, Tag('epp')]
    | Annotated[BilinearModel, Tag('bilinear')] | Annotated[PushoverModel, Tag('pushover')]
    | Annotated[BoucWenModel, Tag('bouc_wen')] | Annotated[PluginModel, Tag('plugin')],
    Discriminator(_model_tag)]


class ColumnSpecimen(ConfigModel):
    """A cantilever column with P-Δ (basic DOFs u, v), served by the specimen server."""

    height: Positive
    """Height L [m]."""
    axial_stiffness: Positive
    """Axial stiffness k_a [N/m]."""
    lateral: HysteresisModel
    """The lateral spring (any hysteresis model)."""


class ErrorsSection(ConfigModel):
    """Experimental errors injected into each step of the simulated specimen."""

    systematic: Annotated[float, Field(gt=-1.0, le=1.0, allow_inf_nan=False)] = 0.0
    """Displacement error as a fraction of the increment, in (-1, 1] (-0.05: a 5 % undershoot)."""
    delay_steps: Annotated[int, Field(ge=0)] = 0
    """Constant delay of the executed target [steps]."""
    displacement_noise: NonNegative = 0.0
    """Standard deviation of the displacement measurement noise [m]."""
    force_noise: NonNegative = 0.0
    """Standard deviation of the force measurement noise [N]."""
    force_bias: Finite = 0.0
    """Constant force-measurement offset [N]."""
    seed: Annotated[int, Field(ge=0)] | None = None
    """Seed of the noise generator (null: a different draw every run)."""


class SpecimenSection(ConfigModel):
    """The simulated specimen: ``elements`` (a model per DOF or story) or a ``column``."""

    topology: Literal['independent', 'shear_building'] = 'independent'
    """How the elements connect the DOFs: one per DOF, or one per story."""
    elements: Annotated[list[HysteresisModel], Field(min_length=1)] | None = None
    """One hysteresis model per DOF (independent) or per story (shear_building)."""
    column: ColumnSpecimen | None = None
    """A cantilever column instead of elements (the specimen server only)."""
    errors: ErrorsSection | None = None
    """Experimental errors injected by the simulator."""
    commit: Literal['per_command', 'per_step'] = 'per_command'
    """When the simulated specimen commits its state: at every command (as a physical one) or
    once per step."""

    @model_validator(mode='after')
    def _elements_or_column(self) -> Self:
        if (self.elements is None) == (self.column is None):
            msg = 'give either elements or column'
            raise ValueError(msg)
        return self
