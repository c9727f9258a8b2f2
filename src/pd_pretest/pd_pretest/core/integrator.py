"""Newmark explicit vectorised over SDOF systems: the session's arithmetic, one array per term.

Per step, for every system at once and in the operation order of
:class:`~pd_core.schemes.NewmarkExplicit` (its SDOF path, thesis eqs. 3.20–3.22)::

    x_{i+1} = x_i + Δt v_i + a_i Δt Δt 0.5
    r_{i+1} = model(x_{i+1})                       (trial, then committed, as the specimen server)
    a_{i+1} = (p_{i+1} − r_{i+1} − c v_i − Δt 0.5 c a_i) / (m + Δt 0.5 c)
    v_{i+1} = v_i + Δt 0.5 (a_i + a_{i+1})

with ``p = −(m ι) a_g`` (:meth:`TestDefinition.loads`) and step 0 as the session runs it
(the specimen at 0, ``a_0 = (p_0 − c v_0 − r_0)/m``). ``a Δt Δt 0.5`` is computed as
``(a Δt)(Δt 0.5)``: halving is exact in binary floating point, so the two are the same float.
Every step is one numpy operation per term on preallocated arrays; the loads are formed a
chunk of steps at a time.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pd_common.types import FloatArray

from .errors import PretestError
from .models import BatchModel

__all__ = ['BatchResult', 'BatchSystems', 'run_newmark_explicit']

#: Steps of loads formed at once.
LOAD_CHUNK = 128


@dataclass
class BatchSystems:
    """SDOF systems that share the time step and the number of steps.

    Attributes:
        mass: ``m`` per system [kg], shape ``(n,)``.
        damping: ``c`` per system [N s/m].
        load_factor: ``m ι`` per system [kg]: ``p = −(m ι) a_g``.
        motions: ground accelerations at the test's steps [m/s²], shape
            ``(n_steps + 1, n_motions)`` (each record × scale once).
        motion_index: the column of ``motions`` of every system, shape ``(n,)``.
        dt: the time step [s].
    """

    mass: FloatArray
    damping: FloatArray
    load_factor: FloatArray
    motions: FloatArray
    motion_index: np.ndarray
    dt: float

    @property
    def n(self) -> int:
        """Number of systems."""
        return int(self.mass.size)

    @property
    def n_steps(self) -> int:
        """Integration steps (the rows of ``motions`` minus step 0)."""
        return int(self.motions.shape[0]) - 1

    def loads(self, start: int, stop: int) -> FloatArray:
        """``p`` of steps ``start..stop-1``, shape ``(stop - start, n)``, as the session's."""
        block = np.take(self.motions[start:stop], self.motion_index, axis=1)
        block *= self.load_factor
        np.subtract(0.0, block, out=block)      # 0 − outer(a_g, m ι), as TestDefinition.loads
        return block


@dataclass
class BatchResult:
    """Peaks of every system (shape ``(n,)``) and, if asked, the whole histories.

    Attributes:
        peak_displacement: ``max |x|`` [m] (the commanded stroke).
        max_increment: ``max |x_{i+1} − x_i|`` [m] (per step, from 0 at step 0).
        peak_force: ``max |r|`` [N] (the measured force).
        peak_velocity: ``max |v|`` [m/s] (the structure's, in test time).
        residual_displacement: ``x`` at the last step [m].
        finite: whether the response stayed finite (else the session fails the step).
        history: ``x``, ``v``, ``a``, ``r`` of shape ``(n_steps + 1, n)`` (empty if not kept).
    """

    peak_displacement: FloatArray
    max_increment: FloatArray
    peak_force: FloatArray
    peak_velocity: FloatArray
    residual_displacement: FloatArray
    finite: np.ndarray
    history: dict[str, FloatArray] = field(default_factory=dict)


def run_newmark_explicit(systems: BatchSystems, model: BatchModel, *,
                         history: bool = False) -> BatchResult:
    """Integrate every system through all its steps (Newmark explicit, SDOF).

    Args:
        systems: the systems and their ground motions.
        model: the vectorised specimen model, one element per system (virgin).
        history: keep ``x, v, a, r`` of every step (memory: 32 bytes per system-step).

    Raises:
        PretestError: the model and the systems differ in size.
    """
    n = systems.n
    if model.n != n:
        msg = f'the model has {model.n} systems, the structure {n}'
        raise PretestError(msg)
    dt = systems.dt
    half_dt = dt * 0.5
    m = systems.mass
    c = systems.damping
    half_dt_c = dt * 0.5 * c
    lhs = m + dt * 0.5 * c
    n_steps = systems.n_steps
    x = np.zeros(n)
    v = np.zeros(n)
    xt = np.empty(n)
    a_new = np.empty(n)
    t1 = np.empty(n)
    peak_x = np.zeros(n)
    max_dx = np.zeros(n)
    peak_f = np.zeros(n)
    peak_v = np.zeros(n)
    with np.errstate(all='ignore'):
        # Step 0: the specimen at rest, a_0 = (p_0 - c v_0 - r_0) / m.
        r = model.trial(x)
        model.commit()
        p0 = systems.loads(0, 1)[0]
        a = (p0 - c * v - r) / m
        np.abs(r, out=peak_f)
        kept = _history(n_steps, n) if history else {}
        if kept:
            _keep(kept, 0, x, v, a, r)
        stop = 0
        loads = p0[np.newaxis, :]
        for step in range(1, n_steps + 1):
            if step >= stop:
                start, stop = step, min(step + LOAD_CHUNK, n_steps + 1)
                loads = systems.loads(start, stop)
            p = loads[step - start]
            # x_{i+1} = x_i + dt v_i + a_i dt dt 0.5
            np.multiply(v, dt, out=xt)
            xt += x
            np.multiply(a, dt, out=t1)
            t1 *= half_dt
            xt += t1
            r = model.trial(xt)
            model.commit()
            # a_{i+1} = (p - r - c v - dt 0.5 c a) / (m + dt 0.5 c)
            np.subtract(p, r, out=a_new)
            np.multiply(c, v, out=t1)
            a_new -= t1
            np.multiply(half_dt_c, a, out=t1)
            a_new -= t1
            a_new /= lhs
            # v_{i+1} = v + dt 0.5 (a + a_{i+1})
            np.add(a, a_new, out=t1)
            t1 *= half_dt
            v += t1
            # Peaks: stroke, increment, force, velocity.
            np.subtract(xt, x, out=t1)
            np.abs(t1, out=t1)
            np.maximum(max_dx, t1, out=max_dx)
            np.abs(xt, out=t1)
            np.maximum(peak_x, t1, out=peak_x)
            np.abs(r, out=t1)
            np.maximum(peak_f, t1, out=peak_f)
            np.abs(v, out=t1)
            np.maximum(peak_v, t1, out=peak_v)
            x, xt = xt, x
            a, a_new = a_new, a
            if kept:
                _keep(kept, step, x, v, a, r)
        finite = np.isfinite(peak_x) & np.isfinite(peak_f) & np.isfinite(peak_v)
    return BatchResult(peak_displacement=peak_x, max_increment=max_dx, peak_force=peak_f,
                       peak_velocity=peak_v, residual_displacement=x.copy(), finite=finite,
                       history=kept)


def _history(n_steps: int, n: int) -> dict[str, FloatArray]:
    return {name: np.zeros((n_steps + 1, n)) for name in ('x', 'v', 'a', 'r')}


def _keep(kept: dict[str, FloatArray], step: int, x: FloatArray, v: FloatArray, a: FloatArray,
          r: FloatArray) -> None:
    kept['x'][step] = x
    kept['v'][step] = v
    kept['a'][step] = a
    kept['r'][step] = r
