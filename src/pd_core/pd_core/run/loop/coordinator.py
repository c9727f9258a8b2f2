"""The step protocol across sites: one structure-level step, one command per site.

The :class:`SiteCoordinator` sits between the :class:`~.session.TestSession` (which sees one
structure-level command and one structure-level feedback per ``(step, iteration)``) and the
sites: :meth:`~SiteCoordinator.dispatch` turns a structure command into one command per site
(and evaluates the numerical elements), :meth:`~SiteCoordinator.on_feedback` takes each site's
answer through that site's own :class:`~.protocol.StepProtocol` and, once *every* site has
answered the pending step, returns the assembled structure feedback (measured displacements
and the total restoring force). A site answering with a limit or a fault is passed on at once
(the session holds); on resume only the sites still owing an answer get the command again.

Mixed control: a site with force-controlled actuators (an experimental element's
``control``) gets commands with ``control_mode`` and ``target_force`` (``F(t)`` of the step's
test time); its displacement-controlled actuators' strokes come from the setup at the basic
displacement made of the structure's trial on the structure DOFs and the last measured one
on the free DOFs, and a force-controlled actuator's ``target_displacement`` is its last
measured stroke (0 before the first answer). The feedback's basic displacement comes from the
measured strokes (the setup's inverse), its basic forces are ``Jᵀ f`` there, and only the
structure DOFs' forces enter the restoring force.

Without a model (a test whose whole structure is the specimen, the thesis's case) the
coordinator is a pass-through to the single default site (topics ``/pd/step_command`` and
``/pd/step_feedback``): the same command and feedback objects go through unchanged.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from pd_common.protocol import DEFAULT_SITE, Command, Feedback, FeedbackStatus, command_of

from ...errors import ProtocolError
from .protocol import StepProtocol, Verdict
from .session import SMALL_MODEL_DOF

if TYPE_CHECKING:
    from ...model.substructure import StructuralModel

__all__ = ['SiteCoordinator']


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
            targets, modes, forces, basics[site] = model.site_command(site, x,
                                                                      command.test_time)
            site_command = command_of(command.test_id, command.step, command.test_time,
                                      model.actuator_names(site), tuple(targets.tolist()),
                                      command.iteration, modes, forces)
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
        protocol.accept(feedback)  # its verdict above: ACCEPTED, nothing changed since
        pending.answers[site] = feedback
        if len(pending.answers) < len(self.sites):
            return verdict, None
        return verdict, self._assemble(pending)

    def commit(self) -> None:
        """The integrator committed the step: commit the numerical springs' last trial."""
        if self.model is not None:
            self.model.commit()

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
        if measured.size <= SMALL_MODEL_DOF:
            # Tuples of a few floats: the session checks them, the journal encodes them by
            # their shape's layout, faster than as arrays.
            return Feedback(test_id=command.test_id, step=command.step,
                            iteration=command.iteration,
                            measured_displacement=tuple(measured.tolist()),
                            restoring_force=tuple(force.tolist()))
        # Read-only arrays rather than tuples: a large model then skips two conversions of
        # every DOF per step (the session, the history and the bag take any float sequence).
        measured.setflags(write=False)
        force.setflags(write=False)
        return Feedback(test_id=command.test_id, step=command.step, iteration=command.iteration,
                        measured_displacement=measured, restoring_force=force)

    def summary(self) -> dict[str, Any]:
        """Per-site protocol counters (for ``summary.json``)."""
        return {site or 'default': {'retries': protocol.retries,
                                    'ignored_messages': protocol.ignored_total}
                for site, protocol in self.protocols.items()}
