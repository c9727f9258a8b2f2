"""Energy balance of a test: input = kinetic + viscous + strain/hysteretic (+ error).

For ``M a + C v + r = p`` with ``p = −M ι a_g`` (relative coordinates), integrating
``vᵀ(·) dt = (·)ᵀ dx`` over the test gives (Uang & Bertero's relative energy equation)::

    E_input(t)   = ∫ pᵀ dx                       work of the effective earthquake load
    E_kinetic(t) = ½ vᵀ M v                      (relative) kinetic energy
    E_viscous(t) = ∫ (C v)ᵀ dx                   energy dissipated by viscous damping
    E_strain(t)  = ∫ rᵀ dx_m                     recoverable strain + dissipated hysteretic
                                                 energy of the specimen (measured force over
                                                 measured displacement)

Each integral is accumulated with the trapezoidal rule over the committed steps, so for a
converged run ``E_input − E_kinetic − E_viscous − E_strain`` is small; its ratio to the
largest energy term of the run is the *energy error*. Errors of the scheme, of the actuator
(measured ≠ commanded displacement) and of the force measurement all show up in it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from .history import ResponseHistory


@dataclass(frozen=True)
class EnergyHistory:
    """Energy terms at each committed step [J] and the normalised error."""

    input: NDArray[np.float64]
    kinetic: NDArray[np.float64]
    viscous: NDArray[np.float64]
    strain: NDArray[np.float64]

    @property
    def error(self) -> NDArray[np.float64]:
        """``E_input − E_kinetic − E_viscous − E_strain`` [J]."""
        return self.input - self.kinetic - self.viscous - self.strain

    @property
    def scale(self) -> float:
        """The largest energy term over the run [J] (the reference of :attr:`error_ratio`)."""
        if self.input.size == 0:
            return 0.0
        return float(max(np.max(np.abs(self.input)), np.max(self.kinetic),
                         np.max(np.abs(self.viscous)), np.max(np.abs(self.strain))))

    @property
    def error_ratio(self) -> NDArray[np.float64]:
        """|error| over the largest energy term of the run (0 if nothing moved)."""
        scale = self.scale
        if scale == 0.0:
            return np.zeros_like(self.input)
        return np.abs(self.error) / scale

    def columns(self) -> dict[str, np.ndarray]:
        """Named columns for ``energy.csv``."""
        return {'E_input': self.input, 'E_kinetic': self.kinetic, 'E_viscous': self.viscous,
                'E_strain': self.strain, 'E_error': self.error,
                'error_ratio': self.error_ratio}

    def summary(self) -> dict[str, float]:
        """Final values and the largest error ratio."""
        if self.input.size == 0:
            return {}
        return {'input': float(self.input[-1]), 'kinetic': float(self.kinetic[-1]),
                'viscous': float(self.viscous[-1]), 'strain': float(self.strain[-1]),
                'error': float(self.error[-1]),
                'max_error_ratio': float(np.max(self.error_ratio)),
                'final_error_ratio': float(self.error_ratio[-1])}


def _trapezoid(force: np.ndarray, displacement: np.ndarray) -> np.ndarray:
    """Cumulative ∫ forceᵀ d(displacement), trapezoidal, starting at 0 (rows = steps)."""
    if force.shape[0] == 0:
        return np.zeros(0)
    increments = 0.5 * np.sum((force[1:] + force[:-1]) * np.diff(displacement, axis=0), axis=1)
    return np.concatenate(([0.0], np.cumsum(increments)))


def energy_balance(history: ResponseHistory, mass: np.ndarray, damping: np.ndarray,
                   influence: np.ndarray, loads: np.ndarray | None = None) -> EnergyHistory:
    """The energy terms of a committed history (see the module docstring).

    ``loads`` (rows p_k = −M Σ ι_c a_gc) replaces ``−M ι a_g`` for multi-component motions.
    """
    n = history.n_committed
    x = history.displacement[:n]
    v = history.velocity[:n]
    load = (-np.outer(history.ground_acceleration[:n], mass @ influence) if loads is None
            else loads[:n])
    kinetic = 0.5 * np.einsum('ij,jk,ik->i', v, mass, v)
    return EnergyHistory(
        input=_trapezoid(load, x),
        kinetic=kinetic,
        viscous=_trapezoid(v @ damping.T, x),
        strain=_trapezoid(history.restoring_force[:n], history.measured_displacement[:n]),
    )
