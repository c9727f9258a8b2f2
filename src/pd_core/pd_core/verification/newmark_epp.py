"""Implicit Newmark response of an elastic-perfectly-plastic SDOF, solved by Newton's method.

The reference the iterations of the implicit pseudo-dynamic schemes converge to: every step of
Newmark's scheme (Newmark 1959; Chopra §5.7) is solved to a tolerance by Newton's
method with the *consistent* tangent of the spring (``k`` elastic, ``0`` yielding), the spring
evaluated by return mapping from its committed state, as a finite-element program does
(OpenSees ``Newmark 0.5 0.25`` with ``Newton`` and ``ElasticPP``). Unlike
:func:`~.epp.epp_exact` it has the scheme's time-stepping error, and none of the iteration error
of a fixed number of trials. It is written from the equations and shares no code with the
schemes (:mod:`..schemes`), so they can be checked against it.

Units are SI; numpy only.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from ..errors import IntegratorError
from .checks import finite, non_negative, positive, sample_history

__all__ = [
    'NewmarkEPPResponse',
    'newmark_epp',
]

#: Newton iterations allowed in one step before the step is declared not converging.
MAX_NEWTON_ITERATIONS = 100


class NewmarkEPPResponse(NamedTuple):
    """Response of :func:`newmark_epp` at the sample times (all arrays ``(n_samples,)``).

    Attributes:
        x: Displacement in m.
        v: Velocity in m/s.
        a: Acceleration in m/s².
        r: Restoring force in N, ``k (x − x_p)`` clipped to ``±f_y``.
        plastic_displacement: Plastic offset ``x_p`` in m.
        newton_iterations: Newton iterations of each step (0 at ``t = 0``).
    """

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    r: np.ndarray
    plastic_displacement: np.ndarray
    newton_iterations: np.ndarray


def _spring(x: float, xp: float, k: float, fy: float) -> tuple[float, float, float]:
    """Return mapping from the committed offset ``xp``: ``(r, tangent, trial offset)``."""
    f = k * (x - xp)
    if f > fy:
        return fy, 0.0, x - fy / k
    if f < -fy:
        return -fy, 0.0, x + fy / k
    return f, k, xp


def newmark_epp(
    mass: float,
    stiffness: float,
    yield_force: float,
    damping: float,
    dt: float,
    load: Any,
    x0: float = 0.0,
    v0: float = 0.0,
    *,
    beta: float = 0.25,
    gamma: float = 0.5,
    tolerance: float = 1e-14,
) -> NewmarkEPPResponse:
    """Implicit Newmark response of an EPP SDOF, each step solved by Newton's method.

    Solves ``m a_{n+1} + c v_{n+1} + r(x_{n+1}) = p_{n+1}`` with Newmark's relations::

        x_{n+1} = x̃ + β Δt² a_{n+1},   x̃ = x_n + Δt v_n + (1/2 − β) Δt² a_n
        v_{n+1} = ṽ + γ Δt a_{n+1},    ṽ = v_n + (1 − γ) Δt a_n

    i.e. ``R(y) = p_{n+1} − m (y − x̃)/(βΔt²) − c [ṽ + γ (y − x̃)/(βΔt)] − r(y) = 0``, where
    ``r(y)`` is the elastic-perfectly-plastic force at ``y`` from the step's committed plastic
    offset ``x_p`` (return mapping: ``k (y − x_p)`` clipped to ``±f_y``). Newton's iterations
    start at ``y = x_n`` and use the consistent tangent
    ``K̂_t = m/(βΔt²) + γ c/(βΔt) + k_t`` (``k_t = k`` elastic, ``0`` yielding); a step ends
    when the displacement increment is at most ``tolerance`` (or 4 ulp of ``y``), and the
    spring's state at the solution is committed. ``R`` is piecewise linear and strictly
    decreasing (``K̂_t ≥ m/(βΔt²) > 0``), so the root is unique and bracketed: a Newton
    iterate outside the bracket of the iterates so far is replaced by the bracket's midpoint
    (a safeguard; with a mass term this large it is not needed in practice).

    Args:
        mass: ``m`` in kg, positive.
        stiffness: Elastic stiffness ``k`` in N/m, positive.
        yield_force: ``f_y`` in N, positive.
        damping: Viscous damping ``c`` in N·s/m, non-negative.
        dt: Time step ``Δt`` in s (the load's sample spacing), positive.
        load: ``p_i`` in N at ``t_i = i·Δt`` (``−m a_g`` for a ground motion), shape
            ``(n_samples,)``.
        x0: Initial displacement in m. If ``|k x0| > f_y`` the spring starts yielded with
            ``x_p = x0 ∓ f_y/k``.
        v0: Initial velocity in m/s.
        beta: Newmark ``β`` (1/4: average acceleration, 1/6: linear acceleration), positive.
        gamma: Newmark ``γ``, non-negative.
        tolerance: Largest displacement increment (m) of a converged step, positive.

    Returns:
        A :class:`NewmarkEPPResponse` with the state at the sample times.

    Raises:
        ConfigError: On an invalid argument.
        IntegratorError: If a step does not converge in ``MAX_NEWTON_ITERATIONS`` iterations.
    """
    m = positive(mass, 'mass')
    k = positive(stiffness, 'stiffness')
    fy = positive(yield_force, 'yield_force')
    c = non_negative(damping, 'damping')
    h = positive(dt, 'dt')
    p = sample_history(load, 'load')
    b = positive(beta, 'beta')
    g = non_negative(gamma, 'gamma')
    tol = positive(tolerance, 'tolerance')
    x = finite(x0, 'x0')
    v = finite(v0, 'v0')

    c_acc = 1.0 / (b * h * h)  # a_{n+1} = c_acc (y − x̃)
    c_vel = g / (b * h)  # v_{n+1} = ṽ + c_vel (y − x̃)
    k_dynamic = c_acc * m + c_vel * c  # the inertial and viscous part of K̂_t

    xp = 0.0
    if abs(k * x) > fy:
        xp = x - math.copysign(fy / k, x)
    r, _, _ = _spring(x, xp, k, fy)
    a = (p[0] - c * v - r) / m

    n_samples = p.size
    xs = np.empty(n_samples)
    vs = np.empty(n_samples)
    accs = np.empty(n_samples)
    rs = np.empty(n_samples)
    xps = np.empty(n_samples)
    counts = np.zeros(n_samples, dtype=int)
    xs[0], vs[0], accs[0], rs[0], xps[0] = x, v, a, r, xp

    for i in range(1, n_samples):
        x_pred = x + h * v + (0.5 - b) * h * h * a
        v_pred = v + (1.0 - g) * h * a
        y = x
        low, high = -math.inf, math.inf  # R(low) > 0 > R(high): the root is in between
        count = 0
        while True:
            count += 1
            if count > MAX_NEWTON_ITERATIONS:
                msg = (f'newmark_epp: step {i} (t = {i * h!r} s) did not converge in '
                       f'{MAX_NEWTON_ITERATIONS} Newton iterations')
                raise IntegratorError(msg)
            force, tangent, _ = _spring(y, xp, k, fy)
            offset = y - x_pred
            residual = p[i] - m * c_acc * offset - c * (v_pred + c_vel * offset) - force
            if residual > 0.0:
                low = y
            elif residual < 0.0:
                high = y
            else:
                break
            step = residual / (k_dynamic + tangent)
            if abs(step) <= max(tol, 4.0 * math.ulp(y)):
                y += step
                break
            y += step
            if not low < y < high and math.isfinite(low) and math.isfinite(high):
                y = 0.5 * (low + high)
        r, _, xp = _spring(y, xp, k, fy)
        a = c_acc * (y - x_pred)
        v = v_pred + g * h * a
        x = y
        xs[i], vs[i], accs[i], rs[i], xps[i] = x, v, a, r, xp
        counts[i] = count
    return NewmarkEPPResponse(xs, vs, accs, rs, xps, counts)
