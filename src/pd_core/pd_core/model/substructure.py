"""Substructuring: numerical elements on the computer, experimental elements at sites.

A :class:`StructuralModel` splits the restoring force of the structure into

* a linear numerical part ``K_lin x`` (springs, shear stories, beam-columns; massless DOFs
  statically condensed out),
* nonlinear numerical springs (the :mod:`pd_common.specimen` hysteresis models, the same ones
  the simulator uses),
* experimental elements, whose force is measured at a *site* (a namespace ``/pd/<site>``
  served by an actuator bridge or a specimen simulator), through an experimental setup.

The step protocol across sites (one command per site, answers gathered) is
:class:`~pd_core.run.loop.coordinator.SiteCoordinator`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from pd_common.protocol import DEFAULT_SITE, ControlMode

from ..errors import ConfigError
from ..schemes.linalg import Tridiagonal

if TYPE_CHECKING:
    import scipy.sparse

    from pd_common.specimen.hysteresis import HysteresisModel

    from .control import ActuatorControl
    from .setups import ExperimentalSetup

__all__ = [
    'ExperimentalElement',
    'NonlinearSpring',
    'StructuralModel',
]

def _distinct(index: NDArray[np.intp]) -> bool:
    """Whether no index appears twice."""
    return len(set(index.tolist())) == index.size


@dataclass
class _TwoEnded:
    """Element DOFs ``x[dofs] - x[relative]`` (a relative index of −1 means the ground)."""

    dofs: NDArray[np.intp]
    relative: NDArray[np.intp]

    def __post_init__(self) -> None:
        """Index the element's two ends once (its DOFs are fixed when it is made)."""
        relative = np.asarray(self.relative)
        linked = relative >= 0  # a basic DOF relative to another DOF (else to the ground)
        #: Where a basic DOF has another end: the mask, the other ends for ``x`` and for
        #: ``scatter`` (``None``: every basic DOF is grounded).
        self._linked: NDArray[np.bool_] | None = linked if linked.any() else None
        self._other_end = np.maximum(relative, 0)
        self._linked_dofs = relative[linked]
        # Distinct indices: ``into[i] += f`` adds each force once, as ``np.add.at`` does.
        self._distinct = (_distinct(np.asarray(self.dofs))
                          and _distinct(self._linked_dofs))

    def basic(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Basic displacements of the element."""
        values = x[self.dofs]
        if self._linked is not None:
            values = values - np.where(self._linked, x[self._other_end], 0.0)
        return values

    def scatter(self, force: np.ndarray, into: np.ndarray) -> None:
        """Add the element's basic forces to the structure force vector ``into``."""
        linked = self._linked
        if self._distinct:
            into[self.dofs] += force
            if linked is not None:
                into[self._linked_dofs] += -force[linked]
            return
        np.add.at(into, self.dofs, force)
        if linked is not None:
            np.add.at(into, self._linked_dofs, -force[linked])

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

    Basic DOFs are either *structure* DOFs (``x[dofs] − x[relative]``) or *free* ones (a
    ``null`` entry of the element's ``dofs``: a force-controlled actuator holds the element
    there, and its displacement comes from the measurement). ``dofs`` and ``relative`` hold
    the structure DOFs only; ``basic_index`` says where they are in the basic vector.

    Attributes:
        name: element name (for messages).
        site: the site serving it.
        setup: basic DOFs ↔ actuator strokes and forces.
        actuator_names: one name per actuator (the site's command DOF names).
        initial_stiffness: initial stiffness on the structure basic DOFs (the free DOFs
            statically condensed out of ``basic_stiffness``).
        basic_index: positions of the structure DOFs in the basic vector (``None``: every
            basic DOF is a structure DOF, in order).
        control: per actuator its :class:`~.control.ActuatorControl` (empty: every actuator
            displacement-controlled).
        basic_stiffness: the initial stiffness in all basic DOFs as given (``None``: the same
            as ``initial_stiffness``).
    """

    name: str = ''
    site: str = DEFAULT_SITE
    setup: ExperimentalSetup | None = None
    actuator_names: tuple[str, ...] = ()
    initial_stiffness: np.ndarray | None = None
    basic_index: NDArray[np.intp] | None = None
    control: tuple[ActuatorControl, ...] = ()
    basic_stiffness: np.ndarray | None = None

    def __post_init__(self) -> None:
        """Index the basic DOFs; nothing measured yet."""
        super().__post_init__()
        n_basic = self.setup.n_basic if self.setup is not None else int(self.dofs.size)
        n_act = self.setup.n_actuators if self.setup is not None else int(self.dofs.size)
        index = (np.arange(self.dofs.size, dtype=np.intp) if self.basic_index is None
                 else np.asarray(self.basic_index, dtype=np.intp))
        self._structural: NDArray[np.intp] = index
        self._free: NDArray[np.intp] = np.array(
            [i for i in range(n_basic) if i not in set(index.tolist())], dtype=np.intp)
        forced = [c.force_controlled for c in self.control] if self.control else []
        self._forced: NDArray[np.bool_] = np.array(forced or [False] * n_act, dtype=bool)
        self._mixed = bool(self._forced.any())
        # What the site measured last (the free DOFs' displacement, the force-controlled
        # actuators' strokes): 0 until the first answer.
        self.measured_basic: NDArray[np.float64] = np.zeros(n_basic)
        self.measured_strokes: NDArray[np.float64] = np.zeros(n_act)

    @property
    def mixed(self) -> bool:
        """Whether some actuator of the element is force-controlled."""
        return self._mixed

    @property
    def free_index(self) -> NDArray[np.intp]:
        """Positions of the free basic DOFs (measured, not commanded) in the basic vector."""
        return self._free

    @property
    def structure_index(self) -> NDArray[np.intp]:
        """Positions of the structure DOFs in the basic vector."""
        return self._structural

    def force_controlled(self) -> NDArray[np.bool_]:
        """Per actuator: whether it is force-controlled."""
        return self._forced

    def trial_basic(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The basic displacement commanded at ``x``.

        The structure's trial on its DOFs, the last measured displacement on the free DOFs.
        """
        if not self._free.size:
            return self.basic(x)
        basic = self.measured_basic.copy()
        basic[self._structural] = self.basic(x)
        return basic

    def targets(self, x: NDArray[np.float64], time: float
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Actuator strokes, target forces and the basic target at ``x`` and test ``time``.

        A force-controlled actuator's stroke is the one last measured (not imposed) and its
        target force ``F(time)``; a displacement-controlled actuator's force is 0.
        """
        setup = self.setup
        assert setup is not None  # every experimental element of a model has a setup
        basic = self.trial_basic(x)
        strokes = np.asarray(setup.actuator_targets(basic), dtype=float)
        forces = np.zeros(strokes.size)
        if self.mixed:
            strokes = np.where(self._forced, self.measured_strokes, strokes)
            forces = np.array([c.force_at(time) if c.force_controlled else 0.0
                               for c in self.control])
        return strokes, forces, basic

    def take_feedback(self, strokes: NDArray[np.float64], force: NDArray[np.float64],
                      target_basic: NDArray[np.float64], x: NDArray[np.float64],
                      force_out: NDArray[np.float64], measured_out: NDArray[np.float64]
                      ) -> None:
        """Add the measured basic forces of the structure DOFs to ``force_out``.

        Move the element's DOFs of ``measured_out`` by the measured − commanded basic displacement;
        remember the measurement (the next command's free DOFs and force-controlled strokes).
        """
        setup = self.setup
        assert setup is not None
        basic = setup.basic_displacement(strokes)
        basic_force = setup.basic_force(force, basic)
        index = self._structural
        self.scatter(basic_force[index] if self._free.size else basic_force, force_out)
        measured_out[self.dofs] = x[self.dofs] + (basic[index] - target_basic[index])
        if self.mixed:
            self.measured_basic = np.array(basic, dtype=float)
            self.measured_strokes = np.array(strokes, dtype=float)


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
        """Group the experimental elements by site; prepare the stiffness product."""
        sites: dict[str, list[ExperimentalElement]] = {}
        for element in self.experimental:
            sites.setdefault(element.site, []).append(element)
        self.sites: dict[str, list[ExperimentalElement]] = sites
        self._actuator_names = {
            site: tuple(name for element in elements for name in element.actuator_names)
            for site, elements in sites.items()}
        self._site_mixed = {site: any(element.mixed for element in elements)
                            for site, elements in sites.items()}
        self._has_linear = bool(_nnz(self.linear_stiffness))
        # A large tridiagonal CSR stiffness (a shear building) multiplies by its bands: the
        # floats of the CSR product at about half its cost.
        banded = Tridiagonal.of_csr(self.linear_stiffness)
        self._linear_product: Any = self.linear_stiffness if banded is None else banded

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
        return self._actuator_names[site]

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
        force = (self._linear_product @ x) if self._has_linear else np.zeros(self.n_dof)
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
        targets, _, _, basics = self.site_command(site, x, 0.0)
        return targets, basics

    def site_mixed(self, site: str) -> bool:
        """Whether some actuator of ``site`` is force-controlled."""
        return self._site_mixed[site]

    def site_command(self, site: str, x: np.ndarray, time: float
                     ) -> tuple[np.ndarray, tuple[int, ...], tuple[float, ...],
                                list[np.ndarray]]:
        """``site``'s command at ``x`` and test ``time``.

        Returns:
            The actuator strokes, the control modes and target forces (both empty when every
            actuator of the site is displacement-controlled: a plain command) and each
            element's basic target.
        """
        strokes, forces, basics = [], [], []
        for element in self.sites[site]:
            stroke, force, basic = element.targets(x, time)
            strokes.append(stroke)
            forces.append(force)
            basics.append(basic)
        if not self.site_mixed(site):
            return np.concatenate(strokes), (), (), basics
        modes = tuple(int(ControlMode.FORCE if forced else ControlMode.DISPLACEMENT)
                      for element in self.sites[site] for forced in element.force_controlled())
        return (np.concatenate(strokes), modes,
                tuple(float(f) for f in np.concatenate(forces)), basics)

    def add_site_feedback(self, site: str, displacement: np.ndarray, force: np.ndarray,
                          target_basics: list[np.ndarray], x: np.ndarray,
                          force_out: np.ndarray, measured_out: np.ndarray) -> None:
        """Add ``site``'s measured forces to ``force_out``; its measured DOFs to ``measured_out``.

        ``measured_out`` starts as the target; each experimental DOF is moved by the
        difference between the measured and the commanded basic displacement. Free basic DOFs
        (held by force-controlled actuators) only enter the next command.
        """
        start = 0
        for element, target_basic in zip(self.sites[site], target_basics):
            setup = element.setup
            assert setup is not None
            stop = start + setup.n_actuators
            element.take_feedback(displacement[start:stop], force[start:stop], target_basic,
                                  x, force_out, measured_out)
            start = stop


def _nnz(matrix: Any) -> int:
    if hasattr(matrix, 'nnz'):
        return int(matrix.nnz)
    return int(np.count_nonzero(matrix))
