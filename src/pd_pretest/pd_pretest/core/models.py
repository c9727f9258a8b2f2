"""Hysteresis models vectorised over systems: one array element per system.

Each class reproduces one scalar model of :mod:`pd_common.specimen.hysteresis` — the same
formulas in the same operation order and branch order — for arrays of shape ``(n,)``, so that
a batch of systems gives, float for float, what ``n`` scalar models give one at a time (the
pre-test tests check this against the project's own session). The state is committed after
every trial (:meth:`BatchModel.trial` then :meth:`BatchModel.commit`), as the specimen server
does for an explicit scheme (one trial per step).

Supported: ``elastic``, ``epp``, ``bilinear`` (softening and ``residual_force`` included) and
``pushover`` with ``memory: none`` and ``beyond_last_point`` ``extrapolate`` or ``plateau``.
:func:`batch_from_models` builds a batch from the scalar models (one per system) that the
test file describes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from pd_common.specimen import (
    BilinearKinematic,
    Elastic,
    ElasticPerfectlyPlastic,
    HysteresisModel,
    PushoverHysteresis,
)
from pd_common.types import FloatArray

from .errors import PretestError

__all__ = [
    'SUPPORTED_MODELS',
    'BatchModel',
    'BilinearBatch',
    'EPPBatch',
    'ElasticBatch',
    'PushoverBatch',
    'batch_from_models',
]

#: The element models the pre-test vectorises (``specimen.elements[0].model``).
SUPPORTED_MODELS = ('elastic', 'epp', 'bilinear', 'pushover')

def _array(values: Sequence[float] | FloatArray | float, n: int) -> FloatArray:
    """A float array of shape ``(n,)`` (a scalar is broadcast)."""
    out = np.empty(n)
    out[...] = values
    return out


class BatchModel:
    """Base of the vectorised models: committed and trial displacement and force.

    Subclasses implement :meth:`trial` (from the committed state only) and keep their own
    trial state, promoted by :meth:`commit`.
    """

    name: ClassVar[str] = ''

    def __init__(self, n: int) -> None:
        self.n = n
        self.xc = np.zeros(n)
        self.fc = np.zeros(n)
        self._xt = np.zeros(n)
        self._ft = np.zeros(n)

    def trial(self, x: FloatArray) -> FloatArray:
        """The trial force at ``x`` (a buffer owned by the model, valid until the next call)."""
        raise NotImplementedError

    def commit(self) -> None:
        """Make the trial state the committed state."""
        self.xc, self._xt = self._xt, self.xc
        self.fc, self._ft = self._ft, self.fc

    def _take_trial(self, x: FloatArray) -> None:
        self._xt[...] = x


class ElasticBatch(BatchModel):
    """``f = k x`` (:class:`~pd_common.specimen.Elastic`)."""

    name = 'elastic'

    def __init__(self, stiffness: FloatArray) -> None:
        super().__init__(stiffness.size)
        self.k = np.array(stiffness, dtype=float)

    def trial(self, x: FloatArray) -> FloatArray:
        """The trial force at ``x``: ``k x``."""
        self._take_trial(x)
        np.multiply(self.k, x, out=self._ft)
        return self._ft


class EPPBatch(BatchModel):
    """Elastic-perfectly-plastic (:class:`~pd_common.specimen.ElasticPerfectlyPlastic`).

    ``f = k (x − x_p)``; beyond ``±F_y`` the force is ``±F_y`` and ``x_p = x ∓ F_y/k``.
    ``clip`` gives exactly the scalar branches' force; the plastic displacement
    ``x − f/k`` equals ``x ∓ F_y/k`` on yielding (``f = ±F_y`` exactly, negation is exact) and
    is replaced by the committed one elsewhere.
    """

    name = 'epp'

    def __init__(self, stiffness: FloatArray, yield_force: FloatArray) -> None:
        n = stiffness.size
        super().__init__(n)
        self.k = np.array(stiffness, dtype=float)
        self.fy = _array(yield_force, n)
        self.neg_fy = -self.fy
        self.xp = np.zeros(n)
        self._xp_t = np.zeros(n)
        self._f = np.empty(n)
        self._tmp = np.empty(n)
        self._elastic = np.empty(n, dtype=bool)

    def trial(self, x: FloatArray) -> FloatArray:
        """The trial force at ``x`` (a buffer owned by the model, valid until the next call)."""
        self._take_trial(x)
        f, tmp, ft, xpt = self._f, self._tmp, self._ft, self._xp_t
        np.subtract(x, self.xp, out=f)
        f *= self.k
        np.clip(f, self.neg_fy, self.fy, out=ft)
        np.equal(f, ft, out=self._elastic)  # not yielding: f within [-F_y, F_y]
        np.divide(ft, self.k, out=tmp)
        np.subtract(x, tmp, out=xpt)
        np.copyto(xpt, self.xp, where=self._elastic)
        return ft

    def commit(self) -> None:
        """Make the trial state the committed state."""
        super().commit()
        self.xp, self._xp_t = self._xp_t, self.xp


class BilinearBatch(BatchModel):
    """Bilinear kinematic hardening/softening (:class:`~pd_common.specimen.BilinearKinematic`).

    ``residual_force`` ``None`` is held as ``-inf`` (the floor test is then never true).
    """

    name = 'bilinear'

    def __init__(self, stiffness: FloatArray, yield_force: FloatArray, hardening_ratio: FloatArray,
                 residual_force: FloatArray | None = None) -> None:
        n = stiffness.size
        super().__init__(n)
        self.k = np.array(stiffness, dtype=float)
        self.fy = _array(yield_force, n)
        self.b = _array(hardening_ratio, n)
        # Exactly the scalar model's H = b k / (1 - b) and the k + H of its plastic increment.
        self.h = self.b * self.k / (1.0 - self.b)
        self.k_plus_h = self.k + self.h
        self.fr = (np.full(n, -math.inf) if residual_force is None
                   else _array(residual_force, n))
        self.has_floor = bool(np.any(np.isfinite(self.fr)))
        self.xp = np.zeros(n)
        self.alpha = np.zeros(n)
        self._xp_t = np.zeros(n)
        self._alpha_t = np.zeros(n)
        self._f = np.empty(n)
        self._xi = np.empty(n)
        self._excess = np.empty(n)
        self._dgamma = np.empty(n)
        self._tmp = np.empty(n)
        self._sign = np.empty(n)
        self._yield = np.empty(n, dtype=bool)
        self._mask = np.empty(n, dtype=bool)
        self._mask2 = np.empty(n, dtype=bool)

    def trial(self, x: FloatArray) -> FloatArray:
        """The trial force at ``x`` (a buffer owned by the model, valid until the next call)."""
        self._take_trial(x)
        k = self.k
        f, xi, excess, dgamma, tmp = self._f, self._xi, self._excess, self._dgamma, self._tmp
        ft, xpt, alt, yielding = self._ft, self._xp_t, self._alpha_t, self._yield
        np.subtract(x, self.xp, out=f)
        f *= k                                  # f = k (x - x_p)
        np.subtract(f, self.alpha, out=xi)      # xi = f - alpha
        np.abs(xi, out=excess)
        excess -= self.fy                       # excess = |xi| - F_y
        np.greater(excess, 0.0, out=yielding)
        np.divide(excess, self.k_plus_h, out=dgamma)
        np.copysign(dgamma, xi, out=dgamma)     # dgamma = copysign(excess / (k + H), xi)
        np.multiply(k, dgamma, out=tmp)
        np.subtract(f, tmp, out=ft)             # f_yield = f - k dgamma
        np.add(self.xp, dgamma, out=xpt)        # x_p + dgamma
        np.multiply(self.h, dgamma, out=tmp)
        np.add(self.alpha, tmp, out=alt)        # alpha + H dgamma
        if self.has_floor:
            self._floor(x, f)
        elastic = self._mask
        np.logical_not(yielding, out=elastic)
        np.copyto(ft, f, where=elastic)
        np.copyto(xpt, self.xp, where=elastic)
        np.copyto(alt, self.alpha, where=elastic)
        return ft

    def _floor(self, x: FloatArray, f: FloatArray) -> None:
        """The strength floor: where the bounding line is below ``F_r`` (scalar branch order)."""
        sign, tmp, ft, xpt, alt = self._sign, self._tmp, self._ft, self._xp_t, self._alpha_t
        yielding, below, stay = self._yield, self._mask, self._mask2
        np.copysign(1.0, self._xi, out=sign)
        np.multiply(sign, ft, out=tmp)
        np.less(tmp, self.fr, out=below)
        below &= yielding                       # yielding and sign * f_yield < F_r
        np.multiply(sign, f, out=tmp)
        np.less_equal(tmp, self.fr, out=stay)
        stay &= below                           # not beyond the floor: elastic
        yielding &= ~stay                       # (treated as elastic below)
        below &= ~stay                          # yield at ±F_r
        np.multiply(sign, self.fr, out=tmp)     # f_yield = sign F_r
        np.copyto(ft, tmp, where=below)
        np.divide(tmp, self.k, out=tmp)
        np.subtract(x, tmp, out=tmp)            # x_p = x - f_yield / k
        np.copyto(xpt, tmp, where=below)
        np.multiply(self.h, tmp, out=tmp)       # alpha = H x_p
        np.copyto(alt, tmp, where=below)

    def commit(self) -> None:
        """Make the trial state the committed state."""
        super().commit()
        self.xp, self._xp_t = self._xp_t, self.xp
        self.alpha, self._alpha_t = self._alpha_t, self.alpha


class _BackboneTable:
    """Piecewise-linear backbones of every system, evaluated like ``Backbone.force_at``.

    Per system the points ``D``, ``F`` and the slopes ``S`` with one extra slope at the last
    point: the last segment's slope (``extrapolate``) or 0 (``plateau``, ``F[-1] + 0 (d -
    D[-1]) = F[-1]`` exactly). Then ``B(d) = F[i] + S[i] (d − D[i])`` with
    ``i = bisect_right(D, d) − 1`` is the scalar formula on every segment, at the last point
    and beyond it. One shared backbone uses ``searchsorted``; different ones are padded with
    ``D = inf`` and indexed by counting.
    """

    def __init__(self, tables: list[tuple[FloatArray, FloatArray, FloatArray]]) -> None:
        n = len(tables)
        first = tables[0]
        self.shared = all(t is first or all(np.array_equal(a, b) for a, b in zip(t, first))
                          for t in tables)
        if self.shared:
            self.d, self.f, self.s = (np.array(a, dtype=float) for a in first)
            self.points = self.d.size
        else:
            width = max(t[0].size for t in tables)
            self.points = width
            d = np.full((n, width), math.inf)
            f = np.zeros((n, width))
            s = np.zeros((n, width))
            for row, (td, tf, ts) in enumerate(tables):
                d[row, :td.size] = td
                f[row, :td.size] = tf
                s[row, :td.size] = ts
            self.columns = [np.ascontiguousarray(d[:, j]) for j in range(width)]
            self.d, self.f, self.s = d.reshape(-1), f.reshape(-1), s.reshape(-1)
            self.offset = np.arange(n, dtype=np.intp) * width
        self._index = np.empty(n, dtype=np.intp)
        self._flag = np.empty(n, dtype=bool)
        self._tmp = np.empty(n)

    def force(self, d: FloatArray, out: FloatArray) -> FloatArray:
        index, tmp = self._index, self._tmp
        if self.shared:
            np.subtract(np.searchsorted(self.d, d, side='right'), 1, out=index)
        else:
            index[...] = self.offset
            for column in self.columns[1:]:
                np.greater_equal(d, column, out=self._flag)
                index += self._flag
        np.take(self.d, index, out=tmp, mode='clip')
        np.subtract(d, tmp, out=tmp)            # d - D[i]
        np.take(self.s, index, out=out, mode='clip')
        tmp *= out                              # S[i] (d - D[i])
        np.take(self.f, index, out=out, mode='clip')
        out += tmp                              # F[i] + S[i] (d - D[i])
        return out


_POS, _NEG, _LINE = 1, -1, 0


class PushoverBatch(BatchModel):
    """The thesis's pushover hysteresis, ``memory: none`` (:class:`PushoverHysteresis`).

    State per system: branch (``+1`` positive backbone, ``-1`` negative, ``0`` the line),
    pivots ``P+``/``P-``, the line's reversal point ``(x_r, f_r)`` and exits ``x_lo``/``x_hi``.
    With ``memory='none'`` the opposite excursion is 0, so a reversal's new exit is the
    zero-force point ``z = x_r − f_r/k_u`` exactly (``B(0) = 0``).
    """

    name = 'pushover'

    def __init__(self, tables: list[tuple[FloatArray, FloatArray, FloatArray]],
                 unloading_stiffness: FloatArray) -> None:
        n = len(tables)
        super().__init__(n)
        self.backbone = _BackboneTable(tables)
        self.ku = _array(unloading_stiffness, n)
        zeros = [np.zeros(n) for _ in range(12)]
        (self.pp, self.pn, self.xr, self.fr, self.xlo, self.xhi,
         self._pp_t, self._pn_t, self._xr_t, self._fr_t, self._xlo_t, self._xhi_t) = zeros
        self.branch = np.full(n, _POS, dtype=np.int8)
        self._branch_t = np.full(n, _POS, dtype=np.int8)
        self._z = np.empty(n)
        self._arg = np.empty(n)
        self._tmp = np.empty(n)
        self._fb = np.empty(n)
        (self._pos, self._neg, self._rev_p, self._rev_n, self._line, self._up, self._down,
         self._flag) = (np.empty(n, dtype=bool) for _ in range(8))

    def trial(self, x: FloatArray) -> FloatArray:
        """The trial force at ``x`` (a buffer owned by the model, valid until the next call)."""
        self._take_trial(x)
        xc, fc, branch = self.xc, self.fc, self.branch
        pos, neg, rev_p, rev_n = self._pos, self._neg, self._rev_p, self._rev_n
        line, up, down, flag = self._line, self._up, self._down, self._flag
        z, arg, tmp, fb, ft = self._z, self._arg, self._tmp, self._fb, self._ft
        pp, pn, xr, fr, xlo, xhi = (self._pp_t, self._pn_t, self._xr_t, self._fr_t,
                                    self._xlo_t, self._xhi_t)
        np.equal(branch, _POS, out=pos)
        np.equal(branch, _NEG, out=neg)
        np.less(x, xc, out=rev_p)
        rev_p &= pos                            # on + and moving back: reversal at (x_c, f_c)
        np.greater(x, xc, out=rev_n)
        rev_n &= neg
        np.divide(fc, self.ku, out=z)
        np.subtract(xc, z, out=z)               # z = x_r - f_r / k_u
        # The trial line (unchanged unless a reversal starts a new one).
        pp[...] = self.pp
        pn[...] = self.pn
        xr[...] = self.xr
        fr[...] = self.fr
        xlo[...] = self.xlo
        xhi[...] = self.xhi
        np.logical_or(rev_p, rev_n, out=flag)
        np.copyto(xr, xc, where=flag)
        np.copyto(fr, fc, where=flag)
        np.copyto(xlo, z, where=rev_p)          # + reversal: exits x_lo = z, x_hi = x_r,
        np.copyto(xhi, xc, where=rev_p)         # P- = z
        np.copyto(pn, z, where=rev_p)
        np.copyto(xlo, xc, where=rev_n)         # - reversal: exits x_lo = x_r, x_hi = z,
        np.copyto(xhi, z, where=rev_n)          # P+ = z
        np.copyto(pp, z, where=rev_n)
        np.equal(branch, _LINE, out=line)
        line |= flag                            # on the line (as it was, or a new one)
        np.greater(x, xhi, out=up)
        up &= line                              # leaves above: positive backbone
        np.less(x, xlo, out=down)
        down &= line
        down &= ~up                             # leaves below: negative backbone
        np.greater_equal(x, xc, out=flag)
        flag &= pos
        up |= flag                              # on the positive backbone
        np.less_equal(x, xc, out=flag)
        flag &= neg
        down |= flag                            # on the negative backbone
        np.subtract(x, pp, out=arg)             # B(x - P+) ...
        np.subtract(pn, x, out=tmp)
        np.copyto(arg, tmp, where=down)         # ... or -B(P- - x)
        self.backbone.force(arg, fb)
        np.subtract(x, xr, out=tmp)
        tmp *= self.ku
        np.add(fr, tmp, out=ft)                 # the line: f_r + k_u (x - x_r)
        np.copyto(ft, fb, where=up)
        np.negative(fb, out=fb)
        np.copyto(ft, fb, where=down)
        bt = self._branch_t
        bt[...] = _LINE
        np.copyto(bt, _POS, where=up)
        np.copyto(bt, _NEG, where=down)
        return ft

    def commit(self) -> None:
        """Make the trial state the committed state."""
        super().commit()
        self.branch, self._branch_t = self._branch_t, self.branch
        self.pp, self._pp_t = self._pp_t, self.pp
        self.pn, self._pn_t = self._pn_t, self.pn
        self.xr, self._xr_t = self._xr_t, self.xr
        self.fr, self._fr_t = self._fr_t, self.fr
        self.xlo, self._xlo_t = self._xlo_t, self.xlo
        self.xhi, self._xhi_t = self._xhi_t, self.xhi


def _backbone_table(model: PushoverHysteresis) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(D, F, S)`` of a pushover model's backbone, with the slope beyond the last point."""
    backbone = model.backbone
    d = np.asarray(backbone.displacement, dtype=float)
    f = np.asarray(backbone.force, dtype=float)
    slopes = np.diff(f) / np.diff(d)            # as Backbone computes its slopes
    last = 0.0 if model.beyond == 'plateau' else float(slopes[-1])
    return d, f, np.append(slopes, last)


def model_name(model: HysteresisModel) -> str:
    """The test file's name of a scalar model (``''`` if the pre-test cannot vectorise it)."""
    if type(model) is Elastic:
        return 'elastic'
    if type(model) is ElasticPerfectlyPlastic:
        return 'epp'
    if type(model) is BilinearKinematic:
        return 'bilinear'
    if type(model) is PushoverHysteresis:
        return 'pushover'
    return ''


def unsupported_reason(model: HysteresisModel) -> str | None:
    """Why a scalar model cannot be vectorised (``None``: it can)."""
    name = model_name(model)
    if not name:
        return (f'model {type(model).__name__} is not supported (supported: '
                f'{", ".join(SUPPORTED_MODELS)})')
    if isinstance(model, PushoverHysteresis):
        if model.memory != 'none':
            return f"pushover memory '{model.memory}' is not supported (only 'none')"
        if model.beyond not in ('extrapolate', 'plateau'):
            return (f"pushover beyond_last_point '{model.beyond}' is not supported "
                    "(extrapolate or plateau)")
    return None


def batch_from_models(models: Sequence[HysteresisModel]) -> BatchModel:
    """The vectorised model of ``models`` (one scalar model per system, all of one kind).

    Raises:
        PretestError: the models are of different kinds or one is not supported.
    """
    if not models:
        msg = 'no systems to simulate'
        raise PretestError(msg)
    kinds = {model_name(model) for model in models}
    for model in models:
        reason = unsupported_reason(model)
        if reason is not None:
            raise PretestError(reason)
    if len(kinds) != 1:
        msg = f'the systems mix element models ({", ".join(sorted(kinds))})'
        raise PretestError(msg)
    kind = kinds.pop()
    k = np.array([model.initial_stiffness for model in models])
    if kind == 'elastic':
        return ElasticBatch(k)
    if kind == 'epp':
        epp = [m for m in models if isinstance(m, ElasticPerfectlyPlastic)]
        return EPPBatch(k, np.array([m.yield_force for m in epp]))
    if kind == 'bilinear':
        bilinear = [m for m in models if isinstance(m, BilinearKinematic)]
        floors = [m.residual_force for m in bilinear]
        residual = (None if all(f is None for f in floors)
                    else np.array([-math.inf if f is None else f for f in floors]))
        return BilinearBatch(k, np.array([m.yield_force for m in bilinear]),
                             np.array([m.hardening_ratio for m in bilinear]), residual)
    pushover = [m for m in models if isinstance(m, PushoverHysteresis)]
    cache: dict[int, tuple[FloatArray, FloatArray, FloatArray]] = {}
    tables = [cache.setdefault(id(m), _backbone_table(m)) for m in pushover]
    return PushoverBatch(tables, np.array([m.unloading_stiffness for m in pushover]))
