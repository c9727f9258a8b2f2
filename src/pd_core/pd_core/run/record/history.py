"""The response history of a test: what ``response.csv`` holds."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pd_common.types import FloatArray


@dataclass
class ResponseHistory:
    """Committed response, one row per step (step 0 is the initial state).

    Attributes:
        dof_names: DOF names.
        dt: integration time step [s].
        displacement: computed (commanded) displacement x [m], shape (steps + 1, n_dof).
        velocity: velocity v [m/s].
        acceleration: relative acceleration a [m/s²].
        restoring_force: measured restoring force fs [N].
        measured_displacement: displacement measured at the specimen [m].
        ground_acceleration: a_g at each step [m/s²], shape (steps + 1,).
        n_committed: number of rows filled (steps committed + 1).
    """

    dof_names: tuple[str, ...]
    dt: float
    displacement: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    restoring_force: NDArray[np.float64]
    measured_displacement: NDArray[np.float64]
    ground_acceleration: NDArray[np.float64]
    n_committed: int = 0

    @classmethod
    def allocate(cls, dof_names: tuple[str, ...], dt: float, ground_acceleration: np.ndarray
                 ) -> ResponseHistory:
        """Empty history for ``len(ground_acceleration)`` rows.

        The rows are written with zeros here (``np.full``, not the lazily mapped pages of
        ``np.zeros``): recording a step then costs no page faults (a 10,000-DOF model would
        otherwise fault in 400 kB of new pages every step).
        """
        rows = len(ground_acceleration)
        shape = (rows, len(dof_names))
        return cls(dof_names=dof_names, dt=dt, displacement=np.full(shape, 0.0),
                   velocity=np.full(shape, 0.0), acceleration=np.full(shape, 0.0),
                   restoring_force=np.full(shape, 0.0),
                   measured_displacement=np.full(shape, 0.0),
                   ground_acceleration=np.asarray(ground_acceleration, dtype=float))

    def record(self, step: int, x: np.ndarray, v: np.ndarray, a: np.ndarray,
               force: tuple[float, ...] | FloatArray,
               measured: tuple[float, ...] | FloatArray) -> None:
        """Fill row ``step`` (rows are filled in order)."""
        self.displacement[step] = x
        self.velocity[step] = v
        self.acceleration[step] = a
        self.restoring_force[step] = force
        self.measured_displacement[step] = measured
        self.n_committed = step + 1

    @property
    def steps(self) -> np.ndarray:
        """Step indices of the committed rows."""
        return np.arange(self.n_committed)

    @property
    def time(self) -> np.ndarray:
        """Time of the committed rows [s] (step · dt)."""
        return self.steps * self.dt

    def columns(self) -> dict[str, np.ndarray]:
        """Committed rows as named columns, in ``response.csv`` order.

        Columns: ``time``, ``step``, then per DOF ``x_<dof>``, ``v_<dof>``, ``a_<dof>``,
        ``fs_<dof>`` (SI units) and the measured displacement ``xm_<dof>``; last ``ag``.
        """
        n = self.n_committed
        result: dict[str, np.ndarray] = {'time': self.time, 'step': self.steps}
        for j, name in enumerate(self.dof_names):
            result[f'x_{name}'] = self.displacement[:n, j]
            result[f'v_{name}'] = self.velocity[:n, j]
            result[f'a_{name}'] = self.acceleration[:n, j]
            result[f'fs_{name}'] = self.restoring_force[:n, j]
            result[f'xm_{name}'] = self.measured_displacement[:n, j]
        result['ag'] = self.ground_acceleration[:n]
        return result
