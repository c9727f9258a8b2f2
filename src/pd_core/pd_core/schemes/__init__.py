"""Step-by-step time-integration schemes for the pseudo-dynamic loop.

One module per family, behind one interface (:class:`Integrator`: predict → measured force →
correct → commit, or revert) and one registry (:data:`SCHEMES`, a
:class:`pd_common.registry.Registry`: the built-ins and the ``pd.schemes`` plug-ins):

* :mod:`.newmark_explicit` — the thesis's Newmark explicit scheme;
* :mod:`.explicit_alpha` — explicit schemes with numerical dissipation (no ``K_I``);
* :mod:`.operator_splitting` — α-OS and generalized-α-OS;
* :mod:`.model_based` — CR and KR-α;
* :mod:`.implicit` — implicit Newmark with a fixed number of forward-only iterations.

Shared pieces: :mod:`.base` (the interface), :mod:`.array` (array bases),
:mod:`.parameters` (one declaration per scheme parameter), :mod:`.linalg` (factorisations,
sparse products) and :mod:`.amplification` (amplification-matrix helpers).
"""

from __future__ import annotations

from .array import ArrayIntegrator, GeneralizedAlphaFamily
from .base import Integrator
from .explicit_alpha import ExplicitGeneralizedAlpha, ModifiedNewmark
from .implicit import AverageAcceleration, LinearAcceleration, NewmarkImplicit
from .linalg import Factorization
from .model_based import ChenRicles, KRAlpha
from .newmark_explicit import (
    NewmarkExplicit,
    amplification_matrix_newmark_explicit,
    newmark_explicit_numerical_frequency,
)
from .operator_splitting import AlphaOS, GeneralizedAlphaOS
from .parameters import SchemeParameter, SchemeParameterError, check_parameter
from .registry import (
    SCHEMES,
    make_integrator,
    numerical_schemes,
    register_scheme,
    scheme_class,
)

__all__ = [
    'SCHEMES',
    'AlphaOS',
    'ArrayIntegrator',
    'AverageAcceleration',
    'ChenRicles',
    'ExplicitGeneralizedAlpha',
    'Factorization',
    'GeneralizedAlphaFamily',
    'GeneralizedAlphaOS',
    'Integrator',
    'KRAlpha',
    'LinearAcceleration',
    'ModifiedNewmark',
    'NewmarkExplicit',
    'NewmarkImplicit',
    'SchemeParameter',
    'SchemeParameterError',
    'amplification_matrix_newmark_explicit',
    'check_parameter',
    'make_integrator',
    'newmark_explicit_numerical_frequency',
    'numerical_schemes',
    'register_scheme',
    'scheme_class',
]
