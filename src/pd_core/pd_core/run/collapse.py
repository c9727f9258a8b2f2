"""Collapse: the structure's tangent turned negative beyond a stated drift.

A specimen that softens (P-Δ, local buckling, a degrading model) reaches a branch where its
restoring force falls as the displacement grows. Beyond the drift the test file states, that is
collapse: the test says so once, clearly, and stops, holds or goes on as asked.

The tangent is measured, not assumed: for DOF ``i`` at committed step ``n`` it is the
incremental stiffness ``k_t = (r_i[n] − r_i[n−w]) / (x_i[n] − x_i[n−w])`` over the last ``w``
(``window``) committed steps, taken only while the DOF moves monotonically away from zero over
the whole window (so unloading and reversals never count). Collapse at step ``n``:
``|x_i[n]| > drift_i`` and ``k_t < tangent_ratio · K_I[i, i]`` (``tangent_ratio`` 0: any
negative tangent; a negative ratio, e.g. −0.005, keeps measurement noise on a plastic plateau
from counting). ``x`` is the committed (computed) displacement and ``r`` the measured restoring
force, so numerical substructures and P-Δ in the model are included.

Schema (``collapse:`` section of a test file; absent: no check)::

    collapse:
      drift: 0.25          # m: one value for every DOF, or a list (one per DOF)
      action: stop         # stop (end the test there, outputs written) | hold | continue
      window: 5            # committed steps over which the tangent is measured, >= 1
      tangent_ratio: 0.0   # collapse when k_t < tangent_ratio * K_I[i, i]; <= 0
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pd_common.units import format_quantity

__all__ = ['COLLAPSE_ACTIONS', 'Collapse', 'CollapseMonitor', 'CollapseSettings']

#: What a test does at collapse.
COLLAPSE_ACTIONS = ('stop', 'hold', 'continue')


@dataclass(frozen=True)
class CollapseSettings:
    """The ``collapse`` section, resolved.

    Attributes:
        drift: displacement magnitude per DOF beyond which a negative tangent is collapse [m].
        action: ``stop``, ``hold`` or ``continue``.
        window: committed steps over which the tangent is measured.
        tangent_ratio: collapse when the tangent is below this ratio of ``K_I[i, i]`` (≤ 0).
    """

    drift: tuple[float, ...]
    action: str = 'stop'
    window: int = 5
    tangent_ratio: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        """The section as written back to a resolved test file."""
        return {'drift': list(self.drift), 'action': self.action, 'window': self.window,
                'tangent_ratio': self.tangent_ratio}


@dataclass(frozen=True)
class Collapse:
    """Where collapse was found.

    Attributes:
        step: committed step at which it was found.
        time: its test time [s].
        dof: the DOF's name.
        displacement: the DOF's displacement there [m].
        restoring_force: the DOF's measured restoring force there [N].
        tangent: the measured incremental stiffness [N/m] (negative).
        initial_stiffness: ``K_I[i, i]`` [N/m].
        drift: the stated drift of the DOF [m].
        action: what the test did (``stop``, ``hold`` or ``continue``).
    """

    step: int
    time: float
    dof: str
    displacement: float
    restoring_force: float
    tangent: float
    initial_stiffness: float
    drift: float
    action: str

    def message(self) -> str:
        """One line for the log and the summary."""
        done = {'stop': 'the test stopped there', 'hold': 'the test holds',
                'continue': 'the test goes on (collapse.action: continue)'}[self.action]
        ratio = self.tangent / self.initial_stiffness if self.initial_stiffness else math.nan
        return (f'COLLAPSE of {self.dof} at step {self.step} (t = {self.time:.6g} s): '
                f'displacement {format_quantity(self.displacement, "m")} beyond the stated '
                f'drift {format_quantity(self.drift, "m")} on a negative tangent '
                f'{format_quantity(self.tangent, "N/m")} ({ratio:.3g} of K_I), restoring force '
                f'{format_quantity(self.restoring_force, "N")}; {done}')

    def as_dict(self) -> dict[str, Any]:
        """For ``summary.json``."""
        return {'step': self.step, 'time': self.time, 'dof': self.dof,
                'displacement': self.displacement, 'restoring_force': self.restoring_force,
                'tangent': self.tangent, 'initial_stiffness': self.initial_stiffness,
                'drift': self.drift, 'action': self.action, 'message': self.message()}


class CollapseMonitor:
    """Looks for collapse after each committed step (first occurrence only).

    Args:
        settings: the resolved ``collapse`` section.
        dof_names: the test's DOF names.
        initial_stiffness: ``K_I`` (its diagonal scales ``tangent_ratio``).
        dt: the test's time step [s].
    """

    def __init__(self, settings: CollapseSettings, dof_names: Sequence[str],
                 initial_stiffness: np.ndarray, dt: float) -> None:
        self.settings = settings
        self.dof_names = tuple(dof_names)
        self._drift = np.asarray(settings.drift, dtype=float)
        self._k_diag = np.diag(np.atleast_2d(np.asarray(initial_stiffness, dtype=float))).copy()
        self._dt = dt
        self.found: Collapse | None = None

    def observe(self, step: int, displacement: np.ndarray, restoring_force: np.ndarray
                ) -> Collapse | None:
        """Check committed step ``step`` given the histories up to it (rows ``0..step``).

        Returns:
            The collapse if it is found at this step (``None`` otherwise, and always after
            the first one).
        """
        w = self.settings.window
        if self.found is not None or step < w:
            return None
        x_now = displacement[step]
        beyond = np.abs(x_now) > self._drift
        if not beyond.any():
            return None
        segment = displacement[step - w:step + 1]
        increments = np.diff(segment, axis=0)
        outward = np.sign(x_now)
        monotonic = np.all(increments * outward > 0.0, axis=0)
        candidates = np.flatnonzero(beyond & monotonic)
        if candidates.size == 0:
            return None
        dx = x_now - segment[0]
        dr = restoring_force[step] - restoring_force[step - w]
        for i in candidates:
            tangent = float(dr[i] / dx[i])
            if tangent < min(self.settings.tangent_ratio * self._k_diag[i], 0.0):
                self.found = Collapse(
                    step=step, time=step * self._dt, dof=self.dof_names[i],
                    displacement=float(x_now[i]),
                    restoring_force=float(restoring_force[step][i]), tangent=tangent,
                    initial_stiffness=float(self._k_diag[i]), drift=float(self._drift[i]),
                    action=self.settings.action)
                return self.found
        return None
