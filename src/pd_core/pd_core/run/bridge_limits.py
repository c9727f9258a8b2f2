"""Each site's actuator bridge in a ROS-free run: its safety limits, applied as the bridge would.

``./pd run --site bridge`` puts an actuator bridge in front of every site (the default site of
a test without substructures); the bridge checks every command against the **measured**
position and every measurement, and holds the test at the first command or measurement beyond a
limit. A ROS-free run has no bridge: with :func:`site_limits` and :class:`BridgeGate`,
:func:`~.runner.run_offline` applies the same limits with the bridge's own checks
(:mod:`pd_common.experimental.limits`) to the same floats, in the bridge's order, so it holds at
the same step with the same message:

1. the command: its control modes and forces (a fault), then ``max_displacement``,
   ``max_increment`` and ``max_velocity`` (over ``step_duration``) from the position last
   measured (:func:`~pd_common.experimental.limits.check_command`); a force-controlled
   actuator's target force against ``max_force``; ``on_limit: saturate`` clips the target
   instead (the step is then answered with a ``LIMIT`` status, and the integrator holds);
2. the measurement (after the specimen moved): non-finite values (a fault), ``max_force``, then
   ``tracking_tolerance`` against the target sent; under mixed control the strokes
   (``max_displacement``, and ``max_increment`` within the step).

The limits are those the bridge of :mod:`pd_bringup.plan` is started with: the bridge's
parameter file (the shipped ``pd_actuator_bridge/config/bridge.yaml``, or another one, as
``run_test --bridge-params``), then the test file's ``sites.<site>.bridge`` mapping for that
site (a test without substructures: the file only), read by
:func:`~pd_common.experimental.limits.limits_from_parameters` exactly as the bridge node does
(0 = off for the optional limits).

Differences that remain: under mixed control the bridge checks after every force sub-step, a
ROS-free run after the step's last one (the same step, the message naming the last sub-step);
the command watchdog (wall-clock time) is not applied.

With ``apply=False`` (``./pd offline --past-limits``) nothing is refused: the specimen is driven
past the limits for study, and the gate records where the bridge would have held and the first
step beyond each limit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from pd_common.config import (
    SchemaError,
    default_bridge_parameter_file,
    read_bridge_parameter_file,
)
from pd_common.experimental.force_ramp import force_ramp
from pd_common.experimental.limits import (
    LimitViolation,
    SafetyLimits,
    check_command,
    check_control,
    check_feedback,
    check_strokes,
    check_target_force,
    check_tracking,
    limits_from_parameters,
    on_limit_from_parameters,
    saturate_command,
)
from pd_common.protocol import Feedback, FeedbackStatus, KeyedAnswers

from ..errors import ConfigError
from .definition import TestDefinition

__all__ = ['BridgeGate', 'LimitRecord', 'SiteLimits', 'limits_report', 'limits_summary',
           'site_limits']

#: The bridge's prefix of the message of a step it executed with a clipped target.
SATURATED_PREFIX = 'saturated: '


@dataclass(frozen=True)
class SiteLimits:
    """What one site's bridge enforces.

    Attributes:
        site: the site (``''``: the default site of a test without substructures).
        limits: the safety limits.
        on_limit: ``'hold'`` or ``'saturate'``.
        dof_names: the bridge's actuator names (its messages name them).
        source: where the limits come from (the parameter file, the test file's mapping).
    """

    site: str
    limits: SafetyLimits
    on_limit: str
    dof_names: tuple[str, ...]
    source: str

    def as_dict(self) -> dict[str, Any]:
        """For ``summary.json``: the limits set (``None``: off), ``on_limit``, the source."""
        limits = {name: getattr(self.limits, name) for name in (
            'max_displacement', 'max_increment', 'max_velocity', 'step_duration', 'max_force',
            'tracking_tolerance', 'max_force_increment')}
        return {'limits': limits, 'on_limit': self.on_limit, 'source': self.source}


def site_limits(definition: TestDefinition, bridge_file: str | Path | None = None
                ) -> dict[str, SiteLimits]:
    """Per site, the limits its bridge would enforce (the sites of :func:`~.runner.site_servers`).

    Args:
        definition: the test.
        bridge_file: the bridge's ROS parameter file (default: the shipped one,
            :func:`pd_common.config.default_bridge_parameter_file`).

    Raises:
        ConfigError: the file cannot be read or its schema refuses it (one line naming the
            file and the dotted path).
        pd_common.errors.BridgeConfigError: a limit or ``on_limit`` the bridge would refuse (a
            ``ValueError``), naming the file or the test file's mapping.
    """
    path = Path(bridge_file) if bridge_file is not None else default_bridge_parameter_file()
    try:
        base = read_bridge_parameter_file(path).parameters()
    except SchemaError as err:
        raise ConfigError(str(err)) from None
    limits_from_parameters(base, str(path))  # a bad file is named as such
    on_limit_from_parameters(base, str(path))
    sites: list[tuple[str, tuple[str, ...], Mapping[str, Any]]] = []
    if definition.model is None:
        sites.append(('', tuple(definition.dof_names), {}))
    else:
        for site in definition.model.site_names:
            settings = definition.site_settings.get(site)
            bridge = settings.bridge if settings is not None else None
            # the keys the test file sets (typed: its schema checked them when it was read)
            given = bridge.model_dump(exclude_unset=True) if bridge is not None else {}
            sites.append((site, tuple(definition.model.actuator_names(site)), given))
    result: dict[str, SiteLimits] = {}
    for site, names, extra in sites:
        parameters = {**base, **extra}
        source = path.name + (f' + {definition.source}: sites.{site}.bridge' if extra else '')
        where = f'{definition.source}: sites.{site}.bridge' if extra else str(path)
        result[site] = SiteLimits(site=site, limits=limits_from_parameters(parameters, where),
                                  on_limit=on_limit_from_parameters(parameters, where),
                                  dof_names=names, source=source)
    return result


@dataclass(frozen=True)
class LimitRecord:
    """A step the bridge held (or would have held) at.

    Attributes:
        site: the site (``''``: the default one).
        step, iteration: the command's key.
        limit: the limit exceeded (``max_displacement``, ``max_increment``, ``max_velocity``,
            ``max_force``, ``tracking_tolerance``), empty for malformed or non-finite data.
        kind: ``'limit'`` or ``'fault'``.
        dof: the offending actuator's index.
        message: the bridge's message, word for word.
    """

    site: str
    step: int
    iteration: int
    limit: str
    kind: str
    dof: int
    message: str

    def as_dict(self) -> dict[str, Any]:
        """For ``summary.json``."""
        return {'site': self.site or 'default', 'step': self.step, 'iteration': self.iteration,
                'limit': self.limit or self.kind, 'kind': self.kind, 'dof': self.dof,
                'message': self.message}


class BridgeGate:
    """One site's bridge in front of its in-process specimen.

    :meth:`handle` checks each command and measurement as the bridge does and refuses (``apply``)
    or records (``apply=False``).

    A refused step is answered as the bridge answers it (its status and message, the position
    and force last measured); the gate then refuses every new step (the bridge's hold is
    latched). With ``on_limit: saturate`` a command beyond a limit is clipped, executed and
    answered ``LIMIT`` (``saturated: ...``): the integrator holds there, the bridge does not.

    Attributes:
        server: the specimen (or continuous actuator) behind the bridge.
        site: the site's limits.
        apply: refuse (the bridge) or only record (past the limits, for study).
        held: the first violation: where the bridge holds (or would have held), or the first
            saturated step.
        exceeded: per limit (or ``'fault'``), the first step beyond it.
        position: the position the bridge checks commands from: the specimen's before the
            first move (its offer), then the last measurement.
    """

    def __init__(self, server: KeyedAnswers, site: SiteLimits, n_dof: int, *,
                 apply: bool = True) -> None:
        self.server = server
        self.site = site
        self.n_dof = n_dof
        self.apply = apply
        self.held: LimitRecord | None = None
        self.exceeded: dict[str, LimitRecord] = {}
        self.holding = False  # the bridge's latched hold (a saturated step does not latch)
        start = getattr(server, 'position', None)
        self.position: tuple[float, ...] = (
            tuple(float(x) for x in start) if start is not None and len(start) == n_dof
            else (0.0,) * n_dof)
        self.force: tuple[float, ...] = (math.nan,) * n_dof  # as the bridge's before a move
        self.held_force: tuple[float, ...] = (0.0,) * n_dof

    def handle(self, test_id: str, step: int, target: Sequence[float], *, iteration: int = 0,
               control_mode: Sequence[int] = (), target_force: Sequence[float] = ()
               ) -> Feedback | None:
        """The bridge's answer to a new command (``None`` if the specimen ignored it)."""
        if self.holding and self.held is not None:  # latched: nothing moves
            return self._reply(test_id, step, iteration, self.held.kind, self.held.message)
        limits, names = self.site.limits, self.site.dof_names
        controlled, forces, control = check_control(control_mode, target_force, self.n_dof,
                                                    names)
        if control is not None:
            return self._refused(test_id, step, iteration, LimitViolation(
                control.kind, control.dof, f'invalid control: {control.message}'))
        mixed = any(controlled)
        imposed = tuple(not flag for flag in controlled)
        sent = tuple(float(x) for x in target)
        note = ''
        saturated: LimitViolation | None = None
        if mixed:
            violation = check_command(target, self.position, limits, names,
                                      displacement_controlled=imposed)
            if violation is None:
                violation = check_target_force(forces, controlled, limits, names)
        else:
            violation = check_command(target, self.position, limits, names)
            if (self.apply and violation is not None
                    and violation.kind is FeedbackStatus.LIMIT
                    and self.site.on_limit == 'saturate'):
                saturation = saturate_command(target, self.position, limits, names)
                if saturation.target is not None:
                    sent, note = saturation.target, saturation.message
                    saturated = LimitViolation(violation.kind, violation.dof,
                                               SATURATED_PREFIX + note, violation.limit)
                violation = saturation.violation
        if violation is not None:
            refusal = self._refused(test_id, step, iteration, violation)
            if self.apply:
                return refusal
        where = ''
        if mixed:
            count = max([1, *(len(force_ramp(self.held_force[dof], forces[dof],
                                             limits.max_force_increment))
                              for dof in range(self.n_dof) if controlled[dof])])
            where = f' at force ramp sub-step {count} of {count}'
            self.held_force = tuple(forces[dof] if controlled[dof] else self.held_force[dof]
                                    for dof in range(self.n_dof))
        start = self.position
        answer = self.server.handle(test_id, step, sent, iteration=iteration,
                                    control_mode=control_mode, target_force=target_force)
        if answer is None or answer.status is not FeedbackStatus.OK:
            return answer  # ignored, or the specimen's own fault: passed on as it is
        measured = tuple(float(x) for x in answer.measured_displacement)
        force = tuple(float(f) for f in answer.restoring_force)
        violation = check_feedback(measured, force, limits, names, n_dof=self.n_dof)
        if violation is None or violation.kind is FeedbackStatus.LIMIT:
            self.position, self.force = measured, force
        if violation is None:
            violation = check_tracking(measured, sent, limits, names,
                                       displacement_controlled=imposed if mixed else None)
        if violation is not None and where:
            violation = LimitViolation(violation.kind, violation.dof,
                                       f'{violation.message}{where}', violation.limit)
        elif violation is None and mixed:
            violation = check_strokes(self.position, start, controlled, limits, names, where)
        if violation is not None:
            refusal = self._refused(test_id, step, iteration, violation)
            if self.apply:
                return refusal
        if saturated is not None:  # answered LIMIT: the integrator holds, the bridge does not
            self._record(step, iteration, saturated)
            return replace(answer, status=FeedbackStatus.LIMIT, message=saturated.message)
        return answer

    def _refused(self, test_id: str, step: int, iteration: int, violation: LimitViolation
                 ) -> Feedback:
        """Record the violation (and latch the hold, if applied).

        The bridge's answer to a step it holds at.
        """
        record = self._record(step, iteration, violation)
        self.holding = self.apply
        return self._reply(test_id, step, iteration, record.kind, violation.message)

    def _record(self, step: int, iteration: int, violation: LimitViolation) -> LimitRecord:
        kind = 'limit' if violation.kind is FeedbackStatus.LIMIT else 'fault'
        record = LimitRecord(site=self.site.site, step=step, iteration=iteration,
                             limit=violation.limit, kind=kind, dof=violation.dof,
                             message=violation.message)
        if self.held is None:
            self.held = record
        self.exceeded.setdefault(record.limit or kind, record)
        return record

    def _reply(self, test_id: str, step: int, iteration: int, kind: str, message: str
               ) -> Feedback:
        status = FeedbackStatus.LIMIT if kind == 'limit' else FeedbackStatus.FAULT
        return Feedback(test_id=test_id, step=step, iteration=iteration,
                        measured_displacement=self.position, restoring_force=self.force,
                        status=status, message=message)


def limits_summary(gates: Mapping[str, BridgeGate]) -> dict[str, Any]:
    """``summary.json``'s ``bridge_limits``.

    Each site's limits, and where the first bridge held (``held``) or would have held
    (``would_have_held``, past the limits), and the first step beyond each limit (``exceeded``).
    """
    applied = all(gate.apply for gate in gates.values())
    records = [gate.held for gate in gates.values() if gate.held is not None]
    first = min(records, key=lambda r: (r.step, r.iteration), default=None)
    exceeded = sorted((record for gate in gates.values() for record in gate.exceeded.values()),
                      key=lambda r: (r.step, r.iteration, r.site))
    return {
        'applied': applied,
        'sites': {site or 'default': gate.site.as_dict() for site, gate in gates.items()},
        'held' if applied else 'would_have_held': first.as_dict() if first else None,
        'exceeded': [record.as_dict() for record in exceeded],
    }


def limits_report(summary: Mapping[str, Any]) -> list[str]:
    """The lines ``./pd offline`` prints about the bridges' limits (none if nothing tripped)."""
    part = summary.get('bridge_limits')
    if not isinstance(part, Mapping):
        return []
    lines = []
    held = part.get('held')
    if held:
        lines.append(f'HELD at step {held["step"]} by the bridge of site {held["site"]} '
                     f'({held["limit"]}): {held["message"]}; ./pd run would hold the test '
                     'there (--past-limits: run past it)')
    would = part.get('would_have_held')
    if would:
        others = [r for r in part.get('exceeded', []) if r != would]
        also = ''.join(f'; {r["limit"]} from step {r["step"]}' + (
            f' (site {r["site"]})' if r['site'] != would['site'] else '') for r in others)
        lines.append(f'past limits: the bridge of site {would["site"]} would have held at '
                     f'step {would["step"]} ({would["limit"]}): {would["message"]}{also}')
    elif not part.get('applied', True):
        lines.append('past limits: no bridge limit was exceeded')
    return lines
