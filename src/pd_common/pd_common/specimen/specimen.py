"""Multi-DOF specimen assembled from uniaxial hysteresis elements."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..errors import SpecimenError
from .column import hysteresis_tangent
from .hysteresis import HysteresisModel

TOPOLOGIES = ('independent', 'shear_building')
"""Accepted ways of connecting the elements to the DOFs."""


class Specimen:
    """Specimen whose restoring forces come from one uniaxial element per DOF.

    Topologies:

    * ``'independent'``: element ``i`` connects DOF ``i`` to the ground, ``r_i = f_i(x_i)``.
    * ``'shear_building'``: element ``i`` is story ``i`` between DOF ``i-1`` (the ground for
      ``i = 0``) and DOF ``i``; with the drift ``d_i = x_i - x_{i-1}`` and story force
      ``f_i(d_i)``, ``r_i = f_i - f_{i+1}`` (``f_n = 0``).

    Args:
        elements: One hysteresis model per DOF (per story), each a distinct object; the
            specimen owns and mutates them.
        topology: ``'independent'`` (default) or ``'shear_building'``.
        dof_names: Names of the DOFs, one per element; default ``dof0, dof1, ...``.

    Raises:
        SpecimenError: If there are no elements, an element is not a HysteresisModel or is
            repeated, the topology is unknown or the DOF names do not match the elements.
    """

    def __init__(self, elements: Sequence[HysteresisModel], topology: str = 'independent',
                 dof_names: Sequence[str] | None = None) -> None:
        elements = list(elements)
        if not elements:
            msg = 'specimen: needs at least one element'
            raise SpecimenError(msg)
        for i, element in enumerate(elements):
            if not isinstance(element, HysteresisModel):
                msg = (
                    f'specimen: elements[{i}] must be a HysteresisModel, got '
                    f'{type(element).__name__}'
                )
                raise SpecimenError(msg)
        if len({id(element) for element in elements}) != len(elements):
            msg = 'specimen: the same element object is used more than once'
            raise SpecimenError(msg)
        if topology not in TOPOLOGIES:
            msg = f"specimen: topology must be one of {', '.join(TOPOLOGIES)}, got {topology!r}"
            raise SpecimenError(msg)
        n = len(elements)
        names = [f'dof{i}' for i in range(n)] if dof_names is None else list(dof_names)
        if len(names) != n:
            msg = f'specimen: {n} elements but {len(names)} DOF names {names}'
            raise SpecimenError(msg)
        if len(set(names)) != n:
            msg = f'specimen: DOF names must be unique, got {names}'
            raise SpecimenError(msg)
        self._elements = elements
        self._topology = topology
        self._dof_names = tuple(names)
        self._shear = topology == 'shear_building'

    @property
    def n_dof(self) -> int:
        """Number of degrees of freedom."""
        return len(self._elements)

    @property
    def dof_names(self) -> tuple[str, ...]:
        """Names of the DOFs."""
        return self._dof_names

    @property
    def topology(self) -> str:
        """``'independent'`` or ``'shear_building'``."""
        return self._topology

    @property
    def elements(self) -> tuple[HysteresisModel, ...]:
        """The elements (the specimen mutates their state)."""
        return tuple(self._elements)

    def _check(self, x: np.ndarray | Sequence[float]) -> list[float]:
        """Return ``x`` as a list of finite floats of length ``n_dof``, else raise."""
        try:
            values = np.asarray(x, dtype=float)
        except (TypeError, ValueError):
            msg = f'specimen: displacement must be {self.n_dof} numbers, got {x!r}'
            raise SpecimenError(msg) from None
        if values.shape != (self.n_dof,):
            msg = f'specimen: displacement must have shape ({self.n_dof},), got {values.shape}'
            raise SpecimenError(msg)
        out: list[float] = values.tolist()
        for name, value in zip(self._dof_names, out):
            if not math.isfinite(value):
                msg = f'specimen: displacement of {name} is not finite ({value})'
                raise SpecimenError(msg)
        return out

    def restoring_force(self, x: np.ndarray | Sequence[float]) -> np.ndarray:
        """Set the trial displacements and return the trial restoring forces.

        Args:
            x: DOF displacements in m, shape ``(n_dof,)``.

        Returns:
            Restoring forces in N, shape ``(n_dof,)``.

        Raises:
            SpecimenError: If ``x`` has the wrong length or a non-finite value; the elements
                may raise :class:`HysteresisError` (a SpecimenError) too.
        """
        xs = self._check(x)
        elements = self._elements
        if len(xs) == 1:
            return np.array([elements[0].set_trial_displacement(xs[0])])
        if not self._shear:
            return np.array([el.set_trial_displacement(xi) for el, xi in zip(elements, xs)])
        story = []
        below = 0.0
        for el, xi in zip(elements, xs):
            story.append(el.set_trial_displacement(xi - below))
            below = xi
        story.append(0.0)
        return np.array([story[i] - story[i + 1] for i in range(len(xs))])

    def tangent(self, x: np.ndarray | Sequence[float]) -> np.ndarray:
        """The trial tangent stiffness ``∂r/∂x`` at ``x`` [N/m], leaving the trial state there.

        Each element's tangent comes from :func:`~pd_common.specimen.column.hysteresis_tangent`;
        assembled like :meth:`initial_stiffness_matrix`.
        """
        xs = self._check(x)
        below = [0.0, *xs[:-1]] if self._shear else [0.0] * len(xs)
        k = np.array([hysteresis_tangent(el, xi - base)
                      for el, xi, base in zip(self._elements, xs, below)])
        if not self._shear:
            return np.diag(k)
        above = np.append(k[1:], 0.0)
        return np.diag(k + above) - np.diag(k[1:], 1) - np.diag(k[1:], -1)

    def committed_restoring_force(self) -> np.ndarray:
        """Return the restoring forces of the committed state in N."""
        story = [el.committed_force for el in self._elements]
        if not self._shear:
            return np.array(story)
        story.append(0.0)
        return np.array([story[i] - story[i + 1] for i in range(self.n_dof)])

    def commit(self) -> None:
        """Commit the trial state of every element."""
        for el in self._elements:
            el.commit()

    def revert_to_last_commit(self) -> None:
        """Discard the trial state of every element."""
        for el in self._elements:
            el.revert_to_last_commit()

    def reset(self) -> None:
        """Return every element to its virgin state."""
        for el in self._elements:
            el.reset()

    def initial_stiffness_matrix(self) -> np.ndarray:
        """Return the initial stiffness matrix in N/m, shape ``(n_dof, n_dof)``.

        Diagonal for ``'independent'``; for ``'shear_building'`` the tridiagonal matrix with
        ``K_ii = k_i + k_{i+1}`` and ``K_{i,i+1} = K_{i+1,i} = -k_{i+1}``.
        """
        k = np.array([el.initial_stiffness for el in self._elements])
        if not self._shear:
            return np.diag(k)
        above = np.append(k[1:], 0.0)
        return np.diag(k + above) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
