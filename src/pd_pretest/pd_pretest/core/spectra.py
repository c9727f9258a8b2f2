"""Elastic response spectra of ground motions (pseudo-acceleration, 5 % damping by default).

Every period's linear SDOF is integrated at once by the exact recurrence for a piecewise-linear
excitation (Nigam & Jennings 1969; :func:`~pd_core.verification.
nigam_jennings_coefficients`), vectorised over the periods: ``S_d = max |x|``,
``S_a = ω² S_d`` (pseudo-acceleration), ``S_v = ω S_d``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pd_common.types import FloatArray
from pd_core.verification import nigam_jennings_coefficients

from .errors import PretestError

__all__ = ['DEFAULT_PERIODS', 'Spectrum', 'response_spectrum']

#: Periods of the spectra [s]: 0.02 … 5 s, log-spaced.
DEFAULT_PERIODS = np.geomspace(0.02, 5.0, 120)


@dataclass(frozen=True)
class Spectrum:
    """A response spectrum.

    Attributes:
        periods: ``T`` [s].
        damping: the damping ratio ``ζ``.
        displacement: ``S_d(T)`` [m].
        pseudo_acceleration: ``S_a = (2π/T)² S_d`` [m/s²].
    """

    periods: FloatArray
    damping: float
    displacement: FloatArray
    pseudo_acceleration: FloatArray

    @property
    def pseudo_velocity(self) -> FloatArray:
        """``S_v = (2π/T) S_d`` [m/s]."""
        result: FloatArray = 2.0 * math.pi / self.periods * self.displacement
        return result

    def at(self, period: float) -> float:
        """``S_a`` at ``period`` [m/s²] (log-linear interpolation in ``T``)."""
        return float(np.interp(math.log(period), np.log(self.periods),
                               self.pseudo_acceleration))


def response_spectrum(acceleration: FloatArray, dt: float, periods: FloatArray | None = None,
                      damping: float = 0.05) -> Spectrum:
    """The response spectrum of a ground acceleration ``a_g`` sampled at ``dt``.

    The SDOF ``ẍ + 2ζωẋ + ω²x = −a_g(t)`` starts at rest; ``a_g`` is linear between samples.

    Raises:
        PretestError: on a non-finite record, ``dt`` or period not positive, ``ζ`` outside
            ``[0, 1)``.
    """
    ag = np.asarray(acceleration, dtype=float).reshape(-1)
    t = np.asarray(DEFAULT_PERIODS if periods is None else periods, dtype=float).reshape(-1)
    if ag.size < 2 or not np.all(np.isfinite(ag)):
        msg = 'response spectrum: the record needs at least 2 finite samples'
        raise PretestError(msg)
    if not (t.size and np.all(np.isfinite(t)) and np.all(t > 0.0)):
        msg = 'response spectrum: periods must be positive and finite'
        raise PretestError(msg)
    if not (math.isfinite(dt) and dt > 0.0):
        msg = f'response spectrum: dt must be positive, got {dt!r}'
        raise PretestError(msg)
    if not 0.0 <= damping < 1.0:
        msg = f'response spectrum: damping must be in [0, 1), got {damping!r}'
        raise PretestError(msg)
    omega = 2.0 * math.pi / t
    a_mat, b_mat = nigam_jennings_coefficients(omega, damping, dt)
    a11, a12 = a_mat[:, 0, 0].copy(), a_mat[:, 0, 1].copy()
    a21, a22 = a_mat[:, 1, 0].copy(), a_mat[:, 1, 1].copy()
    b11, b12 = b_mat[:, 0, 0].copy(), b_mat[:, 0, 1].copy()
    b21, b22 = b_mat[:, 1, 0].copy(), b_mat[:, 1, 1].copy()
    f = (-ag).tolist()
    n = t.size
    x = np.zeros(n)
    v = np.zeros(n)
    xn = np.empty(n)
    tmp = np.empty(n)
    peak = np.zeros(n)
    for f0, f1 in zip(f[:-1], f[1:]):
        # x' = A11 x + A12 v + B11 f0 + B12 f1;  v' = A21 x + A22 v + B21 f0 + B22 f1
        np.multiply(a11, x, out=xn)
        np.multiply(a12, v, out=tmp)
        xn += tmp
        np.multiply(b11, f0, out=tmp)
        xn += tmp
        np.multiply(b12, f1, out=tmp)
        xn += tmp
        x *= a21
        np.multiply(a22, v, out=tmp)
        x += tmp
        np.multiply(b21, f0, out=tmp)
        x += tmp
        np.multiply(b22, f1, out=tmp)
        np.add(x, tmp, out=v)
        x, xn = xn, x
        np.abs(x, out=tmp)
        np.maximum(peak, tmp, out=peak)
    return Spectrum(periods=t, damping=float(damping), displacement=peak,
                    pseudo_acceleration=omega * omega * peak)
