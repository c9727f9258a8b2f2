"""Holds a person made, which only a person clears: the emergency stop and the operator's hold.

The bridge and the integrator each keep one :class:`PersonHolds`. It is *durable*: every change
is an event in the node's record (the integrator's journal, the bridge's record file), written
before the node answers anything else, and a restarted node replays those events
(:meth:`PersonHolds.apply`) before it answers anything. So a crash, a restart or the supervisor
never clears a stop: only a person's signed control does.

* :meth:`~PersonHolds.emergency_stop` latches an emergency stop (open to anyone); only
  ``reset_emergency_stop`` (a bridge) or ``resume`` (the integrator) clears it;
* :meth:`~PersonHolds.operator_hold` latches a person's ``pause`` or ``hold``; a person's
  ``resume`` (the integrator) or ``reset`` (a bridge) clears it;
* :attr:`~PersonHolds.blocks_automatic` is why an automatic action (the supervisor's
  ``auto_resume`` or ``auto_reset``) is refused.

Events are plain mappings ``{'what': ..., ...}`` (JSON in both records).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from .bounds import clip_reason

__all__ = ['PersonHolds']

EMERGENCY_STOP = 'emergency_stop'
OPERATOR_HOLD = 'operator_hold'
CLEARED = 'holds_cleared'


@dataclass
class PersonHolds:
    """The latched emergency stop and operator hold (``None``: not latched).

    Attributes:
        emergency: the latched emergency stop's reason.
        operator: the person's hold, e.g. ``'paused by operator ana@rig (pd control)'``.
        repeats: emergency stops received while one was latched (counted, not recorded).
    """

    emergency: str | None = None
    operator: str | None = None
    repeats: int = 0

    @property
    def blocks_automatic(self) -> str | None:
        """Why an automatic action may not clear the hold (``None``: nothing a person holds)."""
        if self.emergency is not None:
            return f'emergency stop latched ({self.emergency})'
        if self.operator is not None:
            return self.operator
        return None

    def emergency_stop(self, reason: str) -> dict[str, Any] | None:
        """Latch an emergency stop.

        The event to record, or ``None`` when one was latched already (the repeat is counted).
        """
        if self.emergency is not None:
            self.repeats += 1
            return None
        self.emergency = clip_reason(reason) or 'no reason given'
        return {'what': EMERGENCY_STOP, 'reason': self.emergency}

    def operator_hold(self, what: str) -> dict[str, Any]:
        """Latch a person's hold (``what``: e.g. ``'paused by <sender>'``); its event."""
        self.operator = clip_reason(what)
        return {'what': OPERATOR_HOLD, 'reason': self.operator}

    def clear(self, *, emergency: bool, by: str) -> dict[str, Any] | None:
        """Clear the operator's hold (and the emergency stop with ``emergency``).

        The event, or ``None`` when nothing was latched.
        """
        if self.operator is None and (self.emergency is None or not emergency):
            return None
        self.operator = None
        if emergency:
            self.emergency = None
        return {'what': CLEARED, 'emergency': emergency, 'by': clip_reason(by)}

    def apply(self, event: Mapping[str, Any]) -> None:
        """Replay one recorded event (others are ignored)."""
        what = event.get('what')
        if what == EMERGENCY_STOP:
            self.emergency = str(event.get('reason') or 'no reason given')
        elif what == OPERATOR_HOLD:
            self.operator = str(event.get('reason') or 'held by operator')
        elif what == CLEARED:
            self.operator = None
            if event.get('emergency'):
                self.emergency = None

    @classmethod
    def replay(cls, events: Iterable[Mapping[str, Any]]) -> PersonHolds:
        """The holds a record's events leave latched."""
        holds = cls()
        for event in events:
            holds.apply(event)
        return holds
