"""Honest state across restarts: whose specimen state answers, and whether it may.

Every feedback carries the *epoch* of the specimen state that produced it (a random id drawn
when a simulator, or a bridge without a simulator behind it, starts) and that state's
*origin* (:class:`~pd_common.protocol.StateOrigin`):

* ``FRESH`` — a process that started without any history: a new, virgin specimen;
* ``RESTORED`` — a simulator that replayed its state file (the same specimen, restored);
* ``HARDWARE`` — the actuator's and specimen's own physical state, read from the controller.

The first epoch a site answers with is the test's. When it changes, the process behind the site
restarted: a ``RESTORED`` or ``HARDWARE`` state is the same specimen and is taken (the change
is recorded), but a ``FRESH`` one is a *different* specimen — continuing would silently give a
different history — so its answers are refused and the test holds until the site comes back
with its state (or the operator aborts). Feedback without an epoch (records older than
epochs) is not checked.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from pd_common.protocol import Feedback, StateOrigin

__all__ = ['EpochChange', 'EpochGuard']


@dataclass(frozen=True)
class EpochChange:
    """A site's specimen state changed epoch (its process restarted)."""

    site: str
    step: int
    old: str
    new: str
    origin: StateOrigin
    accepted: bool

    def as_dict(self) -> dict[str, Any]:
        """For the run's events and summary."""
        return {'site': self.site or 'default', 'step': self.step, 'old_epoch': self.old,
                'new_epoch': self.new, 'origin': self.origin.name.lower(),
                'accepted': self.accepted}


@dataclass
class EpochGuard:
    """Tracks each site's epoch; refuses answers of a fresh state that replaced it.

    Attributes:
        epochs: the accepted epoch per site.
        changes: every change seen (accepted or refused), in order.
    """

    epochs: dict[str, str] = field(default_factory=dict)
    changes: list[EpochChange] = field(default_factory=list)
    _refused: set[tuple[str, str]] = field(default_factory=set)
    _accepted: set[tuple[str, str]] = field(default_factory=set)

    def check(self, site: str, feedback: Feedback) -> str | None:
        """``None`` if ``feedback`` may be taken, else why not (the test must hold).

        A refused epoch stays refused (its every answer), and is recorded once.
        """
        return self.check_state(site, feedback.epoch, feedback.state_origin, feedback.step)

    def check_state(self, site: str, epoch: str, origin: StateOrigin, step: int, *,
                    announced: bool = False) -> str | None:
        """:meth:`check` of a state a site answers from.

        Or (``announced``) one its session offer announces — an offer may lag behind the answers,
        so an epoch this site already answered from is not a change.
        """
        if not epoch:
            return None
        known = self.epochs.get(site)
        if known is None:
            self.epochs[site] = epoch
            self._accepted.add((site, epoch))
            return None
        if epoch == known or (announced and (site, epoch) in self._accepted):
            return None
        name = site or 'default'
        if origin is StateOrigin.FRESH:
            if (site, epoch) not in self._refused:
                self._refused.add((site, epoch))
                self.changes.append(EpochChange(site, step, known, epoch, origin,
                                                accepted=False))
            return (f'site {name}: answered from a fresh specimen state (epoch {epoch}; it was '
                    f'{known}): its process restarted without its state, a different specimen'
                    '; refusing its answers — restart it with its state (state_file) or abort')
        self.epochs[site] = epoch
        self._accepted.add((site, epoch))
        self.changes.append(EpochChange(site, step, known, epoch, origin, accepted=True))
        return None

    @property
    def accepted_changes(self) -> list[EpochChange]:
        """The restarts taken (a restored or hardware state)."""
        return [change for change in self.changes if change.accepted]
