"""Energy balance of a test: input = kinetic + viscous + strain/hysteretic (+ error).

For ``M a + C v + r = p`` with ``p = −M ι a_g`` (relative coordinates), integrating
``vᵀ(·) dt = (·)ᵀ dx`` over the test gives (Uang & Bertero's relative energy equation)::

    E_input(t)   = ∫ pᵀ dx                       work of the effective earthquake load
    E_kinetic(t) = ½ vᵀ M v                      (relative) kinetic energy
    E_viscous(t) = ∫ (C v)ᵀ dx                   energy dissipated by viscous damping
    E_strain(t)  = ∫ rᵀ dx                       recoverable strain + dissipated hysteretic
                                                 energy of the specimen

One displacement for every term: ``x`` is the committed displacement (the one of the
equation of motion, ``x_<dof>`` in ``response.csv``), and ``r`` is the restoring force *at*
``x``: the measured force carried from where it was measured (``x_m``, ``xm_<dof>``) to ``x``
along the initial stiffness, ``r = r_m + K_I (x − x_m)``. That is the force an
operator-splitting or implicit scheme commits (its last correction is not imposed: ``x ≠
x_m``, and it commits ``r_m + K_I (x − x_m)``), and the measured force itself where the
specimen is at ``x`` (an explicit scheme, an actuator without error). Without ``K_I``
(``initial_stiffness=None``) ``r = r_m`` is taken at ``x``.

Each integral is accumulated with the trapezoidal rule over the committed steps; the *energy
error* ``E_input − E_kinetic − E_viscous − E_strain`` over the largest energy term of the run
is what the balance misses:

* the time stepping's own error. For a scheme whose committed state satisfies
  ``M a + C v + r = p`` at every step with Newmark's ``γ = 1/2`` (Newmark explicit,
  ``newmark_implicit``/``average_acceleration``/``linear_acceleration``, α-OS at ``α = 0``)
  it is exactly ``(β − ¼) Δt²/2 (a_nᵀ M a_n − a_0ᵀ M a_0)``: zero (round-off) for average
  acceleration (β = ¼), ``−Δt²/8 a_nᵀ M a_n`` (``a_0 = 0``) for Newmark explicit (β = 0);
  α-weighted schemes add their numerical dissipation;
* the actuator's error where the scheme did not correct for it: minus the work of
  ``K_I (x_command − x_m)`` along ``x`` (e.g. an explicit scheme, which commits the measured
  force with ``x = x_command``, when the specimen is at ``x_m ≠ x``);
* the force measurement's errors, and a specimen whose stiffness is not ``K_I`` over the
  carried part ``x − x_m`` (the estimate ``r_m + K_I (x − x_m)``).

(Until issue 31 the strain energy was integrated along ``x_m`` and the other terms along
``x``: with an implicit or operator-splitting scheme, whose committed ``x`` is not ``x_m``,
that mixed two displacements. On the thesis's column, linear elastic, El Centro 12 s,
Δt = 0.01 s, ``average_acceleration`` left 4.3e-5 of the scale where one displacement gives
5e-15, ``alpha_os`` (α = −0.05) 2.7e-3 where its own dissipation is 3.7e-4.)
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
                   influence: np.ndarray, loads: np.ndarray | None = None,
                   initial_stiffness: np.ndarray | None = None) -> EnergyHistory:
    """The energy terms of a committed history (see the module docstring).

    ``loads`` (rows p_k = −M Σ ι_c a_gc) replaces ``−M ι a_g`` for multi-component motions.
    ``initial_stiffness`` (``K_I``, n × n) carries the measured force to the committed
    displacement; ``None``: the measured force is taken there as it is.
    """
    n = history.n_committed
    x = history.displacement[:n]
    v = history.velocity[:n]
    load = (-np.outer(history.ground_acceleration[:n], mass @ influence) if loads is None
            else loads[:n])
    force = history.restoring_force[:n]
    if initial_stiffness is not None:
        force = force + (x - history.measured_displacement[:n]) @ np.asarray(
            initial_stiffness, dtype=float).T
    kinetic = 0.5 * np.einsum('ij,jk,ik->i', v, mass, v)
    return EnergyHistory(
        input=_trapezoid(load, x),
        kinetic=kinetic,
        viscous=_trapezoid(v @ damping.T, x),
        strain=_trapezoid(force, x),
    )
