"""Substructuring: numerical elements on the computer, experimental elements at sites.

A :class:`StructuralModel` splits the restoring force of the structure into

* a linear numerical part ``K_lin x`` (springs, shear stories, beam-columns; massless DOFs
  statically condensed out),
* nonlinear numerical springs (the ``pd_specimen_sim`` hysteresis models, driven exactly as the
  simulator drives them: one trial + commit per new ``(step, iteration)``),
* experimental elements, whose force is measured at a *site* (a namespace ``/pd/<site>``
  served by an actuator bridge or a specimen simulator), through an experimental setup.

The :class:`SiteCoordinator` sits between the :class:`~.session.TestSession` (which sees one
structure-level command and one structure-level feedback per ``(step, iteration)``) and the
sites: :meth:`~SiteCoordinator.dispatch` turns a structure command into one command per site
(and evaluates the numerical elements), :meth:`~SiteCoordinator.on_feedback` takes each site's
answer through that site's own :class:`~.protocol.StepProtocol` and, once *every* site has
answered the pending step, returns the assembled structure feedback (measured displacements
and the total restoring force). A site answering with a limit or a fault is passed on at once
(the session holds); on resume only the sites still owing an answer get the command again.

Without a model (a test whose whole structure is the specimen, the thesis's case) the
coordinator is a pass-through to the single default site (topics ``/pd/step_command`` and
``/pd/step_feedback``): the same command and feedback objects go through unchanged.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import ConfigError, ProtocolError
from pd_common.protocol import DEFAULT_SITE, Command, Feedback, FeedbackStatus
from .protocol import StepProtocol, Verdict

if TYPE_CHECKING:
    import scipy.sparse

    from pd_common.specimen.hysteresis import HysteresisModel

    from .setups import ExperimentalSetup

__all__ = [
    'DEFAULT_SITE',
    'ExperimentalElement',
    'NonlinearSpring',
    'SiteCoordinator',
    'StructuralModel',
]

@dataclass
class _TwoEnded:
    """Element DOFs ``x[dofs] - x[relative]`` (a relative index of −1 means the ground)."""

    dofs: np.ndarray
    relative: np.ndarray

    def basic(self, x: np.ndarray) -> np.ndarray:
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

    def force(self, x: np.ndarray) -> float:
        """Drive the spring to the element deformation of ``x``; commit; return its force."""
        assert self.model is not None
        value = self.model.set_trial_displacement(float(self.basic(x)[0]))
        self.model.commit()
        return value


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
        """Restoring force of the numerical elements at ``x`` (springs are committed)."""
        force = (self.linear_stiffness @ x) if self._has_linear else np.zeros(self.n_dof)
        force = np.asarray(force, dtype=float).reshape(-1)
        for spring in self.springs:
            value = spring.force(x)
            spring.scatter(np.array([value]), force)
        return force

    def site_targets(self, site: str, x: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        """Actuator targets of ``site`` at ``x``, and each element's basic target."""
        basics = [element.basic(x) for element in self.sites[site]]
        targets = [element.setup.actuator_targets(basic)  # type: ignore[union-attr]
                   for element, basic in zip(self.sites[site], basics)]
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


@dataclass
class _Pending:
    """The structure-level command being served, and what the sites answered so far."""

    command: Command
    x: np.ndarray
    numerical: np.ndarray
    site_commands: dict[str, Command]
    basics: dict[str, list[np.ndarray]]
    answers: dict[str, Feedback] = field(default_factory=dict)


class SiteCoordinator:
    """Fans a structure-level step out to the sites and gathers their answers.

    Args:
        model: the substructured model, or ``None`` for a pass-through to the default site.
        max_retries: re-sends allowed per site (the session owns the timeout policy).
    """

    def __init__(self, model: StructuralModel | None, max_retries: int = 3) -> None:
        # A private copy: the numerical springs' states belong to this run only.
        self.model = copy.deepcopy(model)
        self.sites: tuple[str, ...] = (model.site_names if model is not None
                                       else (DEFAULT_SITE,))
        self.protocols = {site: StepProtocol(max_retries=max_retries) for site in self.sites}
        self._pending: _Pending | None = None

    @property
    def passthrough(self) -> bool:
        """Whether commands and feedback go through unchanged (no model)."""
        return self.model is None

    @property
    def ignored_total(self) -> int:
        """Site feedback ignored (stale, duplicate, foreign, unexpected) over all sites."""
        return sum(protocol.ignored_total for protocol in self.protocols.values())

    def dispatch(self, command: Command) -> list[tuple[str, Command]]:
        """The site commands of a new structure-level command (numerical elements evaluated)."""
        model = self.model
        if model is None:
            return [(DEFAULT_SITE, command)]
        x = np.array(command.target_displacement, dtype=float)
        numerical = model.numerical_force(x)
        site_commands: dict[str, Command] = {}
        basics: dict[str, list[np.ndarray]] = {}
        for site in self.sites:
            targets, basics[site] = model.site_targets(site, x)
            site_command = Command(test_id=command.test_id, step=command.step,
                                   test_time=command.test_time,
                                   dof_names=model.actuator_names(site),
                                   target_displacement=tuple(targets.tolist()),
                                   iteration=command.iteration)
            protocol = self.protocols[site]
            protocol.pending = None  # a new structure step supersedes anything still owed
            protocol.send(site_command)
            site_commands[site] = site_command
        self._pending = _Pending(command=command, x=x, numerical=numerical,
                                 site_commands=site_commands, basics=basics)
        return list(site_commands.items())

    def resend(self, command: Command) -> list[tuple[str, Command]]:
        """The site commands still owed an (OK) answer, to send again."""
        if self.model is None:
            return [(DEFAULT_SITE, command)]
        pending = self._pending
        if pending is None or pending.command.key != command.key:
            return self.dispatch(command)
        out = []
        for site, site_command in pending.site_commands.items():
            if site not in pending.answers:
                self.protocols[site].retries += 1
                out.append((site, site_command))
        return out

    def on_feedback(self, site: str, feedback: Feedback) -> tuple[Verdict, Feedback | None]:
        """Take one site's answer.

        Returns:
            The site-level verdict and, when the step is complete (or a site refused it), the
            structure-level feedback for the session. In pass-through mode the feedback is
            returned unchanged for the session to classify.
        """
        if self.model is None:
            return Verdict.ACCEPTED, feedback
        protocol = self.protocols.get(site)
        pending = self._pending
        if protocol is None or pending is None:
            return Verdict.UNEXPECTED, None
        verdict = protocol.verdict(feedback)
        if verdict is not Verdict.ACCEPTED:
            protocol.ignore(verdict)
            return verdict, None
        command = pending.command
        if feedback.status is not FeedbackStatus.OK:
            # The step stays owed by this site: hold now, re-send to it on resume.
            return Verdict.REFUSED, Feedback(
                test_id=command.test_id, step=command.step, iteration=command.iteration,
                measured_displacement=command.target_displacement,
                restoring_force=tuple(pending.numerical.tolist()), status=feedback.status,
                message=f'site {site}: {feedback.message or "no reason given"}')
        expected = len(pending.site_commands[site].target_displacement)
        if (len(feedback.restoring_force) != expected
                or len(feedback.measured_displacement) != expected):
            return Verdict.REFUSED, Feedback(
                test_id=command.test_id, step=command.step, iteration=command.iteration,
                measured_displacement=command.target_displacement,
                restoring_force=tuple(pending.numerical.tolist()),
                status=FeedbackStatus.FAULT,
                message=f'site {site}: {len(feedback.restoring_force)} forces and '
                        f'{len(feedback.measured_displacement)} displacements for '
                        f'{expected} actuators')
        protocol.classify(feedback)
        pending.answers[site] = feedback
        if len(pending.answers) < len(self.sites):
            return verdict, None
        return verdict, self._assemble(pending)

    def complete(self) -> Feedback:
        """The structure feedback of the pending step when no site takes part in it.

        Raises:
            ProtocolError: nothing is pending, or sites still owe answers.
        """
        pending = self._pending
        if pending is None or len(pending.answers) < len(pending.site_commands):
            msg = 'no step is pending, or sites still owe their answers'
            raise ProtocolError(msg)
        return self._assemble(pending)

    def _assemble(self, pending: _Pending) -> Feedback:
        model = self.model
        assert model is not None
        force = pending.numerical.copy()
        measured = pending.x.copy()
        for site, answer in pending.answers.items():
            model.add_site_feedback(site, np.array(answer.measured_displacement),
                                    np.array(answer.restoring_force), pending.basics[site],
                                    pending.x, force, measured)
        command = pending.command
        self._pending = None
        # Read-only arrays rather than tuples: a large model then skips two conversions of
        # every DOF per step (the session, the history and the bag take any float sequence).
        measured.setflags(write=False)
        force.setflags(write=False)
        return Feedback(test_id=command.test_id, step=command.step, iteration=command.iteration,
                        measured_displacement=measured,  # type: ignore[arg-type]
                        restoring_force=force)  # type: ignore[arg-type]

    def summary(self) -> dict[str, Any]:
        """Per-site protocol counters (for ``summary.json``)."""
        return {site or 'default': {'retries': protocol.retries,
                                    'ignored_messages': protocol.ignored_total}
                for site, protocol in self.protocols.items()}
