"""Uniaxial hysteresis models driven by displacement (OpenSees-style trial/commit/revert).

Every model keeps a committed state and a trial state. :meth:`HysteresisModel.
set_trial_displacement` always starts from the committed state, so it may be called any number
of times before :meth:`HysteresisModel.commit`; :meth:`HysteresisModel.revert_to_last_commit`
discards the trial. The internal state is an immutable tuple, so models are cheap to copy and
safe to ``copy.deepcopy``.
"""

from __future__ import annotations

import copy
import math
from abc import ABC, abstractmethod
from typing import Any

from ..errors import HysteresisError
from .backbone import BEYOND_MODES, Backbone, residual_strength

State = tuple[Any, ...]


def _positive(value: float, name: str, where: str) -> float:
    """Return ``value`` as a float, raising HysteresisError unless positive and finite."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not (math.isfinite(number) and number > 0.0):
        msg = f'{where}: {name} must be a positive finite number, got {value!r}'
        raise HysteresisError(msg)
    return number


def _ratio(value: float, where: str) -> float:
    """Return a hardening ratio in (-1, 1) as a float, else raise HysteresisError."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not -1.0 < number < 1.0:
        msg = f'{where}: hardening_ratio must be in (-1, 1), got {value!r}'
        raise HysteresisError(msg)
    return number


class HysteresisModel(ABC):
    """Uniaxial force-displacement model with committed and trial states.

    Subclasses implement :meth:`_initial_state` and :meth:`_evaluate`; the base class keeps
    displacement, force and the model's internal state tuple for both states.
    """

    def __init__(self) -> None:
        self._x_c = 0.0
        self._f_c = 0.0
        self._s_c: State = self._initial_state()
        self._x_t = 0.0
        self._f_t = 0.0
        self._s_t: State = self._s_c

    @abstractmethod
    def _initial_state(self) -> State:
        """Return the internal state of the virgin model (at zero displacement and force)."""

    @abstractmethod
    def _evaluate(self, x: float) -> tuple[float, State]:
        """Return the force at trial displacement ``x`` and the trial internal state.

        Must depend only on the committed state (``_x_c``, ``_f_c``, ``_s_c``) and ``x``.
        """

    @property
    @abstractmethod
    def initial_stiffness(self) -> float:
        """Initial (elastic) stiffness in N/m."""

    def set_trial_displacement(self, x: float) -> float:
        """Compute the trial state at displacement ``x`` (m) from the committed state.

        Args:
            x: Trial displacement in m.

        Returns:
            The trial force in N.

        Raises:
            HysteresisError: If ``x`` is not a finite number or the model cannot evaluate it
                (e.g. beyond the last backbone point with ``beyond='error'``); the trial state
                is then left unchanged.
        """
        try:
            x = float(x)
        except (TypeError, ValueError):
            x = math.nan
        if not math.isfinite(x):
            msg = f'{type(self).__name__}: trial displacement must be a finite number, got {x}'
            raise HysteresisError(msg)
        f, state = self._evaluate(x)
        self._x_t = x
        self._f_t = f
        self._s_t = state
        return f

    def commit(self) -> None:
        """Make the trial state the committed state."""
        self._x_c = self._x_t
        self._f_c = self._f_t
        self._s_c = self._s_t

    def revert_to_last_commit(self) -> None:
        """Discard the trial state (the trial becomes the committed state again)."""
        self._x_t = self._x_c
        self._f_t = self._f_c
        self._s_t = self._s_c

    def reset(self) -> None:
        """Return to the virgin state (zero displacement and force, no history)."""
        self._x_c = self._x_t = 0.0
        self._f_c = self._f_t = 0.0
        self._s_c = self._s_t = self._initial_state()

    def copy(self) -> HysteresisModel:
        """Return an independent copy with the same committed and trial states."""
        return copy.deepcopy(self)

    @property
    def trial_displacement(self) -> float:
        """Trial displacement in m."""
        return self._x_t

    @property
    def trial_force(self) -> float:
        """Trial force in N."""
        return self._f_t

    @property
    def committed_displacement(self) -> float:
        """Committed displacement in m."""
        return self._x_c

    @property
    def committed_force(self) -> float:
        """Committed force in N."""
        return self._f_c


class Elastic(HysteresisModel):
    """Linear elastic spring ``f = k x``.

    Args:
        stiffness: ``k`` in N/m, positive.
    """

    def __init__(self, stiffness: float) -> None:
        self._k = _positive(stiffness, 'stiffness', 'Elastic')
        super().__init__()

    def _initial_state(self) -> State:
        return ()

    def _evaluate(self, x: float) -> tuple[float, State]:
        return self._k * x, ()

    @property
    def initial_stiffness(self) -> float:
        """Stiffness in N/m."""
        return self._k


class ElasticPerfectlyPlastic(HysteresisModel):
    """Elastic-perfectly-plastic spring (return mapping on the plastic displacement).

    ``f = k (x - x_p)`` with ``|f| <= F_y``; if the elastic trial exceeds ``F_y`` the force is
    set to ``±F_y`` and ``x_p`` absorbs the excess. Internal state: ``(x_p,)``.

    Args:
        stiffness: ``k`` in N/m, positive.
        yield_force: ``F_y`` in N, positive.
    """

    def __init__(self, stiffness: float, yield_force: float) -> None:
        self._k = _positive(stiffness, 'stiffness', 'ElasticPerfectlyPlastic')
        self._fy = _positive(yield_force, 'yield_force', 'ElasticPerfectlyPlastic')
        super().__init__()

    def _initial_state(self) -> State:
        return (0.0,)

    def _evaluate(self, x: float) -> tuple[float, State]:
        xp = self._s_c[0]
        f = self._k * (x - xp)
        if f > self._fy:
            return self._fy, (x - self._fy / self._k,)
        if f < -self._fy:
            return -self._fy, (x + self._fy / self._k,)
        return f, (xp,)

    @property
    def initial_stiffness(self) -> float:
        """Elastic stiffness in N/m."""
        return self._k

    @property
    def yield_force(self) -> float:
        """Yield force in N."""
        return self._fy


class BilinearKinematic(HysteresisModel):
    """Bilinear spring with linear kinematic hardening or softening (exact return mapping).

    Plastic displacement ``x_p`` and back force ``alpha = H x_p`` with ``H = b k / (1 - b)``,
    so the post-yield tangent is ``k H / (k + H) = b k``. The yield surface
    ``|f - alpha| <= F_y`` translates, giving an elastic range of ``2 F_y`` on reversal
    (Bauschinger effect: reverse yield at ``f_max - 2 F_y``); unloading is at ``k``. With a
    trial ``xi = k (x - x_p) - alpha`` beyond ``F_y`` the plastic increment is
    ``(|xi| - F_y) / (k + H)``, exact for this linear model (``k + H = k / (1 - b) > 0`` for
    every ``b < 1``). Internal state: ``(x_p, alpha)``.

    Equivalently the force is bounded by two lines of slope ``b k`` in the total
    displacement, ``F_y + b k (x - d_y)`` above and ``-F_y + b k (x + d_y)`` below
    (``d_y = F_y / k``); this is OpenSees's ``Steel01`` without isotropic hardening.

    **Softening** (``-1 < b < 0``): the post-yield slope is negative, e.g. a column whose
    pushover with P-Δ descends after yield. The bounding lines descend with the displacement,
    so on a positive excursion the strength falls while the reverse strength grows by the
    same amount, as a P-Δ moment shifts the whole curve. ``residual_force`` ``F_r`` (in
    ``[0, F_y]``, softening only) is a strength floor: each bounding line stops at ``±F_r``
    (``|f| >= F_r`` while yielding), so the backbone is trilinear ``(0, 0)``, ``(d_y, F_y)``,
    ``(d_y + (F_y - F_r)/(-b k), F_r)``, then flat. Without a floor the strength crosses
    zero at ``d_y + F_y / (-b k)`` and becomes negative (collapse).

    Args:
        stiffness: Initial stiffness ``k`` in N/m, positive.
        yield_force: Yield force ``F_y`` in N, positive.
        hardening_ratio: Post-yield to initial stiffness ratio ``b``, ``-1 < b < 1``.
        residual_force: Strength floor ``F_r`` in N, ``0 <= F_r <= F_y``; only with
            ``b < 0``. ``None``: no floor.
    """

    def __init__(self, stiffness: float, yield_force: float, hardening_ratio: float,
                 residual_force: float | None = None) -> None:
        self._k = _positive(stiffness, 'stiffness', 'BilinearKinematic')
        self._fy = _positive(yield_force, 'yield_force', 'BilinearKinematic')
        self._b = _ratio(hardening_ratio, 'BilinearKinematic')
        self._h = self._b * self._k / (1.0 - self._b)
        self._fr = None if residual_force is None else residual_strength(
            residual_force, self._fy, self._b, 'BilinearKinematic', HysteresisError)
        super().__init__()

    def _initial_state(self) -> State:
        return (0.0, 0.0)

    def _evaluate(self, x: float) -> tuple[float, State]:
        xp, alpha = self._s_c
        k = self._k
        f = k * (x - xp)
        xi = f - alpha
        excess = abs(xi) - self._fy
        if excess <= 0.0:
            return f, self._s_c
        dgamma = math.copysign(excess / (k + self._h), xi)
        f_yield = f - k * dgamma
        floor = self._fr
        sign = math.copysign(1.0, xi)
        if floor is not None and sign * f_yield < floor:
            # The bounding line is below the strength floor: yield at ±F_r if beyond it.
            if sign * f <= floor:
                return f, self._s_c
            f_yield = sign * floor
            xp_new = x - f_yield / k
            return f_yield, (xp_new, self._h * xp_new)
        return f_yield, (xp + dgamma, alpha + self._h * dgamma)

    @property
    def initial_stiffness(self) -> float:
        """Elastic stiffness in N/m."""
        return self._k

    @property
    def yield_force(self) -> float:
        """Yield force in N."""
        return self._fy

    @property
    def hardening_ratio(self) -> float:
        """Post-yield to initial stiffness ratio."""
        return self._b

    @property
    def residual_force(self) -> float | None:
        """Strength floor in N (``None``: none)."""
        return self._fr


_POS, _NEG, _LINE = 1, -1, 0

MEMORY_MODES = ('none', 'kinematic')
"""Accepted values of :class:`PushoverHysteresis`'s ``memory``."""


class PushoverHysteresis(HysteresisModel):
    """The thesis's hysteresis rule built on a pushover backbone ``B`` (Appendix A).

    Branches (``k_u`` is the unloading stiffness, by default ``k_ini`` = ``B``'s first slope):

    * positive backbone with pivot ``P+``: ``f = B(x - P+)`` (MATLAB state 1, pivot
      ``xpivot1``);
    * negative backbone with pivot ``P-``: ``f = -B(P- - x)`` (state 3, pivot ``xpivot``);
    * elastic line of slope ``k_u`` through the last reversal point (states 2, 4, 5, 6).

    The virgin model is on the backbone with ``P+ = P- = 0``. A reversal on the positive
    branch at the committed point ``(x_r, f_r)`` starts the line
    ``f = f_r + k_u (x - x_r)``. Its upper exit is ``x_r``: past it the model is back on the
    positive backbone with the same ``P+`` (continuous, as ``B(x_r - P+) = f_r``). Its lower
    exit is the zero-force crossing ``z = x_r - f_r / k_u``: below it the model is on the
    negative backbone with the new pivot ``P- = z`` (MATLAB ``xpivot = xmax - fmax/kini``).
    The mirror holds on the negative branch: lower exit ``x_r`` back onto the negative
    backbone with the same ``P-``, upper exit ``z`` onto the positive backbone with
    ``P+ = z`` (MATLAB ``xpivot1 = xmin - fmin/kini``). Moving either way along the line needs
    no memory (MATLAB states 2/5 and 4/6 are one line each); exits are checked on the trial
    displacement, so one step may go from the line onto a backbone or from a backbone across
    the whole line onto the opposite backbone.

    Consequences (``memory='none'``, the thesis's rule): no memory of the opposite
    excursion (after yielding at ``+`` and unloading, the negative branch yields at ``-F_y``
    a yield displacement below the new pivot, and every new pivot restarts the backbone from
    its origin), unloading and reloading at ``k_u``, symmetric, no stiffness or strength
    degradation. With a softening backbone a cycle therefore climbs the backbone's peak again
    from every new pivot, and the force of a later cycle can exceed the strength left on the
    envelope. A virgin model pushed to negative displacement follows ``-B(-x)`` (the MATLAB
    starts on the positive branch and has no value there).

    **Kinematic memory** (``memory='kinematic'``): each direction remembers how far along
    its backbone it has gone, ``d+`` (the largest ``x - P+`` reached on the positive branch)
    and ``d-`` (the largest ``P- - x`` on the negative one). A line leaves towards a
    direction where it meets that direction's backbone at its remembered point: the upper
    exit of a line whose zero-force point is ``z`` is ``x_hi = z + B(d+)/k_u`` with
    ``P+ = x_hi - d+`` (the backbone translated, kinematically, so that it continues from
    ``d+``), the lower exit ``x_lo = z - B(d-)/k_u`` with ``P- = x_lo + d-``. A reversal on
    a backbone keeps the same exit back onto it as before (``x_r``), so the rule differs from
    the thesis's only where that one resets the opposite direction to ``d = 0``. The force
    stays within the envelope ``[-B(d-), B(d+)]`` and a softening backbone is descended
    cycle after cycle, never climbed again (an excursion's damage is kept). With ``d- = 0``
    (and ``d+ = 0``) the exits are the thesis's ``z``, so both rules agree up to the first
    excursion in the second direction.

    Reversals: the MATLAB detects a reversal by the sign of the velocity at a sample and
    takes that sample as the reversal point. This model only sees displacements and detects
    a reversal when the trial displacement moves backwards from the committed one, taking the
    committed point as the reversal point. With ``x_{i+1} - x_i = dt v_i + O(dt^2)`` the two
    signs agree except within one sample of a turning point, where the reversal point can
    differ by one sample, i.e. by ``O(dt^2)`` in displacement; for a sampling in which the
    signs agree the forces are identical.

    Beyond the last backbone point (measured from the pivot) ``beyond`` applies, see
    :meth:`Backbone.force_at`: ``'extrapolate'`` (default) continues the last slope,
    ``'plateau'`` keeps the last force, ``'error'`` raises :class:`HysteresisError`.

    If the backbone has softened to ``f_r <= 0`` at a positive reversal (or ``>= 0`` at a
    negative one) the line is degenerate (its opposite exit lies beyond ``x_r``) and the
    model goes straight onto the opposite backbone (with ``memory='none'``: pivot ``z``, as
    the MATLAB does); the force then jumps. A strength floor in the backbone (e.g. the
    bilinear backbone's ``residual_force``) avoids this.

    Internal state: ``(branch, P+, P-, x_r, f_r, x_lo, x_hi, d+, d-)`` with the line data
    meaningful on the line only, where ``P+``/``P-`` are the pivots taken on exiting
    above/below.

    Args:
        backbone: The monotonic pushover curve.
        unloading_stiffness: ``k_u`` in N/m; ``None`` uses ``backbone.initial_stiffness``.
        beyond: ``'extrapolate'``, ``'plateau'`` or ``'error'``.
        memory: ``'none'`` (default, the thesis's Appendix A rule) or ``'kinematic'``.

    Raises:
        HysteresisError: If ``unloading_stiffness`` is not positive and finite, the backbone's
            initial stiffness is not positive, or ``beyond`` or ``memory`` is unknown.
    """

    def __init__(self, backbone: Backbone, unloading_stiffness: float | None = None,
                 beyond: str = 'extrapolate', memory: str = 'none') -> None:
        if not isinstance(backbone, Backbone):
            msg = f'PushoverHysteresis: backbone must be a Backbone, got {type(backbone).__name__}'
            raise HysteresisError(msg)
        if beyond not in BEYOND_MODES:
            msg = (
                f"PushoverHysteresis: beyond must be one of {', '.join(BEYOND_MODES)}, got "
                f'{beyond!r}'
            )
            raise HysteresisError(msg)
        k_ini = backbone.initial_stiffness
        if not k_ini > 0.0:
            msg = (
                f"PushoverHysteresis: backbone '{backbone.source}' has a non-positive initial "
                f'stiffness {k_ini:g} N/m'
            )
            raise HysteresisError(msg)
        if memory not in MEMORY_MODES:
            msg = (
                f"PushoverHysteresis: memory must be one of {', '.join(MEMORY_MODES)}, got "
                f'{memory!r}'
            )
            raise HysteresisError(msg)
        self._backbone = backbone
        self._beyond = beyond
        self._kinematic = memory == 'kinematic'
        self._k_ini = k_ini
        self._ku = k_ini if unloading_stiffness is None else _positive(
            unloading_stiffness, 'unloading_stiffness', 'PushoverHysteresis')
        super().__init__()

    def _initial_state(self) -> State:
        return (_POS, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def _evaluate(self, x: float) -> tuple[float, State]:
        state = self._s_c
        branch = state[0]
        ku = self._ku
        if branch == _POS:
            p_pos = state[1]
            if x >= self._x_c:
                return self._backbone.force_at(x - p_pos, self._beyond), state
            # Reversal on the positive backbone at the committed point.
            xr, fr = self._x_c, self._f_c
            d_pos = xr - p_pos
            d_neg = state[8] if self._kinematic else 0.0
            z = xr - fr / ku
            x_lo = z - self._backbone.force_at(d_neg, self._beyond) / ku
            state = (_LINE, p_pos, x_lo + d_neg, xr, fr, x_lo, xr, d_pos, d_neg)
        elif branch == _NEG:
            p_neg = state[2]
            if x <= self._x_c:
                return -self._backbone.force_at(p_neg - x, self._beyond), state
            xr, fr = self._x_c, self._f_c
            d_neg = p_neg - xr
            d_pos = state[7] if self._kinematic else 0.0
            z = xr - fr / ku
            x_hi = z + self._backbone.force_at(d_pos, self._beyond) / ku
            state = (_LINE, x_hi - d_pos, p_neg, xr, fr, xr, x_hi, d_pos, d_neg)
        _, p_pos, p_neg, xr, fr, x_lo, x_hi, d_pos, d_neg = state
        if x > x_hi:
            return (self._backbone.force_at(x - p_pos, self._beyond),
                    (_POS, p_pos, p_neg, xr, fr, x_lo, x_hi, d_pos, d_neg))
        if x < x_lo:
            return (-self._backbone.force_at(p_neg - x, self._beyond),
                    (_NEG, p_pos, p_neg, xr, fr, x_lo, x_hi, d_pos, d_neg))
        return fr + ku * (x - xr), state

    @property
    def initial_stiffness(self) -> float:
        """Initial stiffness of the backbone (``k_ini``) in N/m."""
        return self._k_ini

    @property
    def unloading_stiffness(self) -> float:
        """Slope of the unloading/reloading line in N/m."""
        return self._ku

    @property
    def backbone(self) -> Backbone:
        """The backbone curve."""
        return self._backbone

    @property
    def beyond(self) -> str:
        """Behaviour past the last backbone point."""
        return self._beyond

    @property
    def memory(self) -> str:
        """``'none'`` (the thesis's rule) or ``'kinematic'`` (excursion memory)."""
        return 'kinematic' if self._kinematic else 'none'

    @property
    def excursions(self) -> tuple[float, float]:
        """Committed ``(d+, d-)`` in m: how far along the backbone each direction has gone.

        Updated at each reversal (with ``memory='none'`` the direction left is reset to 0).
        """
        return self._s_c[7], self._s_c[8]

    @property
    def pivots(self) -> tuple[float, float]:
        """Committed pivots ``(P+, P-)`` in m (on the line: those taken on exiting it)."""
        return self._s_c[1], self._s_c[2]
