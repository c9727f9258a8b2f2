"""A cantilever column under an axial load, with P-Δ, in basic coordinates ``(u, v)``.

The simulated specimen of a column test (issue 16): the top of a cantilever of height ``L``
moves laterally by ``u`` and vertically by ``v`` (positive up). Its restoring force, the force
the column's top exerts back on whatever holds it there, is::

    R(u, v) = [ r_lat(u) + k_a · v · u / L ,  k_a · v ]

with ``r_lat`` any uniaxial hysteresis model (elastic, epp, bilinear with hardening or
softening, pushover, Bouc–Wen) and ``k_a`` the axial stiffness. The axial force is
``N = k_a · v`` (tension positive), so a compressive load ``P`` (``N = −P``, ``v = −P/k_a``)
gives the lateral tangent stiffness ``k_t(u) − P/L``: the P-Δ effect of the load on the
displaced top, whose overturning moment ``P · u`` is balanced by an extra lateral reaction
``P · u / L`` at the top of the cantilever.

Assumptions (the model is no more than this):

* P-Δ is the linear geometric stiffness ``N / L`` of a rigid-bar cantilever (no P-δ along the
  member, no large rotations: the lateral term is ``N · u / L``, not ``N · sin θ``);
* no axial–lateral coupling beyond it: ``r_lat`` does not depend on the axial force (no N–M
  interaction in the yield force) and the axial response does not depend on ``u`` (no
  shortening from the lateral displacement);
* the axial response is linear elastic (``k_a``, no history).

The model has a trial and a committed state like :class:`~pd_common.specimen.Specimen`:
:meth:`ColumnSpecimen.restoring_force` evaluates a trial from the committed state (any number
of times), :meth:`~ColumnSpecimen.commit` accepts it, :meth:`~ColumnSpecimen.revert_to_last_commit`
discards it. :meth:`~ColumnSpecimen.tangent` is the trial tangent ``∂R/∂(u, v)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..errors import SpecimenError
from .bouc_wen import BoucWen
from .hysteresis import HysteresisModel

__all__ = ['ColumnSpecimen', 'hysteresis_tangent']

#: Relative size of the finite-difference step of a hysteresis model's tangent.
TANGENT_STEP = 1.0e-7
#: Smallest finite-difference step [m] (for a trial at or near zero displacement).
TANGENT_FLOOR = 1.0e-9


def hysteresis_tangent(model: HysteresisModel, x: float) -> float:
    """The trial tangent ``df/dx`` [N/m] of ``model`` at ``x``, leaving its trial state at ``x``.

    A Bouc–Wen model has its own consistent tangent; every other model is differentiated by a
    one-sided difference of two trial evaluations (from the committed state, as the model
    always evaluates), the step taken in the direction of motion from the committed
    displacement so that the difference stays on the branch the trial is on (exact for the
    piecewise-linear models away from a kink).
    """
    force = model.set_trial_displacement(x)
    if isinstance(model, BoucWen):
        return model.tangent
    direction = 1.0 if x >= model.committed_displacement else -1.0
    step = direction * max(TANGENT_STEP * abs(x), TANGENT_FLOOR)
    ahead = model.set_trial_displacement(x + step)
    model.set_trial_displacement(x)
    return (ahead - force) / step


class ColumnSpecimen:
    """A cantilever column of height ``L`` with P-Δ (see the module docstring).

    Args:
        lateral: the lateral hysteresis model ``r_lat(u)`` (owned and mutated).
        height: ``L`` [m], the cantilever's height.
        axial_stiffness: ``k_a`` [N/m].
        dof_names: the two basic DOFs' names (default ``u, v``).

    Raises:
        SpecimenError: a non-positive height or axial stiffness, a lateral model that is not a
            HysteresisModel, or not two distinct DOF names (the message starts with
            ``column:``).
    """

    def __init__(self, lateral: HysteresisModel, height: float, axial_stiffness: float,
                 dof_names: Sequence[str] = ('u', 'v')) -> None:
        if not isinstance(lateral, HysteresisModel):
            msg = f'column: lateral must be a HysteresisModel, got {type(lateral).__name__}'
            raise SpecimenError(msg)
        for name, value in (('height', height), ('axial_stiffness', axial_stiffness)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                    math.isfinite(value) and value > 0.0):
                msg = f'column: {name} must be a positive finite number, got {value!r}'
                raise SpecimenError(msg)
        names = tuple(dof_names)
        if len(names) != 2 or len(set(names)) != 2:
            msg = f'column: needs two distinct DOF names (u, v), got {list(names)}'
            raise SpecimenError(msg)
        self._lateral = lateral
        self._height = float(height)
        self._k_a = float(axial_stiffness)
        self._dof_names = names
        self._v_c = 0.0
        self._v_t = 0.0

    @property
    def n_dof(self) -> int:
        """2: the lateral ``u`` and the vertical ``v`` of the top."""
        return 2

    @property
    def dof_names(self) -> tuple[str, ...]:
        """Names of the basic DOFs."""
        return self._dof_names

    @property
    def lateral(self) -> HysteresisModel:
        """The lateral model (the specimen mutates its state)."""
        return self._lateral

    @property
    def height(self) -> float:
        """``L`` [m]."""
        return self._height

    @property
    def axial_stiffness(self) -> float:
        """``k_a`` [N/m]."""
        return self._k_a

    def axial_force(self) -> float:
        """``N = k_a · v`` of the trial state [N] (tension positive, a compression < 0)."""
        return self._k_a * self._v_t

    def _check(self, x: np.ndarray | Sequence[float]) -> tuple[float, float]:
        try:
            values = np.asarray(x, dtype=float)
        except (TypeError, ValueError):
            msg = f'column: displacement must be 2 numbers (u, v), got {x!r}'
            raise SpecimenError(msg) from None
        if values.shape != (2,):
            msg = f'column: displacement must have shape (2,), got {values.shape}'
            raise SpecimenError(msg)
        u, v = float(values[0]), float(values[1])
        for name, value in zip(self._dof_names, (u, v)):
            if not math.isfinite(value):
                msg = f'column: displacement of {name} is not finite ({value})'
                raise SpecimenError(msg)
        return u, v

    def restoring_force(self, x: np.ndarray | Sequence[float]) -> NDArray[np.float64]:
        """Set the trial ``(u, v)`` [m] and return the trial ``R(u, v)`` [N].

        Raises:
            SpecimenError: a wrong length or a non-finite value, or the lateral model cannot
                take ``u`` (the trial state is then unchanged).
        """
        u, v = self._check(x)
        lateral = self._lateral.set_trial_displacement(u)
        self._v_t = v
        axial = self._k_a * v
        return np.array([lateral + axial * u / self._height, axial])

    def tangent(self, x: np.ndarray | Sequence[float]) -> NDArray[np.float64]:
        """The trial tangent ``∂R/∂(u, v)`` at ``(u, v)`` [N/m], leaving the trial there.

        The matrix::

            [[k_t(u) + k_a v / L,  k_a u / L],
             [0,                   k_a      ]]
        """
        u, v = self._check(x)
        k_t = hysteresis_tangent(self._lateral, u)
        self._v_t = v
        k_a, length = self._k_a, self._height
        return np.array([[k_t + k_a * v / length, k_a * u / length], [0.0, k_a]])

    def committed_restoring_force(self) -> NDArray[np.float64]:
        """``R`` of the committed state [N]."""
        u = self._lateral.committed_displacement
        axial = self._k_a * self._v_c
        return np.array([self._lateral.committed_force + axial * u / self._height, axial])

    def committed_displacement(self) -> tuple[float, float]:
        """The committed ``(u, v)`` [m]."""
        return self._lateral.committed_displacement, self._v_c

    def commit(self) -> None:
        """Accept the trial state."""
        self._lateral.commit()
        self._v_c = self._v_t

    def revert_to_last_commit(self) -> None:
        """Discard the trial state."""
        self._lateral.revert_to_last_commit()
        self._v_t = self._v_c

    def reset(self) -> None:
        """Back to the virgin state."""
        self._lateral.reset()
        self._v_c = self._v_t = 0.0

    def initial_stiffness_matrix(self) -> NDArray[np.float64]:
        """``diag(k_0, k_a)`` [N/m]: the tangent of the virgin, unloaded column."""
        return np.diag([self._lateral.initial_stiffness, self._k_a])
