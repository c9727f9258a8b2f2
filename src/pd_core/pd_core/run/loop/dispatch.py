"""The step loop between a session and its sites, shared by the node and the ROS-free runner.

:class:`StepDispatcher` owns the order of things for one test: take the session's next
structure-level command, fan it out to the sites (:class:`~.substructure.SiteCoordinator`,
numerical elements evaluated on the way), *send* the site commands (a callable: the node
signs them, the ROS-free runner queues them for a specimen), take each site's feedback, hand
the assembled feedback to the session, and record everything in the journal: a step's answer
and the commands that follow it go to the operating system in one write *before* the commands
leave (``deliver``: the node publishes them then), so the record never lags what a specimen
was sent.

Bag streams: a test without substructures records ``/pd/step_command`` and
``/pd/step_feedback`` exactly as before; a substructured test records each site's stream
(``/pd/<site>/...``) and the structure-level stream (``/pd/structure/...``) that the replay
re-runs through the session.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, NamedTuple

from pd_common.protocol import (
    Command,
    Feedback,
    Signature,
    StateOrigin,
    Status,
    TestState,
    site_topic_name,
)

from ..record.bag import TOPIC_STRUCTURE_COMMAND, TOPIC_STRUCTURE_FEEDBACK
from .coordinator import SiteCoordinator
from .epochs import EpochGuard
from .protocol import Verdict

if TYPE_CHECKING:
    from ..record.journal import RunRecorder
    from .session import TestSession

__all__ = ['DeliverFunction', 'SendFunction', 'Sent', 'StepDispatcher', 'refuse_fresh_state']

class Sent(NamedTuple):
    """A command as it goes out: its signature and its bytes (the journal keeps them)."""

    signature: Signature
    data: bytes


SendFunction = Callable[[str, Command], Sent | Signature | None]
"""``send(site, command)``: hand over a site command (sign it, queue it for a specimen);
returns what it goes out as (:class:`Sent`), or its signature (``None``: unsigned), which the
record keeps with the command. A sender that transmits at once sends before the record is
written; one that transmits given ``deliver`` (the node), or from a queue served after the
dispatcher returns (the ROS-free runner), sends after it."""

DeliverFunction = Callable[[str, Sent], None]
"""``deliver(site, sent)``: transmit a command as :class:`Sent` returned by ``send`` (its
bytes), once its record (and the answer before it) is with the operating system."""

#: One item of a batch: a structure command and its site commands, or the feedback of a step
#: completed at once (a fully numerical model: no site commands).
_BatchItem = tuple[Command | Feedback, list[tuple[str, Command]]]


class StepDispatcher:
    """Drives a :class:`~.session.TestSession` through its sites.

    Args:
        session: the test.
        send: hands over one site command (signs or queues it; see :data:`SendFunction`).
        bag: where commands and feedback are recorded (``None``: not recorded): the run's
            journal, written to the operating system once a step, before its commands leave.
        clock: time stamps for the bag [ns].
        deliver: transmits what ``send`` returned as :class:`Sent`, after the record is
            written (``None``: ``send`` transmits, or queues).
    """

    def __init__(self, session: TestSession, send: SendFunction,
                 bag: RunRecorder | None = None,
                 clock: Callable[[], int] = time.time_ns, *,
                 deliver: DeliverFunction | None = None) -> None:
        self.session = session
        self.coordinator = SiteCoordinator(session.definition.model,
                                           session.definition.protocol.max_retries)
        self.send = send
        self.deliver = deliver
        self.bag = bag
        self._clock = clock
        #: When the commands being sent left [ns]: their record's time stamp (see _send_batch).
        self.send_stamp_ns = 0
        self.epochs = EpochGuard()
        self._epochs_noted = 0
        self._topics = {site: (site_topic_name(site, 'step_command'),
                               site_topic_name(site, 'step_feedback'))
                        for site in self.coordinator.sites}

    @property
    def sites(self) -> tuple[str, ...]:
        """The site names ('' for the single default site of an unstructured test)."""
        return self.coordinator.sites

    def status(self) -> Status:
        """The session's status, counting the feedback ignored at the sites too."""
        status = self.session.status()
        ignored = self.coordinator.ignored_total
        if not ignored:
            return status
        return Status(test_id=status.test_id, state=status.state, step=status.step,
                      total_steps=status.total_steps, omega_dt=status.omega_dt,
                      retries=status.retries,
                      ignored_messages=status.ignored_messages + ignored,
                      message=status.message)

    @contextlib.contextmanager
    def replaying(self, capture: Callable[[str, Command], None]) -> Iterator[None]:
        """Nothing leaves and nothing is recorded while the loop replays a record.

        ``send``, ``deliver`` and the bag are set aside (the site commands the loop computes go
        to ``capture``) and given back afterwards, whatever happened.
        """
        outlets = self.send, self.deliver, self.bag
        self.send, self.deliver, self.bag = capture, None, None
        try:
            yield
        finally:
            self.send, self.deliver, self.bag = outlets

    # -- commands -----------------------------------------------------------------------------
    def start(self) -> None:
        """Send the first command(s)."""
        self._flush(self._next_batch())

    def on_feedback(self, site: str, feedback: Feedback,
                    signature: Signature | None = None, stamp_ns: int | None = None,
                    data: bytes | None = None) -> Verdict:
        """One site's feedback: advance the test if the step is complete; send what follows.

        ``stamp_ns``: the feedback's header stamp (recorded with it: its signature covers it);
        ``data``: its bytes as they arrived (recorded as they are), if it came as bytes.
        """
        received = self._clock()
        # (no epoch: nothing to check, as EpochGuard.check finds)
        reason = self.epochs.check(site, feedback) if feedback.epoch else None
        if reason is not None:  # a fresh specimen replaced the one the test drove
            refuse_fresh_state(self.session, reason)
            self._record_feedback(site, feedback, received, signature, stamp_ns, data)
            self._note_epochs()
            if self.bag is not None:
                self.bag.flush()
            return Verdict.REFUSED
        if self.epochs.changes and len(self.epochs.changes) != self._epochs_noted:
            self._note_epochs()
        passthrough = self.coordinator.passthrough  # (the model is fixed)
        if not passthrough and not self.session.accepting:
            # Holding, paused or finished: the site's answer is not taken (as the session
            # itself does); the held step is re-sent to every site on resume.
            self.session.protocol.ignore(Verdict.UNEXPECTED)
            self._record_feedback(site, feedback, received, signature, stamp_ns, data)
            return Verdict.UNEXPECTED
        verdict, assembled = self.coordinator.on_feedback(site, feedback)
        if assembled is not None:
            session_verdict = self._deliver(assembled)
            if passthrough:
                verdict = session_verdict
        batch = self._next_batch()
        self._record_feedback(site, feedback, received, signature, stamp_ns, data)
        if assembled is not None and not passthrough:
            self._record(TOPIC_STRUCTURE_FEEDBACK, assembled, received)
        # The answer and the next commands go to the OS in one write before the commands leave
        # (one fsync per step at most): a crash may leave a command recorded and not sent,
        # which a resumed run re-sends as owed, never one sent and not recorded.
        self._flush(batch)
        return verdict

    def on_timeout(self) -> bool:
        """The pending step's feedback is late: re-send to the sites still owing it, or hold.

        Returns:
            Whether something was re-sent.
        """
        command = self.session.on_timeout()
        if command is None:
            return False
        self._flush([(command, self.coordinator.resend(command))])
        return True

    def resume(self) -> None:
        """Leave HOLDING/PAUSED: re-send what is owed, or go on with the next step."""
        command = self.session.resume()
        if command is not None:
            self._flush([(command, self.coordinator.resend(command))])
        else:
            self.start()

    def on_offer(self, site: str, epoch: str, origin: StateOrigin) -> str | None:
        """A site announces its specimen state (its session offer).

        A fresh state that replaced the test's specimen holds the test before any answer of it is
        taken; ``None`` if the state may be driven, else why not.
        """
        noted = len(self.epochs.changes)
        reason = self.epochs.check_state(site, epoch, origin, self.session.committed_step + 1,
                                         announced=True)
        if reason is not None and len(self.epochs.changes) != noted:
            if self.session.state in (TestState.RUNNING, TestState.HOLDING, TestState.PAUSED):
                self.session.hold(reason)
                self.session.message = reason
            self._note_epochs()
            if self.bag is not None:
                self.bag.flush()
        elif len(self.epochs.changes) != self._epochs_noted:
            self._note_epochs()
        return reason

    # -- internals ----------------------------------------------------------------------------
    def _note_epochs(self) -> None:
        """Record the epoch changes not recorded yet (a site's process restarted)."""
        for change in self.epochs.changes[self._epochs_noted:]:
            if self.bag is not None:
                self.bag.write_event('epoch_change', self._clock(), **change.as_dict())
        self._epochs_noted = len(self.epochs.changes)

    def _deliver(self, feedback: Feedback) -> Verdict:
        """Hand structure feedback to the session; commit the numerical model with it."""
        committed = self.session.history.n_committed
        verdict = self.session.on_feedback(feedback)
        if self.session.history.n_committed != committed:
            self.coordinator.commit()
        return verdict

    def _next_batch(self) -> list[_BatchItem]:
        """The next command(s); steps without any site are completed at once."""
        batch: list[_BatchItem] = []
        session = self.session
        while (command := session.next_command()) is not None:
            site_commands = self.coordinator.dispatch(command)
            batch.append((command, site_commands))
            if site_commands:
                break
            # A fully numerical model: nothing to wait for.
            feedback = self.coordinator.complete()
            batch.append((feedback, []))
            self._deliver(feedback)
            if session.state is not TestState.RUNNING:
                break
        return batch

    def _send_batch(self, batch: list[_BatchItem]) -> list[tuple[str, Sent | Signature | None]]:
        """Hand over the batch's site commands; their sites and what each goes out as.

        They are recorded at :attr:`send_stamp_ns`, taken before the first is handed over: a
        sender that stamps its messages stamps them with it (the integrator), so the record
        holds the bytes that go out.
        """
        self.send_stamp_ns = self._clock()
        return [(site, self.send(site, site_command))
                for _, site_commands in batch for site, site_command in site_commands]

    def _flush(self, batch: list[_BatchItem]) -> None:
        """Hand over the batch's commands, record them, write the record, then deliver them.

        A record that cannot be written raises before anything is delivered: nothing moves
        that the journal does not hold.
        """
        went = self._send_batch(batch)
        self._record_batch(batch, went)
        if self.bag is not None:
            self.bag.flush()
        if self.deliver is not None:
            for site, sent in went:
                if not isinstance(sent, Sent):  # (a sender's bug: nothing to transmit)
                    msg = f'{site or "the site"}: send returned no bytes (Sent) to deliver'
                    raise TypeError(msg)
                self.deliver(site, sent)

    def _record_batch(self, batch: list[_BatchItem],
                      went: list[tuple[str, Sent | Signature | None]]) -> None:
        if self.bag is None:
            return
        t_ns = self.send_stamp_ns
        passthrough = self.coordinator.passthrough
        sent = iter(went)
        for item, site_commands in batch:
            if isinstance(item, Feedback):
                self._record(TOPIC_STRUCTURE_FEEDBACK, item, t_ns)
                continue
            if not passthrough:
                self._record(TOPIC_STRUCTURE_COMMAND, item, t_ns)
            for site, site_command in site_commands:
                _, out = next(sent)  # (in the batch's order: the same site)
                if isinstance(out, Sent):
                    self._record(self._topics[site][0], site_command, t_ns, out.signature,
                                 data=out.data)
                else:
                    self._record(self._topics[site][0], site_command, t_ns, out)

    def _record_feedback(self, site: str, feedback: Feedback, t_ns: int,
                         signature: Signature | None, stamp_ns: int | None,
                         data: bytes | None = None) -> None:
        topics = self._topics.get(site)
        if topics is not None:
            self._record(topics[1], feedback, t_ns, signature, stamp_ns, data)

    def _record(self, topic: str, item: Command | Feedback, t_ns: int,
                signature: Signature | None = None, stamp_ns: int | None = None,
                data: bytes | None = None) -> None:
        if self.bag is None:
            return
        if isinstance(item, Command):
            self.bag.write_command(item, t_ns, topic, signature, data=data)
        else:
            self.bag.write_feedback(item, t_ns, topic, signature, stamp_ns, data)


def refuse_fresh_state(session: TestSession, reason: str) -> None:
    """A site answered from a fresh specimen state: not taken, and the test holds."""
    session.protocol.ignore(Verdict.REFUSED)
    session.hold(reason)
    if session.state is TestState.HOLDING:
        session.message = reason
