"""Batch pre-test simulation: a test's numerical model for many records, scales and variations.

Before a test, a lab runs the numerical model under candidate records and scale factors to see
whether the actuators' stroke, velocity and force suffice. This package runs every record ×
scale × parameter variation of an SDOF test file at once, vectorised over the systems with
numpy, with the same arithmetic as the session (so each run equals a one-at-a-time
``./pd offline`` run to the last bit), and checks the predicted demand against the actuator
bridge's limits. Pure numpy, no ROS.

* :mod:`.models` — the hysteresis models, vectorised;
* :mod:`.integrator` — Newmark explicit, vectorised;
* :mod:`.plan` — the runs of a test file (records, scales, ``--vary``);
* :mod:`.execute` — batches (and processes) of systems;
* :mod:`.limits` — the bridge's limits, which runs trip them and where the bridge holds them;
* :mod:`.spectra` — elastic response spectra of the records;
* :mod:`.report`, :mod:`.figures` — CSV, summary table and figures.
"""

from __future__ import annotations

from .errors import PretestError
from .execute import RunOutcome, execute, integrate
from .integrator import BatchResult, BatchSystems, run_newmark_explicit
from .limits import LIMIT_NAMES, BridgeLimits, Hold, first_holds, read_bridge_limits, trips
from .models import (
    SUPPORTED_MODELS,
    BatchModel,
    BilinearBatch,
    ElasticBatch,
    EPPBatch,
    PushoverBatch,
    batch_from_models,
)
from .plan import Plan, Variation, build_plan, parse_scales, parse_variation
from .spectra import Spectrum, response_spectrum

__all__ = [
    'LIMIT_NAMES',
    'SUPPORTED_MODELS',
    'BatchModel',
    'BatchResult',
    'BatchSystems',
    'BilinearBatch',
    'BridgeLimits',
    'EPPBatch',
    'ElasticBatch',
    'Hold',
    'Plan',
    'PretestError',
    'PushoverBatch',
    'RunOutcome',
    'Spectrum',
    'Variation',
    'batch_from_models',
    'build_plan',
    'execute',
    'first_holds',
    'integrate',
    'parse_scales',
    'parse_variation',
    'read_bridge_limits',
    'response_spectrum',
    'run_newmark_explicit',
    'trips',
]
