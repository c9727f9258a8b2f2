"""Bouc–Wen hysteresis with energy-driven strength and stiffness degradation (Baber–Wen/Noori).

The time discretisation is that of OpenSees's ``BoucWen`` uniaxial material
(``SRC/material/uniaxial/BoucWenMaterial.cpp``, T. Haukaas), so that a displacement history
applied here and to ``uniaxialMaterial BoucWen`` gives the same forces (to rounding).
"""

from __future__ import annotations

import math
import operator

from ..errors import HysteresisError
from .hysteresis import HysteresisModel, State, _positive

#: Newton start value of ``z`` in every step (OpenSees's ``startPoint``, in m here).
NEWTON_START = 0.01
#: OpenSees's defaults of the optional ``tol`` and ``maxNumIter`` arguments.
DEFAULT_TOLERANCE = 1.0e-8
DEFAULT_MAX_ITERATIONS = 20

_WHERE = 'BoucWen'


def _finite(value: float, name: str) -> float:
    """Return ``value`` as a float, raising HysteresisError unless finite."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not math.isfinite(number):
        msg = f'{_WHERE}: {name} must be a finite number, got {value!r}'
        raise HysteresisError(msg)
    return number


def _nonnegative(value: float, name: str) -> float:
    """Return ``value`` as a float, raising HysteresisError unless finite and ``>= 0``."""
    number = _finite(value, name)
    if number < 0.0:
        msg = f'{_WHERE}: {name} must be >= 0, got {value!r}'
        raise HysteresisError(msg)
    return number


def _signum(value: float) -> float:
    """OpenSees's ``BoucWenMaterial::signum``: ``+1`` if positive, else ``-1`` (also at 0)."""
    return 1.0 if value > 0.0 else -1.0


class BoucWen(HysteresisModel):
    """Bouc–Wen spring with Baber–Wen degradation, discretised exactly as OpenSees's ``BoucWen``.

    Force and hysteretic displacement ``z`` (in m, like ``x``)::

        f = α k x + (1 − α) k z
        dz/dx = [A − ν |z|^n (γ + β sgn(ẋ z))] / η
        A = A0 − δA e,   ν = 1 + δν e,   η = 1 + δη e,   e = ∫ (1 − α) k z dx

    (Bouc 1967; Wen 1976, J. Eng. Mech. Div. ASCE 102(2):249–263; degradation after Baber &
    Wen 1981, J. Eng. Mech. Div. 107(6):1069–1087, and Baber & Noori 1985, J. Eng. Mech.
    111(8):1010–1026: a falling ``A`` lowers the hysteretic stiffness and strength, a growing
    ``ν`` the strength (``z_u ∝ ν^(−1/n)``), a growing ``η`` the stiffness only.)
    On loading (``ẋ z > 0``) the slope factor is ``γ + β``, on unloading ``γ − β``; under
    monotonic loading without degradation ``z → z_u = (A0/(β+γ))^(1/n)`` and
    ``f → α k x + (1 − α) k z_u``. The initial stiffness is ``α k + (1 − α) k A0``; ``e`` is
    the hysteretic work in J, so ``δA``, ``δν``, ``δη`` are per joule. ``e`` is the running
    work integral of Baber & Wen, not a dissipated energy that only grows: it decreases while
    unloading (``ẋ z < 0``) and gains the loop's dissipated energy per closed cycle.

    Step ``x_c → x`` (``Δx = x − x_c``, committed ``z_c``, ``e_c``), as
    ``BoucWenMaterial::setTrialStrain``: backward Euler with the energy at the end of the step,
    ``e = e_c + (1 − α) k Δx z`` (a right-endpoint rectangle rule, not a trapezoid), and
    ``A``, ``ν``, ``η``, ``sgn(Δx z)`` all taken at the new ``z``, solved for ``z`` by
    Newton–Raphson on::

        R(z) = z − z_c − Φ(z) Δx / η(z),   Φ = A − |z|^n (γ + β sgn(Δx z)) ν

    with ``R'`` differentiating ``A``, ``ν``, ``η`` through ``e`` but not ``sgn``. Matched on
    purpose:

    * every step starts Newton from ``z = 0.01`` (OpenSees's ``startPoint``; here in m),
      not from ``z_c``, and stops when a Newton correction ``|Δz| <= tolerance`` (absolute,
      in m) or after ``max_iterations`` corrections; the result is the last iterate (so ``z``,
      ``e`` and the force are those of the last correction);
    * ``sgn(0) = −1`` (OpenSees's ``signum``): a zero step ``Δx = 0`` gives ``z = z_c`` and
      the *unloading* factor ``γ − β`` in the tangent; in ``R'`` the ``|z|^(n−1)`` term is
      dropped at ``z = 0`` exactly;
    * the tangent (:attr:`tangent`, OpenSees's ``getTangent``) is the consistent one,
      ``α k + (1 − α) k dz/dx`` with ``dz/dx`` from the implicit function theorem on ``R``
      (including the energy's dependence on ``x`` and ``z``), but ``k`` at ``z = 0`` exactly;
      the virgin tangent is the initial stiffness.

    Deliberate differences: OpenSees only prints warnings if ``R' = 0`` or Newton has not
    converged after ``maxNumIter`` iterations (and warns even when the last of them did
    converge); this model raises :class:`HysteresisError` (trial state unchanged) if ``R'``
    is zero, a value is not finite, or the last correction is still larger than
    ``tolerance``. OpenSees's ``revertToLastCommit`` keeps the trial stress; here it is
    reverted (base-class semantics). Because Newton always starts at ``z = 0.01`` m, large
    ``n`` (say ``n >= 10``) with steps of several ``z_u``, or a ``z_u`` much smaller than
    0.01 m (e.g. 1e-4 m with ``n = 5``), may need more ``max_iterations`` (or smaller
    steps); keep the absolute ``tolerance`` well below ``z_u`` (OpenSees has the same start
    value, in its own units).

    Parameter ranges. OpenSees checks none; here: ``k > 0``; ``α < 1`` finite (negative gives a
    softening post-yield branch; ``α = 1`` would be a linear spring); ``n > 0`` (usually
    ``n >= 1``; ``n → ∞`` tends to bilinear); ``β >= 0`` and ``β + γ > 0``, which is exactly
    the bounded (BIBO-stable) set of Ikhouane, Mañosa & Rodellar 2007 (Syst. Control Lett.
    56(3):197–205) for ``A > 0`` (``β < 0`` lets ``z`` grow without bound on unloading);
    ``β`` and ``γ`` are in ``m^−n``; ``A0 > 0``; ``δA, δν, δη >= 0`` (``A`` may become
    negative after enough energy, as in OpenSees); ``0 < tolerance < 0.99`` m (OpenSees skips
    the iteration entirely if ``tolerance >= |0.01 − 1|``); ``max_iterations >= 1``.

    Internal state: ``(z, e, tangent)``.

    Args:
        stiffness: ``k`` in N/m, positive (OpenSees ``ko``).
        post_yield_ratio: ``α``, finite and ``< 1`` (OpenSees ``alpha``).
        exponent: ``n``, positive (OpenSees ``n``).
        beta: ``β`` in m^−n, ``>= 0`` (OpenSees ``beta``).
        gamma: ``γ`` in m^−n, finite with ``β + γ > 0`` (OpenSees ``gamma``).
        a0: ``A0``, positive (OpenSees ``Ao``).
        delta_a: ``δA`` in 1/J, ``>= 0`` (OpenSees ``deltaA``).
        delta_nu: ``δν`` in 1/J, ``>= 0`` (OpenSees ``deltaNu``).
        delta_eta: ``δη`` in 1/J, ``>= 0`` (OpenSees ``deltaEta``).
        tolerance: Newton tolerance on the correction of ``z`` in m (OpenSees ``tol``).
        max_iterations: Maximum Newton corrections per step (OpenSees ``maxNumIter``).

    Raises:
        HysteresisError: If a parameter is out of range (the message names it).
    """

    def __init__(self, stiffness: float, post_yield_ratio: float, exponent: float,
                 beta: float, gamma: float, a0: float = 1.0, delta_a: float = 0.0,
                 delta_nu: float = 0.0, delta_eta: float = 0.0,
                 tolerance: float = DEFAULT_TOLERANCE,
                 max_iterations: int = DEFAULT_MAX_ITERATIONS) -> None:
        self._k = _positive(stiffness, 'stiffness', _WHERE)
        self._alpha = _finite(post_yield_ratio, 'post_yield_ratio')
        if not self._alpha < 1.0:
            msg = f'{_WHERE}: post_yield_ratio must be < 1, got {post_yield_ratio!r}'
            raise HysteresisError(msg)
        self._n = _positive(exponent, 'exponent', _WHERE)
        self._beta = _nonnegative(beta, 'beta')
        self._gamma = _finite(gamma, 'gamma')
        if not self._beta + self._gamma > 0.0:
            msg = f'{_WHERE}: beta + gamma must be > 0 (z bounded), got {beta!r} + {gamma!r}'
            raise HysteresisError(msg)
        self._a0 = _positive(a0, 'a0', _WHERE)
        self._delta_a = _nonnegative(delta_a, 'delta_a')
        self._delta_nu = _nonnegative(delta_nu, 'delta_nu')
        self._delta_eta = _nonnegative(delta_eta, 'delta_eta')
        self._tol = _positive(tolerance, 'tolerance', _WHERE)
        if not self._tol < abs(NEWTON_START - 1.0):
            msg = f'{_WHERE}: tolerance must be < 0.99 m, got {tolerance!r}'
            raise HysteresisError(msg)
        if isinstance(max_iterations, bool):
            iterations = 0
        else:
            try:
                iterations = operator.index(max_iterations)
            except TypeError:
                iterations = 0
        if iterations < 1:
            msg = f'{_WHERE}: max_iterations must be an integer >= 1, got {max_iterations!r}'
            raise HysteresisError(msg)
        self._max_it = iterations
        super().__init__()

    def _initial_state(self) -> State:
        return (0.0, 0.0, self.initial_stiffness)

    def _evaluate(self, x: float) -> tuple[float, State]:
        e_c = self._s_c[1]
        alpha, k = self._alpha, self._k
        dx = x - self._x_c
        try:
            z, last_correction = self._solve_z(dx)
            e = e_c + (1.0 - alpha) * k * dx * z
            tangent = self._tangent(z, e, dx)
        except (ZeroDivisionError, OverflowError) as exc:
            msg = (f'{_WHERE}: {exc} in the step to x = {x:g} m from {self._x_c:g} m (zero '
                   'Newton derivative, zero eta or overflow)')
            raise HysteresisError(msg) from None
        if not math.isfinite(z):
            msg = f'{_WHERE}: the Newton iteration for z diverged at x = {x:g} m'
            raise HysteresisError(msg)
        if last_correction > self._tol:
            msg = (f'{_WHERE}: the Newton iteration for z did not converge in '
                   f'{self._max_it} iterations at x = {x:g} m (last correction '
                   f'{last_correction:.3g} m)')
            raise HysteresisError(msg)
        force = alpha * k * x + (1.0 - alpha) * k * z
        if not (math.isfinite(force) and math.isfinite(e) and math.isfinite(tangent)):
            msg = f'{_WHERE}: non-finite force, energy or tangent at x = {x:g} m'
            raise HysteresisError(msg)
        return force, (z, e, tangent)

    def _solve_z(self, dx: float) -> tuple[float, float]:
        """Newton on ``R(z)`` as OpenSees: return the last iterate and the last correction."""
        z_c, e_c = self._s_c[0], self._s_c[1]
        n, beta, gamma, a0 = self._n, self._beta, self._gamma, self._a0
        d_a, d_nu, d_eta = self._delta_a, self._delta_nu, self._delta_eta
        de_dz = (1.0 - self._alpha) * self._k * dx  # e = e_c + de_dz z
        z = z_old = NEWTON_START
        z_new = 1.0
        count = 0
        while abs(z_old - z_new) > self._tol and count < self._max_it:
            e = e_c + de_dz * z
            a = a0 - d_a * e
            nu = 1.0 + d_nu * e
            eta = 1.0 + d_eta * e
            psi = gamma + beta * _signum(dx * z)
            phi = a - math.pow(abs(z), n) * psi * nu
            residual = z - z_c - phi / eta * dx
            if z == 0.0:
                pow1 = pow2 = 0.0
            else:
                pow1 = math.pow(abs(z), n - 1.0)
                pow2 = math.pow(abs(z), n)
            dphi = (-d_a * de_dz - n * pow1 * _signum(z) * psi * nu
                    - pow2 * psi * (d_nu * de_dz))
            slope = 1.0 - (dphi * eta - phi * (d_eta * de_dz)) / eta ** 2.0 * dx
            z_new = z - residual / slope
            z_old = z
            z = z_new
            count += 1
        return z, abs(z_old - z_new)

    def _tangent(self, z: float, e: float, dx: float) -> float:
        """Consistent tangent ``df/dx`` at the converged ``z`` (OpenSees's ``Ttangent``)."""
        alpha, k, n = self._alpha, self._k, self._n
        if z == 0.0:
            return alpha * k + (1.0 - alpha) * k
        d_a, d_nu, d_eta = self._delta_a, self._delta_nu, self._delta_eta
        a = self._a0 - d_a * e
        nu = 1.0 + d_nu * e
        eta = 1.0 + d_eta * e
        psi = self._gamma + self._beta * _signum(dx * z)
        z_n = math.pow(abs(z), n)
        phi = a - z_n * psi * nu
        de_dx = (1.0 - alpha) * k * z   # ∂e/∂x at fixed z
        de_dz = (1.0 - alpha) * k * dx  # ∂e/∂z at fixed x
        c = dx / eta
        phi_eta2 = phi / (eta * eta) * dx * d_eta
        # −∂R/∂x and ∂R/∂z:
        numerator = -c * d_a * de_dx - c * z_n * psi * d_nu * de_dx - phi_eta2 * de_dx + phi / eta
        z_n1 = math.pow(abs(z), n - 1.0)
        denominator = (1.0 + c * d_a * de_dz + c * n * z_n1 * _signum(z) * psi * nu
                       + c * z_n * psi * d_nu * de_dz + phi_eta2 * de_dz)
        return alpha * k + (1.0 - alpha) * k * (numerator / denominator)

    @property
    def initial_stiffness(self) -> float:
        """``α k + (1 − α) k A0`` in N/m (OpenSees's ``getInitialTangent``)."""
        return self._alpha * self._k + (1.0 - self._alpha) * self._k * self._a0

    @property
    def tangent(self) -> float:
        """Trial tangent ``df/dx`` in N/m (OpenSees's ``getTangent``)."""
        return float(self._s_t[2])

    @property
    def hysteretic_energy(self) -> float:
        """Committed hysteretic work ``e`` in J (drives the degradation)."""
        return float(self._s_c[1])

    @property
    def hysteretic_displacement(self) -> float:
        """Committed hysteretic displacement ``z`` in m."""
        return float(self._s_c[0])

    @property
    def ultimate_hysteretic_displacement(self) -> float:
        """Virgin bound ``z_u = (A0/(β+γ))^(1/n)`` in m (before any degradation)."""
        return float((self._a0 / (self._beta + self._gamma)) ** (1.0 / self._n))

    @property
    def stiffness(self) -> float:
        """``k`` in N/m."""
        return self._k

    @property
    def post_yield_ratio(self) -> float:
        """``α``."""
        return self._alpha

    @property
    def exponent(self) -> float:
        """``n``."""
        return self._n

    @property
    def beta(self) -> float:
        """``β`` in m^−n."""
        return self._beta

    @property
    def gamma(self) -> float:
        """``γ`` in m^−n."""
        return self._gamma

    @property
    def a0(self) -> float:
        """``A0``."""
        return self._a0

    @property
    def delta_a(self) -> float:
        """``δA`` in 1/J."""
        return self._delta_a

    @property
    def delta_nu(self) -> float:
        """``δν`` in 1/J."""
        return self._delta_nu

    @property
    def delta_eta(self) -> float:
        """``δη`` in 1/J."""
        return self._delta_eta

    @property
    def tolerance(self) -> float:
        """Newton tolerance on the correction of ``z`` in m."""
        return self._tol

    @property
    def max_iterations(self) -> int:
        """Maximum Newton corrections per step."""
        return self._max_it
