"""The bridge's force control: what each actuator holds and the force ramp being executed.

Mixed control (``docs/force_control.md``): a command may give each DOF a control mode and a
target force (:class:`pd_common.protocol.Command`). The force of each force-controlled DOF goes
from the force it holds (its last commanded force, 0 at the start, or the measured force a
restarted bridge adopted) to the target through
:func:`pd_common.experimental.force_ramp.force_ramp` sub-steps of at most
``max_force_increment`` (each DOF along its own ramp; one that arrives earlier holds its
target; the displacement-controlled DOFs at their targets from the first sub-step), each sent
to the driver (:meth:`~.drivers.base.ActuatorDriver.command_force`) and answered before the
next. After each sub-step the bridge checks the measurement (max_force on every DOF; tracking
on the displacement-controlled ones) and, on every DOF, the measured stroke within
max_displacement and its change since the step began within max_increment
(:func:`~.limits.check_strokes`): a force-controlled actuator running away holds the test with
a LIMIT naming it, and no further sub-step is sent. A ramp-down (lifecycle deactivation) takes
the force-controlled DOFs to 0 N through the same sub-steps and checks.

:class:`ForceControl` keeps that state and plans the ramps; the
:class:`~.bridge.ActuatorBridge` sends the sub-steps to the driver and holds on a violation.
Pure Python, no I/O.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from pd_common.experimental.force_ramp import force_ramp
from pd_common.experimental.limits import (
    KIND_LIMIT,
    LimitViolation,
    SafetyLimits,
    check_strokes,
    check_target_force,
    check_tracking,
)
from pd_common.experimental.limits import dof_label as _dof_label
from pd_common.experimental.limits import format_value as _fmt
from pd_common.protocol import ControlMode

from .drivers.base import StepId

__all__ = ['MAX_FORCE_SUBSTEPS', 'ForceControl', 'ForceRamp']

#: Most sub-steps of one force ramp (a command's, or a ramp-down's): a command's sub-steps and
#: its ramp-down's are numbered together below ``2 * MAX_FORCE_SUBSTEPS`` (=
#: :data:`~.drivers.base.SUBSTEP_STRIDE`, what :func:`~.drivers.base.force_substep_key`
#: carries).
MAX_FORCE_SUBSTEPS = 32768


@dataclass
class ForceRamp:
    """The sub-steps of a mixed command (or a ramp-down) being executed."""

    test_id: str
    step: StepId | None  # the integrator's step answered at the end; None: a ramp-down
    key: tuple[int, ...]  # the driver's sub-step ids are (*key, first + index)
    first: int
    modes: tuple[int, ...]
    force_controlled: tuple[bool, ...]
    targets: tuple[float, ...]  # the displacement-controlled DOFs' targets
    forces: list[tuple[float, ...]]  # per sub-step, the force targets
    start: tuple[float, ...]  # the strokes when the step began
    index: int = 0

    @property
    def current_id(self) -> tuple[int, ...]:
        """The driver's id of the sub-step in flight."""
        return (*self.key, self.first + self.index)

    @property
    def where(self) -> str:
        """`` at force ramp sub-step i of n`` (or of the ramp-down) for messages."""
        what = 'force ramp-down' if self.step is None else 'force ramp'
        return f' at {what} sub-step {self.index + 1} of {len(self.forces)}'


def _modes(force_controlled: Sequence[bool]) -> tuple[int, ...]:
    """Per DOF the :class:`~pd_common.protocol.ControlMode` of a force-controlled flag."""
    return tuple(int(ControlMode.FORCE if flag else ControlMode.DISPLACEMENT)
                 for flag in force_controlled)


class ForceControl:
    """The force-control state of one bridge: held forces, modes and the ramp in execution.

    Not thread-safe on its own: the bridge calls it under its lock.
    """

    def __init__(self, limits: SafetyLimits, dof_names: tuple[str, ...]) -> None:
        """Nothing held (0 N on every DOF), every DOF displacement-controlled."""
        self._limits = limits
        self._dof_names = dof_names
        self._n_dof = len(dof_names)
        self.held_force: tuple[float, ...] = (0.0,) * self._n_dof
        #: Per DOF whether the last command executed force-controlled it.
        self.force_controlled: tuple[bool, ...] = (False,) * self._n_dof
        #: The sub-steps in execution (``None``: none).
        self.ramp: ForceRamp | None = None
        #: Number of force sub-steps sent to the driver (commands and ramp-downs).
        self.substeps = 0
        #: One line on the last ramp-down: what it did, or why it stopped.
        self.ramp_down_note = ''
        self._next_substep: tuple[str, tuple[int, ...], int] | None = None  # after the last

    @property
    def ramping_down(self) -> bool:
        """Whether a ramp-down is executing."""
        return self.ramp is not None and self.ramp.step is None

    def adopt(self, measured: Sequence[float]) -> bool:
        """Take measured forces as the held ones unless a force was commanded already.

        See :meth:`~.bridge.ActuatorBridge.adopt_held_force`.
        """
        values = [float(value) for value in measured]
        if (self.substeps or len(values) != len(self.held_force)
                or not all(math.isfinite(value) for value in values)):
            return False
        self.held_force = tuple(values)
        return True

    def plain_command(self) -> None:
        """A displacement-only command is executed: no DOF is force-controlled."""
        self.force_controlled = (False,) * self._n_dof

    def plan(self, force_controlled: tuple[bool, ...], forces: Sequence[float]
             ) -> list[tuple[float, ...]]:
        """Per sub-step the force targets (0 on the displacement-controlled DOFs).

        Each force-controlled DOF follows ``force_ramp(held, target, max_force_increment)``; one
        that arrives earlier holds its target; at least one sub-step.
        """
        increment = self._limits.max_force_increment
        ramps = {dof: force_ramp(self.held_force[dof], float(forces[dof]), increment)
                 for dof in range(self._n_dof) if force_controlled[dof]}
        count = max([1, *(len(ramp) for ramp in ramps.values())])
        plan = []
        for sub in range(count):
            values = [0.0] * self._n_dof
            for dof, ramp in ramps.items():
                values[dof] = ramp[min(sub, len(ramp) - 1)] if ramp else float(forces[dof])
            plan.append(tuple(values))
        return plan

    def start_step(self, test_id: str, step: StepId, target: Sequence[float],
                   force_controlled: tuple[bool, ...], forces: tuple[float, ...],
                   current: Sequence[float]) -> LimitViolation | None:
        """Check a mixed command's forces and plan its ramp (displacements checked already).

        Returns:
            The violation (nothing planned), or ``None``: :attr:`ramp` is the new ramp.
        """
        violation = check_target_force(forces, force_controlled, self._limits, self._dof_names)
        if violation is not None:
            return violation
        plan = self.plan(force_controlled, forces)
        if len(plan) > MAX_FORCE_SUBSTEPS:
            return LimitViolation(
                KIND_LIMIT, 0,
                f'force ramp needs {len(plan)} sub-steps, more than {MAX_FORCE_SUBSTEPS} '
                f'(max_force_increment {_fmt(self._limits.max_force_increment)} N); '
                'nothing moved')
        key = tuple(int(x) for x in step) if isinstance(step, tuple) else (int(step),)
        self.ramp = ForceRamp(
            test_id=test_id, step=step, key=key, first=0, modes=_modes(force_controlled),
            force_controlled=force_controlled, targets=tuple(float(x) for x in target),
            forces=plan, start=tuple(current))
        self._next_substep = (test_id, key, len(plan))
        self.force_controlled = force_controlled
        return None

    def loaded(self) -> str:
        """The DOFs the last command force-controlled that hold a force.

        For messages ('' if none: nothing to ramp down).
        """
        return ', '.join(f'{_dof_label(dof, self._dof_names)} at '
                         f'{_fmt(self.held_force[dof])} N' for dof in range(self._n_dof)
                         if self.force_controlled[dof] and self.held_force[dof] != 0.0)

    def start_ramp_down(self, current: tuple[float, ...], last_test_id: str) -> str:
        """Plan the ramp of the force-controlled DOFs down to 0 N from ``current`` strokes.

        Returns:
            :attr:`ramp_down_note`: what is ramped down, or why not (then :attr:`ramp` is
            unchanged).
        """
        held = self.loaded()
        zeros = tuple(0.0 if on else force
                      for on, force in zip(self.force_controlled, self.held_force))
        forces = self.plan(self.force_controlled, zeros)
        if len(forces) > MAX_FORCE_SUBSTEPS:
            self.ramp_down_note = (f'force not ramped down (it needs {len(forces)} sub-steps, '
                                   f'more than {MAX_FORCE_SUBSTEPS}): {held} kept')
            return self.ramp_down_note
        test_id, key, first = self._next_substep or (last_test_id, (0,), 0)
        self.ramp = ForceRamp(
            test_id=test_id, step=None, key=key, first=first,
            modes=_modes(self.force_controlled), force_controlled=self.force_controlled,
            targets=current, forces=forces, start=current)
        self._next_substep = (test_id, key, first + len(forces))
        self.ramp_down_note = (f'ramping force down to 0 N in {len(forces)} sub-steps '
                               f'(max_force_increment '
                               f'{_fmt(self._limits.max_force_increment)} N): {held}')
        return self.ramp_down_note

    def next_substep(self, measured: tuple[float, ...] | None
                     ) -> tuple[ForceRamp, list[float], tuple[float, ...]]:
        """The sub-step to send now: ``(ramp, targets, forces)``.

        Counts it and takes its forces as the held ones.

        Args:
            measured: The strokes last measured (``None``: none yet, the ramp's start): a
                force-controlled DOF's target (not imposed).
        """
        ramp = self.ramp
        assert ramp is not None
        forces = ramp.forces[ramp.index]
        if measured is None or len(measured) != self._n_dof:
            measured = ramp.start
        targets = [measured[dof] if ramp.force_controlled[dof] else ramp.targets[dof]
                   for dof in range(self._n_dof)]
        self.held_force = tuple(
            forces[dof] if ramp.force_controlled[dof] else self.held_force[dof]
            for dof in range(self._n_dof))
        self.substeps += 1
        return ramp, targets, forces

    def substep_violation(self, violation: LimitViolation | None,
                          displacement: Sequence[float], stored: tuple[float, ...] | None
                          ) -> LimitViolation | None:
        """What is wrong with the sub-step just answered, located in the ramp.

        Args:
            violation: The bridge's measurement check (:func:`~.limits.check_feedback`).
            displacement: The measured displacement.
            stored: The measurement as the bridge stored it (``None``: not stored).
        """
        ramp = self.ramp
        assert ramp is not None
        if violation is None:
            violation = check_tracking(
                displacement, ramp.targets, self._limits, self._dof_names,
                displacement_controlled=tuple(not flag for flag in ramp.force_controlled))
        if violation is not None:
            return LimitViolation(violation.kind, violation.dof,
                                  f'{violation.message}{ramp.where}')
        if stored is not None:  # finite and well formed
            return check_strokes(stored, ramp.start, ramp.force_controlled, self._limits,
                                 self._dof_names, ramp.where)
        return None

    def advance(self) -> bool:
        """The sub-step in flight is answered and checked.

        Whether another one follows (else the ramp has ended and :attr:`ramp` is ``None``).
        """
        ramp = self.ramp
        assert ramp is not None
        ramp.index += 1
        if ramp.index < len(ramp.forces):
            return True
        self.ramp = None
        if ramp.step is None:
            self.ramp_down_note = f'ramped force down to 0 N in {len(ramp.forces)} sub-steps'
        return False

    def stop(self, message: str) -> None:
        """The bridge holds: drop the ramp in execution (a ramp-down's note says why)."""
        if self.ramping_down:
            self.ramp_down_note = f'force ramp-down stopped: {message}'
        self.ramp = None

    def cancel(self) -> None:
        """Forget the ramp in execution (an operator's reset; the hold stopped it already)."""
        self.ramp = None
