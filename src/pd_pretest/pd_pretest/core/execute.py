"""Running a pre-test plan: batches of systems, optionally split across processes.

Runs that share the time step and the number of steps form one batch (one vectorised
integration); its ground motions are each record × scale once. With ``workers > 1`` a batch is
split into that many contiguous slices, each integrated in its own process (``fork``): the
arithmetic per system is the same, so the results are too. The runs that exceed a limit are
integrated once more with their histories (:data:`HOLD_CHUNK` at a time) to find the step at
which the bridge would hold each (:func:`~.limits.first_holds`).
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from pd_common.specimen import HysteresisModel

from .integrator import BatchResult, BatchSystems, run_newmark_explicit
from .limits import LIMIT_NAMES, BridgeLimits, Hold, first_holds, trips
from .models import batch_from_models
from .plan import Plan, Run

__all__ = ['HOLD_CHUNK', 'Batch', 'RunOutcome', 'batches', 'execute', 'holds', 'integrate']

#: Systems below which a batch is not split across processes (start-up would dominate).
MIN_SYSTEMS_PER_WORKER = 2000
#: Runs integrated again with their histories at once, to find where the bridge holds them
#: (32 bytes per system-step: 100 MB for 1024 runs of El Centro's 3119 steps).
HOLD_CHUNK = 1024


@dataclass(frozen=True)
class RunOutcome:
    """The predicted demand of one run on its actuator.

    Attributes:
        run: the run.
        status: ``ok``; ``unstable`` (ω·Δt above the scheme's limit: the session refuses to
            start); ``diverged`` (non-finite response: the session fails the step).
        omega_dt: ``ω·Δt`` of the initial stiffness.
        peak_stroke: ``max |x|`` commanded [m].
        max_increment: largest ``|Δx|`` in one step [m].
        peak_velocity: ``max_increment / step_duration`` [m/s] (NaN without a step duration).
        peak_force: ``max |f|`` measured [N].
        residual: the displacement at the end [m].
        structure_velocity: ``max |v|`` of the structure in test time [m/s].
        trips: the limits of :data:`~.limits.LIMIT_NAMES` the run would exceed (anywhere:
            its demand past the first one too).
        hold: where the bridge would hold the run (the first step beyond a limit, the limit
            and the bridge's message), ``None`` if nowhere (or it does not start).
    """

    run: Run
    status: str
    omega_dt: float
    peak_stroke: float
    max_increment: float
    peak_velocity: float
    peak_force: float
    residual: float
    structure_velocity: float
    trips: tuple[str, ...]
    hold: Hold | None = None


def _integrate_slice(systems: BatchSystems, models: Sequence[HysteresisModel],
                     history: bool) -> BatchResult:
    return run_newmark_explicit(systems, batch_from_models(models), history=history)


def _slice(systems: BatchSystems, part: slice) -> BatchSystems:
    return BatchSystems(mass=systems.mass[part], damping=systems.damping[part],
                        load_factor=systems.load_factor[part], motions=systems.motions,
                        motion_index=systems.motion_index[part], dt=systems.dt)


#: The batch a forked worker integrates a slice of (inherited with the parent's memory, so
#: nothing but the slice bounds and the results are pickled).
_SHARED: list[tuple[BatchSystems, Sequence[HysteresisModel], bool]] = []


def _forked_slice(lo: int, hi: int) -> BatchResult:
    systems, models, history = _SHARED[-1]
    part = slice(lo, hi)
    return _integrate_slice(_slice(systems, part), models[part], history)


def integrate(systems: BatchSystems, models: Sequence[HysteresisModel], *, workers: int = 1,
              history: bool = False) -> BatchResult:
    """Integrate a batch, in ``workers`` processes if it is large enough.

    The model of each system is built from its scalar model (:func:`batch_from_models`).
    Worker processes are forked (``fork``) after the batch is set aside, so they inherit it.
    """
    n = systems.n
    workers = max(1, min(workers, n // MIN_SYSTEMS_PER_WORKER))
    if workers == 1:
        return _integrate_slice(systems, models, history)
    bounds = np.linspace(0, n, workers + 1).astype(int)
    context = multiprocessing.get_context('fork')
    _SHARED.append((systems, models, history))
    try:
        with ProcessPoolExecutor(max_workers=workers - 1, mp_context=context) as pool:
            futures = [pool.submit(_forked_slice, int(lo), int(hi))
                       for lo, hi in zip(bounds[1:-1], bounds[2:])]
            first = _forked_slice(0, int(bounds[1]))  # this process takes the first slice
            results = [first, *(future.result() for future in futures)]
    finally:
        _SHARED.pop()
    kept = {key: np.concatenate([r.history[key] for r in results], axis=1)
            for key in results[0].history}
    return BatchResult(
        peak_displacement=np.concatenate([r.peak_displacement for r in results]),
        max_increment=np.concatenate([r.max_increment for r in results]),
        peak_force=np.concatenate([r.peak_force for r in results]),
        peak_velocity=np.concatenate([r.peak_velocity for r in results]),
        residual_displacement=np.concatenate([r.residual_displacement for r in results]),
        finite=np.concatenate([r.finite for r in results]), history=kept)


@dataclass(frozen=True)
class Batch:
    """Runs integrated together: their systems and each system's scalar model (virgin)."""

    runs: list[Run]
    systems: BatchSystems
    models: list[HysteresisModel]


def batches(plan: Plan) -> list[Batch]:
    """The plan's runs grouped by time step and number of steps, ready to integrate."""
    groups: dict[tuple[float, int], list[Run]] = {}
    for run in plan.runs:
        record = plan.loads[run.load_key]
        groups.setdefault((record.dt, record.n_steps), []).append(run)
    result = []
    for (dt, _), runs in groups.items():
        columns: dict[tuple[tuple[int, tuple[float, ...]], float], int] = {}
        for run in runs:
            columns.setdefault((run.load_key, run.scale), len(columns))
        motions = np.stack([plan.loads[key].at_test_steps(scale)
                            for (key, scale) in columns], axis=1)
        structures = [plan.structures[run.structure_key] for run in runs]
        systems = BatchSystems(
            mass=np.array([s.mass for s in structures]),
            damping=np.array([s.damping for s in structures]),
            load_factor=np.array([s.load_factor for s in structures]),
            motions=motions,
            motion_index=np.array([columns[(run.load_key, run.scale)] for run in runs],
                                  dtype=np.intp),
            dt=dt)
        result.append(Batch(runs=runs, systems=systems, models=[s.model for s in structures]))
    return result


def holds(batch: Batch, runs: Sequence[int], limits: BridgeLimits, dof_name: str
          ) -> dict[int, Hold | None]:
    """Where the bridge would hold the batch's runs ``runs``.

    Indices in the batch: each integrated again with its history (the same arithmetic per system,
    so the same floats), :data:`HOLD_CHUNK` runs at a time.
    """
    found: dict[int, Hold | None] = {}
    systems = batch.systems
    for first in range(0, len(runs), HOLD_CHUNK):
        chosen = np.asarray(runs[first:first + HOLD_CHUNK], dtype=np.intp)
        part = BatchSystems(mass=systems.mass[chosen], damping=systems.damping[chosen],
                            load_factor=systems.load_factor[chosen], motions=systems.motions,
                            motion_index=systems.motion_index[chosen], dt=systems.dt)
        result = run_newmark_explicit(
            part, batch_from_models([batch.models[j] for j in chosen]), history=True)
        for j, hold in zip(chosen, first_holds(limits, result.history['x'],
                                               result.history['r'], dof_name)):
            found[int(j)] = hold
    return found


def execute(plan: Plan, limits: BridgeLimits, *, workers: int = 1) -> list[RunOutcome]:
    """Every run of ``plan``, in the plan's order."""
    outcomes: dict[int, RunOutcome] = {}
    duration = limits.step_duration
    for batch in batches(plan):
        result = integrate(batch.systems, batch.models, workers=workers)
        tripped = trips(limits, peak_displacement=result.peak_displacement,
                        max_increment=result.max_increment, peak_force=result.peak_force)
        tripping = [j for j, run in enumerate(batch.runs)
                    if plan.structures[run.structure_key].stability.stable
                    and any(tripped[name][j] for name in LIMIT_NAMES)]
        held = holds(batch, tripping, limits, plan.dof_name) if tripping else {}
        for j, run in enumerate(batch.runs):
            stability = plan.structures[run.structure_key].stability
            status = ('unstable' if not stability.stable
                      else 'ok' if result.finite[j] else 'diverged')
            increment = float(result.max_increment[j])
            outcomes[run.index] = RunOutcome(
                run=run, status=status, omega_dt=stability.omega_dt,
                peak_stroke=float(result.peak_displacement[j]), max_increment=increment,
                peak_velocity=increment / duration if duration else float('nan'),
                peak_force=float(result.peak_force[j]),
                residual=float(result.residual_displacement[j]),
                structure_velocity=float(result.peak_velocity[j]),
                trips=tuple(name for name in LIMIT_NAMES if tripped[name][j]),
                hold=held.get(j))
    return [outcomes[i] for i in range(len(plan.runs))]
