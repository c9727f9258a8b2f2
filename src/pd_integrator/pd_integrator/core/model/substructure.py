"""Substructuring: numerical elements on the computer, experimental elements at sites.

A :class:`StructuralModel` splits the restoring force of the structure into

* a linear numerical part ``K_lin x`` (springs, shear stories, beam-columns; massless DOFs
  statically condensed out),
* nonlinear numerical springs (the :mod:`pd_common.specimen` hysteresis models, the same ones
  the simulator uses),
* experimental elements, whose force is measured at a *site* (a namespace ``/pd/<site>``
  served by an actuator bridge or a specimen simulator), through an experimental setup.

The step protocol across sites (one command per site, answers gathered) is
:class:`~pd_integrator.core.run.coordinator.SiteCoordinator`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from pd_common.protocol import DEFAULT_SITE

from ..errors import ConfigError

if TYPE_CHECKING:
    import scipy.sparse

    from pd_common.specimen.hysteresis import HysteresisModel

    from .setups import ExperimentalSetup

__all__ = [
    'ExperimentalElement',
    'NonlinearSpring',
    'StructuralModel',
]

@dataclass
class _TwoEnded:
    """Element DOFs ``x[dofs] - x[relative]`` (a relative index of −1 means the ground)."""

    dofs: NDArray[np.intp]
    relative: NDArray[np.intp]

    def basic(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Basic displacements of the element."""
        values = x[self.dofs]
        grounded = self.relative >= 0
        if grounded.any():
            values = values - np.where(grounded, x[np.maximum(self.relative, 0)], 0.0)
        return values

    def scatter(self, force: np.ndarray, into: np.ndarray) -> None:
        """Add the element's basic forces to the structure force vector ``into``."""
        np.add.at(into, self.dofs, force)
        grounded = self.relative >= 0
        if grounded.any():
            np.add.at(into, self.relative[grounded], -force[grounded])

    def matrix(self, n: int) -> np.ndarray:
        """``B`` with ``basic = B x`` (dense, ``n_basic × n``)."""
        b = np.zeros((self.dofs.size, n))
        b[np.arange(self.dofs.size), self.dofs] = 1.0
        for row, rel in enumerate(self.relative):
            if rel >= 0:
                b[row, rel] -= 1.0
        return b


@dataclass
class NonlinearSpring(_TwoEnded):
    """A numerical spring with a ``pd_specimen_sim`` hysteresis model (one basic DOF)."""

    name: str = ''
    model: HysteresisModel | None = None

    def trial_force(self, x: np.ndarray) -> float:
        """The force at the element deformation of ``x``, a trial from the committed state."""
        assert self.model is not None
        return self.model.set_trial_displacement(float(self.basic(x)[0]))

    def commit(self) -> None:
        """Promote the last trial (the integrator committed the step)."""
        assert self.model is not None
        self.model.commit()


@dataclass
class ExperimentalElement(_TwoEnded):
    """An element whose basic forces are measured at ``site`` through ``setup``.

    Attributes:
        name: element name (for messages).
        site: the site serving it.
        setup: basic DOFs → actuator strokes.
        actuator_names: one name per actuator (the site's command DOF names).
        initial_stiffness: basic-space initial stiffness (``n_basic × n_basic``).
    """

    name: str = ''
    site: str = DEFAULT_SITE
    setup: ExperimentalSetup | None = None
    actuator_names: tuple[str, ...] = ()
    initial_stiffness: np.ndarray | None = None


@dataclass
class StructuralModel:
    """The numerical model of a substructured test (on the retained, i.e. massive, DOFs).

    Attributes:
        dof_names: retained DOF names (the session's DOFs).
        linear_stiffness: condensed linear numerical stiffness (dense or CSR).
        springs: nonlinear numerical springs.
        experimental: experimental elements.
        condensed_names: DOFs removed by static condensation (massless, linear only).
    """

    dof_names: tuple[str, ...]
    linear_stiffness: np.ndarray | scipy.sparse.csr_matrix
    springs: list[NonlinearSpring] = field(default_factory=list)
    experimental: list[ExperimentalElement] = field(default_factory=list)
    condensed_names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        sites: dict[str, list[ExperimentalElement]] = {}
        for element in self.experimental:
            sites.setdefault(element.site, []).append(element)
        self.sites: dict[str, list[ExperimentalElement]] = sites
        self._has_linear = bool(_nnz(self.linear_stiffness))

    @property
    def n_dof(self) -> int:
        """Number of retained DOFs."""
        return len(self.dof_names)

    @property
    def site_names(self) -> tuple[str, ...]:
        """The sites, in order of first appearance."""
        return tuple(self.sites)

    def actuator_names(self, site: str) -> tuple[str, ...]:
        """The actuator DOF names of ``site`` (the DOF names of its commands)."""
        return tuple(name for element in self.sites[site] for name in element.actuator_names)

    def initial_stiffness(self) -> np.ndarray:
        """Dense initial stiffness: linear part + springs' and experimental elements' initial."""
        n = self.n_dof
        linear = self.linear_stiffness
        k = np.array(linear.toarray() if hasattr(linear, 'toarray') else linear, dtype=float)
        for spring in self.springs:
            b = spring.matrix(n)
            assert spring.model is not None
            k += spring.model.initial_stiffness * (b.T @ b)
        for element in self.experimental:
            if element.initial_stiffness is None:
                msg = f'experimental element {element.name!r}: initial_stiffness is required'
                raise ConfigError(msg)
            b = element.matrix(n)
            k += b.T @ element.initial_stiffness @ b
        return k

    def numerical_force(self, x: np.ndarray) -> np.ndarray:
        """Restoring force of the numerical elements at ``x``.

        The nonlinear springs take ``x`` as a *trial* from their committed state (as an
        OpenSees element does): every iteration of a step starts from the same committed
        state, and :meth:`commit` promotes the last trial when the integrator commits.
        """
        force = (self.linear_stiffness @ x) if self._has_linear else np.zeros(self.n_dof)
        force = np.asarray(force, dtype=float).reshape(-1)
        for spring in self.springs:
            value = spring.trial_force(x)
            spring.scatter(np.array([value]), force)
        return force

    def commit(self) -> None:
        """Commit the numerical springs' last trial (called when the integrator commits)."""
        for spring in self.springs:
            spring.commit()

    def site_targets(self, site: str, x: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        """Actuator targets of ``site`` at ``x``, and each element's basic target."""
        basics = [element.basic(x) for element in self.sites[site]]
        targets = []
        for element, basic in zip(self.sites[site], basics):
            setup = element.setup
            assert setup is not None  # every experimental element of a model has a setup
            targets.append(setup.actuator_targets(basic))
        return np.concatenate(targets), basics

    def add_site_feedback(self, site: str, displacement: np.ndarray, force: np.ndarray,
                          target_basics: list[np.ndarray], x: np.ndarray,
                          force_out: np.ndarray, measured_out: np.ndarray) -> None:
        """Add ``site``'s measured forces to ``force_out``; its measured DOFs to ``measured_out``.

        ``measured_out`` starts as the target; each experimental DOF is moved by the
        difference between the measured and the commanded basic displacement.
        """
        start = 0
        for element, target_basic in zip(self.sites[site], target_basics):
            setup = element.setup
            assert setup is not None
            stop = start + setup.n_actuators
            basic = setup.basic_displacement(displacement[start:stop])
            element.scatter(setup.basic_force(force[start:stop], basic), force_out)
            measured_out[element.dofs] = x[element.dofs] + (basic - target_basic)
            start = stop


def _nnz(matrix: Any) -> int:
    if hasattr(matrix, 'nnz'):
        return int(matrix.nnz)
    return int(np.count_nonzero(matrix))
