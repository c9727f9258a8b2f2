"""Fault injection for the step protocol: a plan and a deterministic injector (pure, no ROS).

The fault proxy (:mod:`pd_bringup.fault_proxy`) sits between a sender of step commands (the
integrator) and a receiver (a simulator or a bridge) and passes every step message through a
:class:`FaultInjector`, one per direction. For each message the injector draws, from its own
``random.Random`` seeded by the plan's seed and the direction, exactly one fate:

* **forward** it now;
* **drop** it (probability ``drop``);
* **duplicate** it: forward it twice, back to back (``duplicate``);
* **delay** it: hold it until ``t + d``, ``d`` uniform in ``(0, delay_s]`` (``delay``); later
  messages may overtake it;
* **reorder** it: hold it until the next message of the same direction has been handled, and
  send it right after that one (``reorder``); if no other message comes within ``delay_s`` it is
  released then (a stop-and-wait protocol sends nothing new until it hears back).

The fates are exclusive (one uniform draw per message), so each kind happens with exactly its
probability and the probabilities may add up to 1 at most. Two draws are made per message
whatever its fate, so the n-th message of a direction always meets the same fate for a seed.

The injector does not know what it carries (the proxy hands it the serialized bytes): messages
are passed on as they came, signatures and all. It keeps no clock of its own: the caller gives
the time (``time.monotonic()`` in the node, a fake clock in tests).
"""

from __future__ import annotations

import heapq
import itertools
import math
import random
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any, Generic, TypeVar

from pd_common.resources import find_executable

from .reports import add_to_summary, read_reports

__all__ = ['COUNTERS', 'DEFAULT_DELAY_S', 'FAULT_KINDS', 'Fate', 'FaultInjector', 'FaultPlan',
           'FaultPlanError', 'attach_reports', 'fault_summary', 'proxy_command']

#: The fault kinds a plan gives a probability for (in the order of the fates' intervals).
FAULT_KINDS = ('drop', 'duplicate', 'delay', 'reorder')
#: Default largest delay of a delayed message (and longest hold of a reordered one), s.
DEFAULT_DELAY_S = 0.05
#: The counters of one direction (see :attr:`FaultInjector.counts`).
COUNTERS = ('received', 'forwarded', 'dropped', 'duplicated', 'delayed', 'reordered',
            'reorder_swapped', 'reorder_released', 'reorder_expired')

_ITEMS = (*FAULT_KINDS, 'delay_s', 'seed')
_NO_FAULTS = ('', 'none')

T = TypeVar('T')


class FaultPlanError(ValueError):
    """A fault plan is malformed or out of range (the message is one line)."""


@dataclass(frozen=True)
class FaultPlan:
    """What to do to the step messages: a probability per fault kind, a delay, a seed.

    Attributes:
        drop: probability that a message is dropped.
        duplicate: probability that a message is forwarded twice.
        delay: probability that a message is held for up to ``delay_s``.
        reorder: probability that a message is held until the next one has passed.
        delay_s: largest delay, and longest hold of a reordered message, s (> 0).
        seed: seed of the injectors' random generators (a non-negative integer).

    Raises:
        FaultPlanError: a probability outside [0, 1], probabilities adding up to more than 1,
            a non-positive or non-finite ``delay_s``, or a negative seed.
    """

    drop: float = 0.0
    duplicate: float = 0.0
    delay: float = 0.0
    reorder: float = 0.0
    delay_s: float = DEFAULT_DELAY_S
    seed: int = 0

    def __post_init__(self) -> None:
        """Check every probability and their sum."""
        for name in _ITEMS:
            problem = _problem(name, getattr(self, name))
            if problem:
                msg = f'fault plan: {name}={getattr(self, name)!r}: {problem}'
                raise FaultPlanError(msg)
        if self.total > 1.0 + 1e-12:
            msg = f'fault plan: {_sum_problem(self.total)}'
            raise FaultPlanError(msg)

    @property
    def total(self) -> float:
        """Probability that a message suffers any fault."""
        return self.drop + self.duplicate + self.delay + self.reorder

    @property
    def transparent(self) -> bool:
        """Whether nothing is ever done to a message."""
        return self.total == 0.0

    @classmethod
    def parse(cls, text: str) -> FaultPlan:
        """A plan from ``'drop=0.1,duplicate=0.1,delay=0.1,reorder=0.1,seed=7,delay_s=0.05'``.

        Items are ``name=value`` separated by commas (spaces allowed); names not given keep
        their defaults; ``''`` or ``'none'`` is the plan without faults.

        Raises:
            FaultPlanError: an item is malformed, unknown, repeated or out of range (the
                one-line message names it), or the probabilities add up to more than 1.
        """
        if text.strip().lower() in _NO_FAULTS:
            return cls()
        values: dict[str, float] = {}
        seed = 0
        for raw in text.split(','):
            item = raw.strip()
            name, sep, value = (part.strip() for part in item.partition('='))
            if not item:
                msg = f'fault plan {text!r}: an empty item (two commas, or a trailing comma?)'
                raise FaultPlanError(msg)
            if not sep or not name or not value:
                msg = f'fault plan: item {item!r}: expected name=value'
                raise FaultPlanError(msg)
            if name not in _ITEMS:
                msg = f'fault plan: item {item!r}: unknown name {name!r} ({", ".join(_ITEMS)})'
                raise FaultPlanError(msg)
            if name in values:
                msg = f'fault plan: item {item!r}: {name} is given twice'
                raise FaultPlanError(msg)
            number: float | int
            try:
                number = int(value) if name == 'seed' else float(value)
            except ValueError:
                what = 'an integer' if name == 'seed' else 'a number'
                msg = f'fault plan: item {item!r}: {value!r} is not {what}'
                raise FaultPlanError(msg) from None
            problem = _problem(name, number)
            if problem:
                msg = f'fault plan: item {item!r}: {problem}'
                raise FaultPlanError(msg)
            values[name] = float(number)
            if name == 'seed':
                seed = int(number)
        total = sum(values.get(kind, 0.0) for kind in FAULT_KINDS)
        if total > 1.0 + 1e-12:
            msg = f'fault plan {text!r}: {_sum_problem(total)}'
            raise FaultPlanError(msg)
        return cls(drop=values.get('drop', 0.0), duplicate=values.get('duplicate', 0.0),
                   delay=values.get('delay', 0.0), reorder=values.get('reorder', 0.0),
                   delay_s=values.get('delay_s', DEFAULT_DELAY_S), seed=seed)

    def __str__(self) -> str:
        """The plan as :meth:`parse` reads it (every item, canonical order)."""
        items = [f'{name}={_number(getattr(self, name))}' for name in (*FAULT_KINDS, 'delay_s')]
        return ','.join([*items, f'seed={self.seed}'])

    def as_dict(self) -> dict[str, float | int]:
        """The plan's fields (for a JSON report)."""
        return {name: getattr(self, name) for name in _ITEMS}


def _problem(name: str, value: object) -> str:
    """What is wrong with ``value`` for the plan item ``name`` ('' if nothing)."""
    if name == 'seed':
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            return 'the seed must be a non-negative integer'
        return ''
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(
            value):
        return 'must be a finite number'
    if name == 'delay_s':
        return '' if value > 0.0 else 'the largest delay must be positive (seconds)'
    return '' if 0.0 <= value <= 1.0 else 'a probability must be in [0, 1]'


def _number(value: float) -> str:
    """``value`` short (``0.1``, ``1``), but exact: it reads back as the same float."""
    short = format(value, 'g')
    return short if float(short) == value else repr(float(value))


def _sum_problem(total: float) -> str:
    return (f'the probabilities add up to {total:g}, more than 1 (drop, duplicate, delay and '
            'reorder exclude each other: each message suffers one fault at most)')


class Fate(Enum):
    """What happens to one message."""

    FORWARD = 'forward'
    DROP = 'drop'
    DUPLICATE = 'duplicate'
    DELAY = 'delay'
    REORDER = 'reorder'


class FaultInjector(Generic[T]):
    """Applies a :class:`FaultPlan` to the messages of one direction, deterministically.

    Args:
        plan: the plan.
        direction: the direction's name (the proxy gives the topic it takes from, e.g.
            ``'/pd/step_command'``); it is mixed into the seed so that the two directions of a
            proxy, and the proxies of two sites, draw independent fates.

    Attributes:
        counts: per counter of :data:`COUNTERS`: ``received`` messages; messages ``forwarded``
            (a duplicate counts twice, a held one when it is released); per fault kind the
            messages it hit (``dropped``, ``duplicated``, ``delayed``, ``reordered``). Of the
            reordered ones, ``reorder_swapped`` went out right after the next message,
            ``reorder_released`` went out when the next one came but was itself dropped,
            delayed or held (so nothing overtook them), ``reorder_expired`` were released
            after ``delay_s`` because no other message came.
    """

    def __init__(self, plan: FaultPlan, direction: str = '') -> None:
        self.plan = plan
        self.direction = direction
        self._random = random.Random(f'{plan.seed}/{direction}')
        self.counts: dict[str, int] = dict.fromkeys(COUNTERS, 0)
        # Held messages as (release time, arrival number, message): a heap for the delayed
        # ones (the arrival number breaks ties, so messages are never compared), one slot for
        # the message waiting to be reordered.
        self._delayed: list[tuple[float, int, T]] = []
        self._reordered: tuple[float, int, T] | None = None
        self._arrivals = itertools.count()

    def restore(self, counts: Mapping[str, object]) -> None:
        """Continue where an earlier injector of the same plan and direction stopped.

        For a restarted proxy: the counters of :data:`COUNTERS` are taken over and the random
        generator is advanced past the ``received`` messages, so the next message meets the
        fate it would have met without the restart. What the earlier one held is lost (as a
        network loses what is in flight). Call it before the first :meth:`submit`.

        Raises:
            ValueError: a counter is not a non-negative integer, or messages were handled
                already.
        """
        if self.counts['received'] or self.held:
            msg = f'{self.direction or "injector"}: restore before the first message only'
            raise ValueError(msg)
        restored = dict.fromkeys(COUNTERS, 0)
        for name in COUNTERS:
            value = counts.get(name, 0)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                msg = (f'{self.direction or "injector"}: counter {name}={value!r}: not a '
                       'non-negative integer')
                raise ValueError(msg)
            restored[name] = value
        for _ in range(restored['received']):
            self.decide()
            next(self._arrivals)
        self.counts = restored

    def decide(self) -> tuple[Fate, float]:
        """Draw the fate of the next message and its hold (s; 0 unless delayed or reordered).

        Always draws two numbers, so the n-th message's fate depends only on n and the seed.
        """
        u = self._random.random()
        hold = self.plan.delay_s * (1.0 - self._random.random())  # in (0, delay_s]
        plan = self.plan
        edge = 0.0
        for fate, probability in ((Fate.DROP, plan.drop), (Fate.DUPLICATE, plan.duplicate),
                                  (Fate.DELAY, plan.delay), (Fate.REORDER, plan.reorder)):
            edge += probability
            if u < edge:
                if fate is Fate.DELAY:
                    return fate, hold
                if fate is Fate.REORDER:
                    return fate, plan.delay_s
                return fate, 0.0
        return Fate.FORWARD, 0.0

    def submit(self, message: T, now: float) -> list[T]:
        """Take one message arriving at ``now``; return what to send now, in order.

        Held messages already due (see :meth:`poll`) go first, then what this message's fate
        produces, then the message that was waiting to be reordered (if any).
        """
        out = self.poll(now)
        self.counts['received'] += 1
        fate, hold = self.decide()
        waiting, self._reordered = self._reordered, None
        arrival = next(self._arrivals)
        sent: list[T] = []
        if fate is Fate.FORWARD:
            sent = [message]
        elif fate is Fate.DROP:
            self.counts['dropped'] += 1
        elif fate is Fate.DUPLICATE:
            self.counts['duplicated'] += 1
            sent = [message, message]
        elif fate is Fate.DELAY:
            self.counts['delayed'] += 1
            heapq.heappush(self._delayed, (now + hold, arrival, message))
        else:
            self.counts['reordered'] += 1
            self._reordered = (now + hold, arrival, message)
        if waiting is not None:
            self.counts['reorder_swapped' if sent else 'reorder_released'] += 1
            sent.append(waiting[2])
        self.counts['forwarded'] += len(sent)
        return out + sent

    def poll(self, now: float) -> list[T]:
        """The held messages due at ``now`` (delays elapsed, reorder holds expired), in order."""
        due: list[tuple[float, int, T]] = []
        while self._delayed and self._delayed[0][0] <= now:
            due.append(heapq.heappop(self._delayed))
        if self._reordered is not None and self._reordered[0] <= now:
            due.append(self._reordered)
            self._reordered = None
            self.counts['reorder_expired'] += 1
        due.sort(key=lambda held: held[:2])
        self.counts['forwarded'] += len(due)
        return [held[2] for held in due]

    def next_release(self) -> float | None:
        """When the next held message is due (``None``: nothing is held)."""
        times = [held[0] for held in self._delayed[:1]]
        if self._reordered is not None:
            times.append(self._reordered[0])
        return min(times) if times else None

    @property
    def held(self) -> int:
        """Messages held now (delayed or waiting to be reordered)."""
        return len(self._delayed) + (self._reordered is not None)

    def report(self) -> dict[str, int]:
        """The counters and the messages held now (for a JSON report)."""
        return {**self.counts, 'held': self.held}


def proxy_command(front: str, back: str, plan: str, report_file: Path) -> list[str]:
    """The command line of a fault proxy (``ros2 run pd_bringup fault_proxy``).

    Args:
        front: namespace the sender talks to (e.g. ``/pd``).
        back: namespace the receiver is really in (e.g. ``/pd/behind``).
        plan: the fault plan (checked here, so a bad one fails before anything starts).
        report_file: where the proxy writes its JSON counters.

    Raises:
        FaultPlanError: the plan is invalid.
        pd_common.resources.ResourceError: pd_bringup (or its ``fault_proxy``) is not built.
    """
    parsed = FaultPlan.parse(plan)
    return [str(find_executable('pd_bringup', 'fault_proxy')), '--ros-args',
            '-p', f'front:={front}', '-p', f'back:={back}', '-p', f'faults:={parsed}',
            '-p', f'report_file:={report_file}']


def fault_summary(reports: Mapping[str, Mapping[str, Any]], files: Mapping[str, str]
                  ) -> dict[str, Any]:
    """The ``faults`` block of a run's ``summary.json``.

    Args:
        reports: per proxy (its name), the report it wrote (see ``fault_proxy``).
        files: per proxy, its report file's name in the run folder.

    Returns:
        ``plan`` (of the first proxy), ``totals`` (each counter summed over every proxy and
        both directions) and ``proxies`` (per proxy: its report file and its report).
    """
    totals = dict.fromkeys((*COUNTERS, 'held'), 0)
    proxies: dict[str, Any] = {}
    plan = ''
    for name, report in reports.items():
        plan = plan or str(report.get('faults', ''))
        for direction in ('step_command', 'step_feedback'):
            counts = report.get(direction)
            if isinstance(counts, Mapping):
                for counter in totals:
                    value = counts.get(counter, 0)
                    totals[counter] += value if isinstance(value, int) else 0
        proxies[name] = {'report': files.get(name, ''), **report}
    return {'plan': plan, 'totals': totals, 'proxies': proxies}


def attach_reports(summary_file: Path, report_files: Mapping[str, Path]) -> dict[str, Any] | None:
    """Add the proxies' reports to ``summary.json`` (as ``faults``, see :func:`fault_summary`).

    Args:
        summary_file: the run's ``summary.json`` (left alone when it does not exist).
        report_files: per proxy (its name), its report file.

    Returns:
        The ``faults`` block (``None``: no proxy wrote a report). A report that cannot be read
        is given as ``{'error': ...}``.
    """
    reports = read_reports(report_files)
    if not reports:
        return None
    block = fault_summary(reports, {name: path.name for name, path in report_files.items()})
    add_to_summary(summary_file, 'faults', block)
    return block
