"""The console's view of a test: statuses, per-site histories, gauges, the page's JSON.

The console node feeds this model what it hears on the graph (the integrator's status, each
site's step commands and feedback and its bridge's status, the test definition); a finished
run feeds it the messages of its bag. The model keeps bounded, decimated histories
(:class:`~.series.DecimatedRows`) and makes the frame pushed to the page
(:meth:`ConsoleModel.frame`) — at most ``max_points`` rows per series, whatever the test's
length and rate. It does no I/O and imports no ROS.
"""

from __future__ import annotations

import json
import math
import re
from collections import OrderedDict, deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from pd_common.config.schema_test_file import SITE_NAME_PATTERN
from pd_common.experimental import TrackingMonitor
from pd_common.protocol import Command, Feedback, FeedbackStatus, StepKey, TestState
from pd_common.protocol import Status as TestStatusData

from .series import DecimatedRows, rounded

_SITE_NAME = re.compile(SITE_NAME_PATTERN)


def _finite(value: Any) -> float | None:
    """``value`` as a finite float if it is a number that is one (a bool is none)."""
    if not isinstance(value, int | float) or isinstance(value, bool):
        return None
    try:
        number = float(value)
    except OverflowError:  # (an integer of hundreds of digits)
        return None
    return number if math.isfinite(number) else None

__all__ = ['BRIDGE_LIMITS', 'DEFAULT_MAX_POINTS', 'ConsoleModel', 'Gauge', 'SiteView',
           'sites_of_definition']

#: The bridge limits shown as gauges (pd_actuator_bridge's parameters; 0 = off).
BRIDGE_LIMITS = ('max_displacement', 'max_increment', 'max_velocity', 'max_force',
                 'tracking_tolerance')
_UNITS = {'max_displacement': 'm', 'max_increment': 'm', 'max_velocity': 'm/s',
          'max_force': 'N', 'tracking_tolerance': 'm'}
#: Rows per series pushed to the page (and kept).
DEFAULT_MAX_POINTS = 600
#: Seconds of statuses the rate is measured over.
RATE_WINDOW = 10.0
_TIMES_KEPT = 256


@dataclass
class Gauge:
    """How close a site is to one bridge limit (``limit`` 0: the limit is off)."""

    name: str
    limit: float
    value: float = 0.0
    peak: float = 0.0

    def update(self, value: float) -> None:
        """The current value (absolute), and the peak so far."""
        self.value = abs(value)
        self.peak = max(self.peak, self.value)

    def to_json(self) -> dict[str, Any]:
        """The gauge for the page: value, peak and their ratios to the limit."""
        on = self.limit > 0.0
        return {'name': self.name, 'unit': _UNITS.get(self.name, ''), 'limit': self.limit,
                'off': not on, 'value': rounded(self.value), 'peak': rounded(self.peak),
                'ratio': rounded(self.value / self.limit) if on else None,
                'peak_ratio': rounded(self.peak / self.limit) if on else None}


@dataclass
class SiteView:
    """What the console knows of one site: its streams, counters, gauges and bridge status."""

    name: str
    label: str
    limits: dict[str, float]
    max_points: int
    dof_names: tuple[str, ...] = ()
    histories: list[DecimatedRows] = field(default_factory=list)
    gauges: dict[str, Gauge] = field(default_factory=dict)
    commands: int = 0
    resends: int = 0
    feedback_ok: int = 0
    feedback_limit: int = 0
    feedback_fault: int = 0
    last_message: str = ''
    #: ``(test id, step)`` of the last command this site answered (drawn or not).
    last_answered: tuple[str, int] | None = None
    bridge_status: TestStatusData | None = None
    _times: OrderedDict[tuple[str, StepKey], tuple[float, tuple[float, ...]]] = field(
        default_factory=OrderedDict)
    _answered: set[tuple[str, StepKey]] = field(default_factory=set)
    _previous_target: tuple[float, ...] | None = None
    _tracking: TrackingMonitor | None = None
    #: The rows (one tuple per DOF) answered since the last :meth:`ConsoleModel.drain`
    #: (``None``: not kept); bounded, the oldest dropped first.
    fresh: deque[tuple[tuple[float, ...], ...]] | None = None

    def __post_init__(self) -> None:
        """One gauge per bridge limit."""
        self.gauges = {name: Gauge(name, float(self.limits.get(name, 0.0)))
                       for name in BRIDGE_LIMITS}

    def _set_dofs(self, names: tuple[str, ...]) -> None:
        if names == self.dof_names:
            return
        self.dof_names = names
        self.histories = [DecimatedRows(self.max_points, key=2) for _ in names]
        self._tracking = TrackingMonitor(len(names), keep_history=False) if names else None
        self._previous_target = None

    def on_command(self, command: Command) -> None:
        """A step command sent to this site (a repeat of one already sent is a re-send).

        One whose DOF names do not match its targets, or whose targets are not finite, is not
        drawn (no command of the test's is such: without a key, anyone's may be shown).
        """
        if (len(command.dof_names) != len(command.target_displacement)
                or not all(map(math.isfinite, command.target_displacement))):
            return
        key = (command.test_id, command.key)
        if key in self._times:
            self.resends += 1
            return
        self._set_dofs(tuple(command.dof_names))
        self.commands += 1
        target = tuple(float(x) for x in command.target_displacement)
        self._times[key] = (float(command.test_time), target)
        while len(self._times) > _TIMES_KEPT:
            old, _ = self._times.popitem(last=False)
            self._answered.discard(old)
        if self._previous_target is not None and len(target) == len(self._previous_target):
            increment = max((abs(a - b) for a, b in zip(target, self._previous_target,
                                                       strict=True)), default=0.0)
            self.gauges['max_increment'].update(increment)
            duration = float(self.limits.get('step_duration', 0.0))
            if duration > 0.0:
                self.gauges['max_velocity'].update(increment / duration)
        self._previous_target = target

    def on_feedback(self, feedback: Feedback) -> None:
        """This site's answer; drawn when it answers a command seen (once per command)."""
        key = (feedback.test_id, feedback.key)
        if feedback.status == FeedbackStatus.LIMIT:
            self.feedback_limit += 1
        elif feedback.status == FeedbackStatus.FAULT:
            self.feedback_fault += 1
        else:
            self.feedback_ok += 1
        if feedback.message:
            self.last_message = feedback.message
        if key not in self._times or key in self._answered:
            return
        self._answered.add(key)
        self.last_answered = (feedback.test_id, int(feedback.step))
        test_time, target = self._times[key]
        measured = [float(x) for x in feedback.measured_displacement]
        forces = [float(x) for x in feedback.restoring_force]
        if (feedback.status != FeedbackStatus.OK or len(measured) != len(target)
                or len(forces) != len(target) or not all(map(math.isfinite, measured))):
            return
        assert self._tracking is not None
        sample = self._tracking.update(target, measured)
        rows = tuple((test_time, target[i], measured[i], forces[i], float(sample.error[i]),
                      float(sample.indicator[i])) for i in range(len(target)))
        for history, row in zip(self.histories, rows, strict=True):
            history.append(row)
        if self.fresh is not None:
            self.fresh.append(rows)
        self.gauges['max_displacement'].update(max(max(map(abs, measured)),
                                                   max(map(abs, target))))
        self.gauges['max_force'].update(max(map(abs, forces)))
        self.gauges['tracking_tolerance'].update(float(max(abs(e) for e in sample.error)))

    def to_json_gauges(self) -> dict[str, Any]:
        """Only the gauges of :meth:`to_json` (cheap)."""
        return {'gauges': [gauge.to_json() for gauge in self.gauges.values()]}

    def to_json(self, test_over: bool = False) -> dict[str, Any]:
        """The site for the page.

        ``test_over``: the test ended, so a bridge that says it is active is shown idle: it answers
        nothing more of this test.
        """
        dofs = []
        for name, history in zip(self.dof_names, self.histories, strict=True):
            t, command, measured, force, error, indicator = history.columns(6)
            dofs.append({'name': name, 't': t, 'command': command, 'measured': measured,
                         'force': force, 'error': error, 'indicator': indicator,
                         'samples': history.count})
        status = self.bridge_status
        return {
            'name': self.name, 'label': self.label, 'dofs': dofs,
            'gauges': [gauge.to_json() for gauge in self.gauges.values()],
            'counts': {'commands': self.commands, 'resends': self.resends,
                       'ok': self.feedback_ok, 'limit': self.feedback_limit,
                       'fault': self.feedback_fault},
            'message': self.last_message,
            'bridge': None if status is None else _bridge_json(status, test_over),
        }


#: Test states after which the test's bridges answer nothing more of it.
ENDED = (TestState.FINISHED, TestState.ABORTED, TestState.INTERRUPTED)


def _bridge_json(status: TestStatusData, test_over: bool) -> dict[str, Any]:
    """A bridge's status for the page: once the test is over, an active bridge is idle."""
    shown = _status_json(status)
    if test_over and TestState(status.state) == TestState.RUNNING:
        shown.update(state=int(TestState.IDLE), state_name=TestState.IDLE.name,
                     message=f'idle: the test is over ({status.message})')
    return shown


def _status_json(status: TestStatusData) -> dict[str, Any]:
    state = TestState(status.state)
    return {'state': int(state), 'state_name': state.name, 'step': status.step,
            'total': status.total_steps, 'message': status.message,
            'retries': status.retries, 'ignored': status.ignored_messages,
            'refused': status.refused_messages, 'refused_by_reason': status.refused_by_reason}


def sites_of_definition(definition: Mapping[str, Any]) -> dict[str, str]:
    """The sites of a resolved test definition and a label for each (its elements).

    A test without experimental elements has the one default site ``''``.
    """
    elements = (definition.get('structure') or {}).get('elements') or []
    sites: dict[str, list[str]] = {}
    for element in elements:
        if element.get('type') == 'experimental':
            sites.setdefault(str(element.get('site', '')), []).append(
                str(element.get('name', '')))
    if not sites:
        return {'': 'specimen'}
    return {site: ', '.join(name for name in names if name) or site
            for site, names in sites.items()}


class ConsoleModel:
    """Everything the page shows, fed by plain protocol data.

    Args:
        clock: monotonic clock in s (for the rate and ETA; injectable for tests).
        max_points: rows kept and pushed per series.
        default_limits: the bridge limits of a site whose test definition names none (the
            bridge's parameter file).
        fresh_rows: keep up to this many rows per site answered since the last
            :meth:`drain` (0: none; a live feed such as Foxglove's drains them).
    """

    def __init__(self, clock: Callable[[], float], *, max_points: int = DEFAULT_MAX_POINTS,
                 default_limits: Mapping[str, float] | None = None, fresh_rows: int = 0
                 ) -> None:
        self._clock = clock
        self.fresh_rows = fresh_rows
        self.max_points = max_points
        self.default_limits = dict(default_limits or {})
        self.definition: dict[str, Any] = {}
        self.sites: dict[str, SiteView] = {}
        self.status: TestStatusData | None = None
        self.energy: DecimatedRows | None = None
        self.figures: list[str] = []
        self.mode = 'live'
        self.source = ''
        self.version = 0
        self._progress: deque[tuple[float, int]] = deque()

    # -- inputs ----------------------------------------------------------------------------
    def on_definition(self, text: str) -> None:
        """The resolved test definition (JSON): its sites and their bridge limits."""
        try:
            definition = json.loads(text)
        except ValueError:
            return
        if not isinstance(definition, dict):
            return
        try:  # (the integrator's is well-formed; without a key, anyone's may arrive)
            if not isinstance(definition.get('test', {}), dict):
                return
            labels = sites_of_definition(definition)
            if not all(_SITE_NAME.fullmatch(site) for site in labels if site):
                return  # (a site becomes a namespace of the topics watched)
            raw_sites = definition.get('sites') or {}
            bridges = {site: dict((raw_sites.get(site) or {}).get('bridge') or {})
                       for site in labels}
        except (AttributeError, TypeError, ValueError):
            return  # not a test definition's shape: not shown
        self.definition = definition
        for site, label in labels.items():
            limits = dict(self.default_limits)
            limits.update({k: limit for k, v in bridges[site].items()
                           if (limit := _finite(v)) is not None})
            existing = self.sites.get(site)
            if existing is None:
                self._add_site(SiteView(site, label, limits, self.max_points))
            else:
                existing.label = label
        self.version += 1

    def _add_site(self, view: SiteView) -> SiteView:
        if self.fresh_rows > 0:
            view.fresh = deque(maxlen=self.fresh_rows)
        self.sites[view.name] = view
        return view

    def site(self, name: str) -> SiteView:
        """The view of site ``name`` (created with the default limits when new)."""
        view = self.sites.get(name)
        if view is None:
            view = self._add_site(SiteView(name, name or 'specimen',
                                           dict(self.default_limits), self.max_points))
        return view

    def drain(self) -> dict[str, tuple[tuple[str, ...], list[tuple[tuple[float, ...], ...]]]]:
        """Per site, its DOF names and the rows answered since the last drain.

        Each a tuple per DOF of ``(t, command, measured, force, error, indicator)``.
        """
        drained = {}
        for name, view in self.sites.items():
            if view.fresh:
                drained[name] = (view.dof_names, list(view.fresh))
                view.fresh.clear()
        return drained

    def on_command(self, site: str, command: Command) -> None:
        """A step command on ``site``'s topic."""
        self.site(site).on_command(command)
        self.version += 1

    def on_feedback(self, site: str, feedback: Feedback) -> None:
        """A step feedback on ``site``'s topic."""
        self.site(site).on_feedback(feedback)
        self.version += 1

    def on_bridge_status(self, site: str, status: TestStatusData) -> None:
        """The status of ``site``'s bridge."""
        self.site(site).bridge_status = status
        self.version += 1

    def on_status(self, status: TestStatusData, at: float | None = None) -> None:
        """The integrator's status (``at``: when it arrived, default the clock)."""
        now = self._clock() if at is None else at
        if self.status is not None and (status.test_id != self.status.test_id
                                        or status.step < self.status.step):
            self._progress.clear()
        self.status = status
        if TestState(status.state) == TestState.RUNNING:
            self._progress.append((now, int(status.step)))
        else:
            self._progress.clear()
        while self._progress and now - self._progress[0][0] > RATE_WINDOW:
            self._progress.popleft()
        self.version += 1

    def set_energy(self, time: list[float], error: list[float]) -> None:
        """The energy error history (a finished run's ``energy.csv``)."""
        self.energy = DecimatedRows(self.max_points, key=1)
        for row in zip(time, error, strict=True):
            self.energy.append(row)
        self.version += 1

    # -- outputs ---------------------------------------------------------------------------
    def rate(self) -> float:
        """Steps per second over the last ``RATE_WINDOW`` s of a running test (0 if unknown)."""
        if len(self._progress) < 2:
            return 0.0
        (t0, s0), (t1, s1) = self._progress[0], self._progress[-1]
        return (s1 - s0) / (t1 - t0) if t1 > t0 else 0.0

    def test_json(self) -> dict[str, Any]:
        """State, step/total, rate, ETA and the integrator's counters."""
        test = self.definition.get('test') or {}
        status = self.status
        if status is None:
            return {'id': str(test.get('id', '')), 'state': None, 'state_name': 'WAITING',
                    'step': 0, 'total': 0, 'rate': 0.0, 'eta': None, 'message': '',
                    'retries': 0, 'ignored': 0, 'refused': 0, 'refused_by_reason': '',
                    'omega_dt': None, 'live_step': 0}
        rate = self.rate()
        remaining = status.total_steps - status.step
        eta = remaining / rate if rate > 0.0 else None
        answered = [view.last_answered[1] for view in self.sites.values()
                    if view.last_answered is not None
                    and view.last_answered[0] == status.test_id]
        # the integrator publishes its status every few seconds; the sites' answers show
        # the steps in between (a step is committed once every site answered it)
        live = max(status.step, min(answered)) if answered else status.step
        return {**_status_json(status), 'id': status.test_id, 'rate': rounded(rate),
                'eta': rounded(eta) if eta is not None else None,
                'omega_dt': rounded(status.omega_dt), 'live_step': live}

    def frame(self) -> dict[str, Any]:
        """The frame pushed to the page: everything it draws, decimated."""
        energy = None
        if self.energy is not None:
            t, error = self.energy.columns(2)
            energy = {'t': t, 'error': error}
        return {'type': 'frame', 'mode': self.mode, 'source': self.source,
                'version': self.version, 'test': self.test_json(),
                'sites': [view.to_json(test_over=self.status is not None and TestState(
                    self.status.state) in ENDED) for view in self.sites.values()],
                'energy': energy, 'figures': list(self.figures)}
