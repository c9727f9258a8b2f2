"""Event-driven exact response of an elastic-perfectly-plastic SDOF.

On each branch (elastic or plastic) the equation of motion is linear with a linear load and is
integrated in closed form; the yield and unloading events are located by root finding on the
closed form (the elastoplastic system of Chopra ch. 7, integrated branch by branch without
time-stepping error). The load is piecewise linear between samples ``t_i = i·Δt``, as for
:func:`~.nigam_jennings.nigam_jennings`, whose exact transition the elastic branch uses.

Units are SI; numpy/scipy only.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
import scipy.optimize

from ..errors import ConfigError, IntegratorError
from .checks import finite, non_negative, positive, sample_history
from .nigam_jennings import SERIES_STOP, SERIES_TERMS, transition_scalar

__all__ = [
    'EPPResponse',
    'epp_exact',
]

# |z| below which φ_k(z) is summed as a power series (plastic branch).
_PHI_SERIES_Z = 1.0
# Largest angle ω_d·h (rad) of one scan sub-interval of the elastic branch; < π is required
# so that the acceleration (a damped sinusoid) has at most one zero in a sub-interval.
_SCAN_ANGLE = 1.0
# Events allowed within one load segment before the solution is declared chattering.
_MAX_EVENTS_PER_SEGMENT = 1000


class EPPResponse(NamedTuple):
    """Response of :func:`epp_exact` at the sample times (all arrays ``(n_samples,)``).

    Attributes:
        x: Displacement in m.
        v: Velocity in m/s.
        a: Acceleration in m/s².
        r: Restoring force in N, ``k (x − x_p)`` clipped to ``±f_y``.
        plastic_displacement: Plastic offset ``x_p`` in m.
        hysteretic_energy: Energy dissipated by yielding since ``t = 0``, ``f_y Σ|Δx_p|``, in J.
        events: ``(time, kind)`` of each branch change, ``kind`` one of ``'yield+'``,
            ``'yield-'`` and ``'unload'``.
    """

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    r: np.ndarray
    plastic_displacement: np.ndarray
    hysteretic_energy: np.ndarray
    events: tuple[tuple[float, str], ...]


def _phi123(z: float) -> tuple[float, float, float]:
    """``φ₁, φ₂, φ₃`` of a scalar: ``φ_k(z) = Σ_j z^j/(j+k)!`` (``φ₁ = (e^z − 1)/z``, ...)."""
    if abs(z) < _PHI_SERIES_Z:
        p1 = p2 = p3 = 0.0
        term = 1.0  # z^j / j!
        for j in range(SERIES_TERMS):
            p1 += term / (j + 1)
            p2 += term / ((j + 1) * (j + 2))
            p3 += term / ((j + 1) * (j + 2) * (j + 3))
            term *= z / (j + 1)
            if abs(term) < SERIES_STOP:
                break
        return p1, p2, p3
    p1 = math.expm1(z) / z
    p2 = (p1 - 1.0) / z
    p3 = (p2 - 0.5) / z
    return p1, p2, p3


def _root(func: Any, lo: float, hi: float, scale: float) -> float:
    """First root of a function with ``func(lo) ≤ 0 < func(hi)`` (or the reverse)."""
    f_lo = func(lo)
    if f_lo == 0.0:
        return lo
    # scipy has no type information; brentq returns the root as a float.
    root: float = scipy.optimize.brentq(func, lo, hi, xtol=1e-15 * scale,
                                        rtol=4.0 * np.finfo(float).eps)
    return root


def epp_exact(
    mass: float,
    stiffness: float,
    yield_force: float,
    damping: float,
    dt: float,
    load: Any,
    x0: float = 0.0,
    v0: float = 0.0,
) -> EPPResponse:
    """Event-driven exact response of an elastic-perfectly-plastic SDOF.

    Solves ``m ẍ + c ẋ + r = p(t)`` with ``p`` linear between the samples ``load[i]`` at
    ``t_i = i·Δt`` and ``r`` elastic-perfectly-plastic: ``r = k (x − x_p)`` with
    ``|r| ≤ f_y``; ``x_p`` changes only while ``r = ±f_y`` and the velocity has the sign of
    ``r``. Within one load segment the motion follows one linear branch at a time, each solved
    in closed form from the state at the branch start (time ``σ`` from there, load
    ``p = p₀ + sσ``):

    * **elastic** (``u = x − x_p``): ``ü + 2ζωu̇ + ω²u = p/m`` with ``ω² = k/m``,
      ``ζ = c/(2mω)`` — the exact transition of :func:`nigam_jennings` over an arbitrary
      interval (Chopra §5.2, eq. 2.2.4 and §4.3–4.4).
    * **plastic** (``r = ±f_y``): ``m v̇ + c v = g(σ) = p₀ ∓ f_y + sσ``; with ``λ = c/m``
      (variation of constants, valid for ``c = 0`` too)::

          v(σ) = v₀ e^{−λσ} + (g₀/m) σ φ₁(−λσ) + (s/m) σ² φ₂(−λσ)
          x(σ) = x₀ + v₀ σ φ₁(−λσ) + (g₀/m) σ² φ₂(−λσ) + (s/m) σ³ φ₃(−λσ)

      where ``φ₁(z) = (e^z − 1)/z``, ``φ₂ = (e^z − 1 − z)/z²``, ``φ₃ = (e^z − 1 − z − z²/2)/z³``.

    Events (located with :func:`scipy.optimize.brentq` on the closed forms):

    * **yield**: on the elastic branch ``|u|`` reaches ``u_y = f_y/k`` while moving outward;
      the motion continues on the plastic branch of that sign.
    * **unload**: on the plastic branch the velocity changes sign; the motion continues on
      the elastic branch with the new plastic offset.

    Roots are isolated exactly rather than by a blind scan: on the elastic branch the
    acceleration is a damped sinusoid (its zeros are ``π/ω_D`` apart), so on scan
    sub-intervals shorter than ``1/ω_D`` it has at most one zero; splitting there makes the
    velocity monotone, splitting at the velocity's zeros makes ``u`` monotone, and a threshold
    crossing is then a sign change at the ends. On the plastic branch
    ``v = α + βσ + γe^{−λσ}``, so the acceleration ``β − λγe^{−λσ}`` is monotone and the
    velocity has at most one extremum per segment.

    Args:
        mass: ``m`` in kg, positive.
        stiffness: Elastic stiffness ``k`` in N/m, positive.
        yield_force: ``f_y`` in N, positive.
        damping: Viscous damping ``c`` in N·s/m, ``0 ≤ c < 2√(km)``.
        dt: Load sample spacing in s.
        load: ``p_i`` in N (``−m a_g`` for a ground motion), shape ``(n_samples,)``.
        x0: Initial displacement in m. If ``|k x0| > f_y`` the spring starts yielded with
            ``x_p = x0 ∓ u_y``.
        v0: Initial velocity in m/s.

    Returns:
        An :class:`EPPResponse` with the state at the sample times, the plastic offset, the
        cumulative hysteretic energy and the list of events.

    Raises:
        ConfigError: On invalid parameters (including an overdamped elastic branch).
        IntegratorError: If the branches chatter (more than 1000 events in one segment).
    """
    m = positive(mass, 'mass')
    k = positive(stiffness, 'stiffness')
    fy = positive(yield_force, 'yield_force')
    c = non_negative(damping, 'damping')
    h = positive(dt, 'dt')
    p = sample_history(load, 'load')
    x = finite(x0, 'x0')
    v = finite(v0, 'v0')
    omega = math.sqrt(k / m)
    zeta = c / (2.0 * m * omega)
    if zeta >= 1.0:
        msg = (
            f'damping: c = {c!r} gives ζ = {zeta:.4g} ≥ 1; the elastic branch must be '
            'underdamped'
        )
        raise ConfigError(msg)
    wd = omega * math.sqrt(1.0 - zeta * zeta)
    lam = c / m
    uy = fy / k
    # Most elastic segments start at a sample and span dt: cache those transitions.
    cache: dict[float, tuple[float, ...]] = {}

    def transition(sigma: float) -> tuple[float, ...]:
        found = cache.get(sigma)
        if found is None:
            found = transition_scalar(omega, zeta, sigma)
            if len(cache) < 16:
                cache[sigma] = found
        return found

    # Initial branch: 0 elastic, +1/-1 plastic in that direction.
    xp = 0.0
    branch = 0
    if abs(k * x) >= fy:
        sign = 1 if x > 0.0 else -1
        xp = x - sign * uy
        if sign * v > 0.0:
            branch = sign
    energy = 0.0
    events: list[tuple[float, str]] = []

    n_samples = p.size
    xs = np.empty(n_samples)
    vs = np.empty(n_samples)
    rs = np.empty(n_samples)
    xps = np.empty(n_samples)
    es = np.empty(n_samples)

    def restoring(x_now: float, xp_now: float, branch_now: int) -> float:
        if branch_now != 0:
            return branch_now * fy
        return min(fy, max(-fy, k * (x_now - xp_now)))

    xs[0], vs[0], xps[0], es[0] = x, v, xp, energy
    rs[0] = restoring(x, xp, branch)

    for i in range(n_samples - 1):
        slope = (p[i + 1] - p[i]) / h
        t_seg = i * h
        tau = 0.0  # local time within the segment
        n_events = 0
        while True:
            remaining = h - tau
            p0 = p[i] + slope * tau
            if branch == 0:
                sigma, u_end, v_end, kind = _elastic_branch(
                    transition, omega, zeta, wd, uy, x - xp, v, p0 / m, slope / m, remaining
                )
                x = xp + u_end
                v = v_end
                if kind is None:
                    break
                branch = 1 if kind == 'yield+' else -1
            else:
                sigma, x_end, v_end, kind = _plastic_branch(
                    lam, m, branch, fy, x, v, p0, slope, remaining
                )
                energy += fy * abs(x_end - x)
                x = x_end
                xp = x - branch * uy
                v = v_end
                if kind is None:
                    break
                branch = 0
            tau += sigma
            events.append((t_seg + tau, kind))
            n_events += 1
            if n_events > _MAX_EVENTS_PER_SEGMENT:
                msg = (
                    f'epp_exact: more than {_MAX_EVENTS_PER_SEGMENT} yield/unload events '
                    f'between t = {t_seg!r} s and {t_seg + h!r} s (chattering)'
                )
                raise IntegratorError(msg)
            if tau >= h:
                break
        xs[i + 1], vs[i + 1], xps[i + 1], es[i + 1] = x, v, xp, energy
        rs[i + 1] = restoring(x, xp, branch)

    acc = (p - c * vs - rs) / m
    return EPPResponse(xs, vs, acc, rs, xps, es, tuple(events))


def _elastic_branch(
    transition: Callable[[float], tuple[float, ...]],
    omega: float,
    zeta: float,
    wd: float,
    uy: float,
    u0: float,
    v0: float,
    f0: float,
    s: float,
    span: float,
) -> tuple[float, float, float, str | None]:
    """Follow the elastic branch for up to ``span`` s; stop at the first yield event.

    Returns ``(σ, u(σ), v(σ), kind)`` with ``kind`` ``None`` if no event occurred (``σ`` is
    then ``span``), else ``'yield+'`` / ``'yield-'`` (and ``u(σ) = ±u_y`` exactly).
    """
    two_zw = 2.0 * zeta * omega
    w2 = omega * omega

    def state(sigma: float) -> tuple[float, float, float]:
        a11, a12, a21, a22, p1x, p1v, p2x, p2v = transition(sigma)
        u = a11 * u0 + a12 * v0 + p1x * f0 + p2x * s
        v = a21 * u0 + a22 * v0 + p1v * f0 + p2v * s
        return u, v, f0 + s * sigma - two_zw * v - w2 * u

    n_sub = max(1, math.ceil(span * wd / _SCAN_ANGLE))
    left = 0.0
    u_l, v_l, a_l = u0, v0, f0 - two_zw * v0 - w2 * u0
    for j in range(1, n_sub + 1):
        right = span if j == n_sub else span * j / n_sub
        u_r, v_r, a_r = state(right)
        # Break [left, right] into pieces on which u is monotone.
        cuts = [(left, u_l, v_l)]
        if a_l * a_r < 0.0:
            ta = _root(lambda t: state(t)[2], left, right, span)
            ua, va, _ = state(ta)
            cuts.append((ta, ua, va))
        cuts.append((right, u_r, v_r))
        pieces = [cuts[0]]
        for (ta, _ua, va), (tb, ub, vb) in zip(cuts[:-1], cuts[1:]):
            if va * vb < 0.0:
                tv = _root(lambda t: state(t)[1], ta, tb, span)
                uv, vv, _ = state(tv)
                pieces.append((tv, uv, vv))
            pieces.append((tb, ub, vb))
        for (ta, ua, _va), (tb, ub, _vb) in zip(pieces[:-1], pieces[1:]):
            if ub > uy:
                te = _root(lambda t: state(t)[0] - uy, ta, tb, span) if ua < uy else ta
                _, ve, _ = state(te)
                return te, uy, ve, 'yield+'
            if ub < -uy:
                te = _root(lambda t: state(t)[0] + uy, ta, tb, span) if ua > -uy else ta
                _, ve, _ = state(te)
                return te, -uy, ve, 'yield-'
        left, u_l, v_l, a_l = right, u_r, v_r, a_r
    return span, u_l, v_l, None


def _plastic_branch(
    lam: float,
    m: float,
    sign: int,
    fy: float,
    x0: float,
    v0: float,
    p0: float,
    s: float,
    span: float,
) -> tuple[float, float, float, str | None]:
    """Follow the plastic branch of the given sign for up to ``span`` s; stop at unloading.

    Returns ``(σ, x(σ), v(σ), kind)`` with ``kind`` ``None`` (``σ = span``) or ``'unload'``
    (and ``v(σ) = 0`` exactly).
    """
    g0 = (p0 - sign * fy) / m
    sm = s / m

    def state(sigma: float) -> tuple[float, float, float]:
        z = -lam * sigma
        p1, p2, p3 = _phi123(z)
        v = v0 * math.exp(z) + g0 * sigma * p1 + sm * sigma * sigma * p2
        x = x0 + v0 * sigma * p1 + g0 * sigma * sigma * p2 + sm * sigma ** 3 * p3
        return x, v, g0 + sm * sigma - lam * v

    x_r, v_r, a_r = state(span)
    a_l = g0 - lam * v0
    cuts = [(0.0, v0)]
    if a_l * a_r < 0.0:
        ta = _root(lambda t: state(t)[2], 0.0, span, span)
        cuts.append((ta, state(ta)[1]))
    cuts.append((span, v_r))
    for (ta, va), (tb, vb) in zip(cuts[:-1], cuts[1:]):
        if sign * vb < 0.0:
            te = _root(lambda t: state(t)[1], ta, tb, span) if sign * va > 0.0 else ta
            return te, state(te)[0], 0.0, 'unload'
    return span, x_r, v_r, None
