"""One pseudo-dynamic test, step by step, independent of any transport.

:class:`TestSession` is the single implementation of the test loop. The ROS node publishes the
commands it hands out and feeds it the feedback it receives; the ROS-free runner calls a
specimen directly. Because both run the same calls in the same order on the same floats, their
histories are identical.

Phases: an optional stiffness *probe* (test id ``<id>:probe``), then step 0 (command the
initial displacement, measure the initial restoring force r₀), then integration steps 1..N.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

import numpy as np

from pd_common.protocol import (
    Command,
    Feedback,
    FeedbackStatus,
    Status,
    TestState,
    command_of,
)
from pd_common.types import FloatArray

from ...dynamics.stability import StabilityReport, check_stability, require_stable
from ...errors import (
    AnalysisEndedError,
    ConfigError,
    ElementLinkError,
    IntegratorError,
    PdIntegratorError,
    ProtocolError,
)
from ...schemes import SchemeParameterError, make_integrator
from ...schemes.opensees_element import OpenSeesElement
from ..collapse import Collapse, CollapseMonitor
from ..record.history import ResponseHistory
from .protocol import StepProtocol, TimeoutAction, Verdict

if TYPE_CHECKING:
    from ...schemes import Integrator
    from ..definition import TestDefinition

PROBE_SUFFIX = ':probe'


#: Up to this many DOFs a model's step values are plain tuples, checked in plain Python (the
#: structure feedback of :mod:`.coordinator` too); above it a command's target is a
#: :class:`_Target` holding its array, and the checks take one numpy pass.
SMALL_MODEL_DOF = 16


def _all_finite(values: tuple[float, ...] | FloatArray) -> bool:
    """Whether every value is finite (numpy for long vectors, plain Python for short ones)."""
    if isinstance(values, np.ndarray) or len(values) > SMALL_MODEL_DOF:
        return bool(np.isfinite(np.asarray(values, dtype=float)).all())
    return all(map(math.isfinite, values))


class _Target(tuple[float, ...]):
    """A command's target displacement.

    A tuple of floats that also holds them as the integrator's read-only array, which
    ``np.array``/``np.asarray`` return without reading the floats back one by one (the coordinator,
    the bag, the tracking check of a large model).
    """

    _array: FloatArray | None = None

    @classmethod
    def of(cls, array: FloatArray) -> _Target:
        """The tuple of ``array``'s floats (``array`` is kept, made read-only)."""
        target = cls(array.tolist())
        array.setflags(write=False)
        target._array = array
        return target

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> np.ndarray:
        array = self._array
        if array is None or (dtype is not None and np.dtype(dtype) != array.dtype):
            plain: np.ndarray = np.array(tuple(self), dtype=dtype)  # (a copy made elsewhere)
            return plain
        return array.copy() if copy else array


class TestSession:
    """Drives one test.

    Use: ``command = session.next_command()`` → send it → ``session.on_feedback(feedback)`` →
    repeat until ``session.state`` is FINISHED (or HOLDING/ABORTED). ``on_timeout()`` tells what
    to do when feedback is late.

    Attributes:
        definition: the test (with the measured stiffness once the probe is done).
        state: current :class:`TestState`.
        message: human-readable reason of the current state.
        history: committed response.
        stability: the stability report (once the stiffness is known).
        probe_stiffness: the stiffness matrix measured by the probe, if any.
        collapse: where the structure collapsed (``None``: it did not, or no ``collapse``
            section), see :mod:`.collapse`.
    """

    def __init__(self, definition: TestDefinition) -> None:
        self.definition = definition
        self.state = TestState.IDLE
        self.message = 'ready'
        self.protocol = StepProtocol(max_retries=definition.protocol.max_retries)
        self.history = ResponseHistory.allocate(definition.dof_names, definition.dt,
                                                definition.ground_acceleration)
        self.stability: StabilityReport | None = None
        self.probe_stiffness: np.ndarray | None = None
        self.collapse_monitor: CollapseMonitor | None = None
        self.collapse: Collapse | None = None
        self._integrator: Integrator | None = None
        self._step = 0  # next integration step to command
        self._probe_plan: list[tuple[float, ...]] = []
        self._probe_forces: list[tuple[float, ...] | FloatArray] = []
        self._last_command: Command | None = None
        # The last integration command and its target as the integrator's array (a large
        # model's tracking check then skips converting the command's tuple back).
        self._target: tuple[Command, FloatArray] | None = None
        self._failure: str | None = None  # a numerical failure: the test cannot go on
        # p_k = -M ι a_g(t_k) for every step, computed once.
        self._loads = definition.loads()
        if definition.needs_probe:
            self._plan_probe()
        else:
            self._setup_integrator()

    # -- public API ---------------------------------------------------------------------------
    def replay_external(self, commands: Iterable[Command]) -> None:
        """An external scheme (a served OpenSees model) takes its trials from ``commands``.

        The recorded commands of the test, in order: the record is re-run without the
        external program (``./pd replay``, ``./pd recover``). Other schemes ignore it.
        """
        if isinstance(self._integrator, OpenSeesElement):
            self._integrator.replay((c.step, c.iteration, tuple(c.target_displacement))
                                    for c in commands if c.test_id == self.definition.test_id)

    @property
    def served_element(self) -> OpenSeesElement | None:
        """The external scheme serving an OpenSees element, if the test is served."""
        integrator = self._integrator
        return integrator if isinstance(integrator, OpenSeesElement) else None

    @property
    def total_steps(self) -> int:
        """Number of integration steps of the test."""
        return self.definition.n_steps

    @property
    def committed_step(self) -> int:
        """Last committed integration step (−1 before step 0)."""
        return self.history.n_committed - 1

    @property
    def omega_dt(self) -> float:
        """ω_max·Δt of the test (NaN until the stiffness is known)."""
        return self.stability.omega_dt if self.stability is not None else math.nan

    @property
    def probing(self) -> bool:
        """Whether the stiffness probe is still running."""
        return bool(self._probe_plan) and self.probe_stiffness is None

    @property
    def accepting(self) -> bool:
        """Whether feedback is taken now (running, or paused with a step still pending)."""
        return self.state is TestState.RUNNING or (
            self.state is TestState.PAUSED and self.protocol.pending is not None)

    def next_command(self) -> Command | None:
        """The next command to send, or ``None`` (finished, holding, or one pending)."""
        if self.state in (TestState.FINISHED, TestState.ABORTED, TestState.HOLDING,
                          TestState.PAUSED, TestState.INTERRUPTED) or (
                              self.protocol.pending is not None):
            return None
        if self.probing:
            index = len(self._probe_forces)
            command = Command(test_id=self.definition.test_id + PROBE_SUFFIX, step=index,
                              test_time=0.0, dof_names=self.definition.dof_names,
                              target_displacement=self._probe_plan[index])
        else:
            try:
                command = self._integration_command()
            except AnalysisEndedError as end:  # an external integrator (OpenSees) ended the test
                self.state = TestState.FINISHED
                self.message = f'{end}; {self.committed_step} steps committed'
                return None
            except IntegratorError as err:  # a non-finite target: the response diverged
                self._fail(self._step, err)
                return None
        self.state = TestState.RUNNING
        self.message = ('probing the initial stiffness' if self.probing
                        else f'step {command.step} of {self.total_steps}')
        self.protocol.send(command)
        self._last_command = command
        return command

    def on_feedback(self, feedback: Feedback) -> Verdict:
        """Take one feedback message; returns how it was classified.

        Feedback is ignored (and counted) while holding, paused or finished. Accepted feedback
        with a non-OK status puts the test on hold; the step is not advanced.
        """
        if not self.accepting:
            self.protocol.ignore(Verdict.UNEXPECTED)
            return Verdict.UNEXPECTED
        verdict = self.protocol.verdict(feedback)
        if verdict is not Verdict.ACCEPTED:
            self.protocol.ignore(verdict)
            return verdict
        if feedback.status is not FeedbackStatus.OK:
            # The step was refused (limit or fault): it stays pending; hold, never invent.
            self._hold(f'step {feedback.step}: {feedback.status.name.lower()} reported by the '
                       f'specimen side: {feedback.message or "no reason given"}')
            return Verdict.REFUSED
        if len(feedback.restoring_force) != self.definition.n_dof or not _all_finite(
                feedback.restoring_force):
            self._hold(f'step {feedback.step}: invalid restoring force '
                       f'{list(feedback.restoring_force)!r}')
            return Verdict.REFUSED
        pending = self.protocol.pending
        assert pending is not None
        implausible = self._implausible(pending, feedback)
        if implausible is not None:
            self._hold(implausible)
            return Verdict.REFUSED
        self.protocol.accept(feedback)  # its verdict above: ACCEPTED, nothing changed since
        if pending.test_id.endswith(PROBE_SUFFIX):
            self._on_probe_feedback(feedback)
        else:
            self._on_step_feedback(pending, feedback)
        if self.state is TestState.PAUSED and self.protocol.pending is None:
            self.message = f'paused after step {self.committed_step}'
        return verdict

    def on_timeout(self) -> Command | None:
        """The feedback of the pending command is late: the command to re-send, or hold."""
        if self.protocol.pending is None or self.state is not TestState.RUNNING:
            return None
        if self.protocol.on_timeout() is TimeoutAction.HOLD:
            pending = self.protocol.pending
            self._hold(f'no feedback for step {pending.step} of {pending.test_id!r} after '
                       f'{self.protocol.max_retries} re-sends')
            return None
        return self.protocol.pending

    def hold(self, reason: str) -> None:
        """Hold now (e.g. an emergency stop): nothing more is commanded until :meth:`resume`.

        The pending step stays pending; its feedback, if it arrives while holding, is ignored
        and the step is re-sent on resume.
        """
        if self.state in (TestState.RUNNING, TestState.PAUSED, TestState.IDLE):
            self._hold(reason)

    def pause(self) -> None:
        """Stop after the pending step (operator request)."""
        if self.state is TestState.RUNNING:
            self.state = TestState.PAUSED
            self.message = 'pausing'

    def resume(self) -> Command | None:
        """Leave HOLDING/PAUSED; returns the pending command to re-send, if any.

        After a numerical failure (see :attr:`failure`) the test cannot go on: it stays on hold
        (abort it); the record up to the last committed step is intact.
        """
        if self.state not in (TestState.HOLDING, TestState.PAUSED, TestState.INTERRUPTED):
            return None
        if self._failure is not None:
            self.message = f'cannot resume: {self._failure}; abort the test'
            return None
        self.state = TestState.RUNNING
        self.message = 'resumed'
        self.protocol.attempts = 0
        return self.protocol.pending

    def interrupt(self, reason: str) -> None:
        """The integrator's process is being stopped (a signal): the test can be resumed.

        Nothing more is commanded; the record up to the last committed step is intact and
        ``./pd run --resume`` continues from it.
        """
        if self.state not in (TestState.FINISHED, TestState.ABORTED):
            self.state = TestState.INTERRUPTED
            self.message = reason

    def abort(self, reason: str) -> None:
        """End the test now (operator request or fatal error); nothing more is commanded."""
        if self.state is not TestState.FINISHED:
            self.state = TestState.ABORTED
            self.message = reason

    def status(self) -> Status:
        """The current status message."""
        return Status(test_id=self.definition.test_id, state=self.state,
                      step=max(self.committed_step, 0), total_steps=self.total_steps,
                      omega_dt=self.omega_dt, retries=self.protocol.retries,
                      ignored_messages=self.protocol.ignored_total, message=self.message)

    @property
    def failure(self) -> str | None:
        """Why the integration failed (a non-finite trial state), or ``None``."""
        return self._failure

    # -- internals ----------------------------------------------------------------------------
    def _implausible(self, pending: Command, feedback: Feedback) -> str | None:
        """Why the measured displacement cannot be committed, or ``None``.

        Why the measured displacement cannot be committed (non-finite, or too far from the
        command: ``protocol.tracking_tolerance``), or ``None``.
        """
        measured = feedback.measured_displacement
        if len(measured) != self.definition.n_dof or not _all_finite(measured):
            return (f'step {feedback.step}: invalid measured displacement {list(measured)!r} '
                    '(a fault of the measurement): not committed')
        tolerance = self.definition.protocol.tracking_tolerance
        if tolerance <= 0.0:
            return None
        target = pending.target_displacement
        if len(target) > SMALL_MODEL_DOF:  # one numpy pass (the same floats, the same worst)
            target_array = (self._target[1] if self._target is not None
                            and self._target[0] is pending else np.asarray(target, dtype=float))
            deviation = np.abs(np.asarray(measured, dtype=float) - target_array)
            worst = int(np.argmax(deviation))
            error = float(deviation[worst])
        else:
            errors = [abs(m - t) for m, t in zip(measured, target, strict=True)]
            error = max(errors)
            if error <= tolerance:
                return None
            worst = errors.index(error)  # the first largest, as argmax
        if error <= tolerance:
            return None
        name = self.definition.dof_names[worst] if worst < len(self.definition.dof_names) \
            else str(worst)
        return (f'step {feedback.step}: measured displacement of {name} {measured[worst]:.6g} m '
                f'is {error:.3g} m from the commanded {target[worst]:.6g} m '
                f'(protocol.tracking_tolerance {tolerance:g} m): not committed; check the '
                'actuator, then resume (or abort)')

    def _hold(self, reason: str) -> None:
        self.state = TestState.HOLDING
        self.message = reason

    def _fail(self, step: int, error: IntegratorError) -> None:
        """A numerical failure: revert to the last committed step and hold with the reason.

        Nothing more is commanded; the committed history stays as it is (OpenSees's
        ``revertToLastStep`` on a failed step). The failure is final: :meth:`resume` refuses.
        """
        if self._integrator is not None:
            self._integrator.revert_to_last_step()
        if isinstance(error, ElementLinkError):  # the served model's link: closed for good
            self._failure = (f'step {step}: {error}; reverted to step {self.committed_step}; '
                             'continue the test with ./pd serve --resume RUN_DIR and the '
                             'model started again')
        else:
            self._failure = (f'step {step}: numerical failure ({error}); reverted to step '
                             f'{self.committed_step}')
        self._hold(self._failure)

    def _plan_probe(self) -> None:
        """Step 0 at rest, then push each DOF by +amplitude and bring it back."""
        n = self.definition.n_dof
        amplitude = self.definition.probe.amplitude
        zero = (0.0,) * n
        plan = [zero]
        for j in range(n):
            push = tuple(amplitude if i == j else 0.0 for i in range(n))
            plan += [push, zero]
        self._probe_plan = plan

    def _on_probe_feedback(self, feedback: Feedback) -> None:
        self._probe_forces.append(feedback.restoring_force)
        if len(self._probe_forces) < len(self._probe_plan):
            return
        n = self.definition.n_dof
        amplitude = self.definition.probe.amplitude
        forces = np.array(self._probe_forces)
        stiffness = np.empty((n, n))
        for j in range(n):
            before = forces[2 * j]
            pushed = forces[2 * j + 1]
            stiffness[:, j] = (pushed - before) / amplitude
        self.probe_stiffness = 0.5 * (stiffness + stiffness.T)
        try:
            self.definition = self.definition.with_initial_stiffness(self.probe_stiffness)
            self._setup_integrator()
        except PdIntegratorError as err:  # e.g. the measured stiffness makes the test unstable
            self.abort(f'after the stiffness probe: {err}')

    def _setup_integrator(self) -> None:
        definition = self.definition
        structure = definition.structure()
        try:
            self._integrator = make_integrator(
                definition.scheme, mass=structure.mass, damping=structure.damping,
                dt=definition.dt, initial_stiffness=structure.initial_stiffness,
                **definition.scheme_parameters)
        except SchemeParameterError as err:  # unknown or out of range
            msg = f'{definition.source}: test.scheme_parameters: {err}'
            raise ConfigError(msg) from None
        self.stability = check_stability(self._integrator, structure.mass,
                                         structure.initial_stiffness, definition.dt,
                                         softening=definition.may_soften)
        require_stable(self.stability)
        if definition.collapse is not None:
            self.collapse_monitor = CollapseMonitor(
                definition.collapse, definition.dof_names, structure.initial_stiffness,
                definition.dt)

    def _integration_command(self) -> Command:
        integrator = self._integrator
        if integrator is None:
            msg = 'the integrator is not set up (probe not finished)'
            raise ProtocolError(msg)
        step = self._step
        iteration = 0
        if step == 0:
            target = np.zeros(self.definition.n_dof)
        else:
            target = integrator.predict()
            iteration = integrator.iteration
        command = command_of(self.definition.test_id, step, self.definition.time(step),
                             self.definition.dof_names,
                             (_Target.of(target) if target.size > SMALL_MODEL_DOF
                              else tuple(target.tolist())),
                             iteration, (), ())
        self._target = (command, target)
        return command

    def _on_step_feedback(self, command: Command, feedback: Feedback) -> None:
        integrator = self._integrator
        assert integrator is not None
        definition = self.definition
        step = command.step
        force = np.array(feedback.restoring_force, dtype=float)
        try:
            if step == 0:
                x0 = np.array(command.target_displacement)
                integrator.initialize(x0, np.zeros(definition.n_dof), self._loads[0], force)
            else:
                integrator.correct(force, self._loads[step])
                if integrator.phase != 'corrected':
                    return  # an implicit scheme iterates: next command (step, iteration + 1)
                integrator.commit()
        except AnalysisEndedError as end:  # OpenSees ended within a step: it stays uncommitted
            self.state = TestState.FINISHED
            self.message = f'{end}; {self.committed_step} steps committed'
            return
        except IntegratorError as err:
            self._fail(step, err)
            return
        self.history.record(step, *integrator.committed_state(),
                            feedback.restoring_force, feedback.measured_displacement)
        self._step = step + 1
        if step >= definition.n_steps:
            self.state = TestState.FINISHED
            self.message = f'all {definition.n_steps} steps committed'
        elif self.collapse_monitor is not None:
            self._check_collapse(step)

    def _check_collapse(self, step: int) -> None:
        """Stop, hold or go on at the first collapse (``collapse.action``)."""
        assert self.collapse_monitor is not None
        history = self.history
        found = self.collapse_monitor.observe(step, history.displacement,
                                              history.restoring_force)
        if found is None:
            return
        self.collapse = found
        if found.action == 'stop':
            self.state = TestState.FINISHED
            self.message = found.message()
        elif found.action == 'hold':
            self._hold(found.message())

    def summary_info(self) -> dict[str, object]:
        """Run information for ``summary.json``: scheme, stability, protocol counters, state."""
        definition = self.definition
        stability = self.stability
        info: dict[str, object] = {
            'test_id': definition.test_id,
            'scheme': definition.scheme,
            'scheme_parameters': (self._integrator.parameters if self._integrator is not None
                                  else dict(definition.scheme_parameters)),
            'numerical_damping': stability.numerical_damping if stability else math.nan,
            'state': self.state.name.lower(),
            'message': self.message,
            'failure': self._failure,
            'total_steps': definition.n_steps,
            'omega_max': stability.omega_max if stability else math.nan,
            'omega_max_dt': self.omega_dt,
            'stability_limit': stability.limit if stability else math.nan,
            'period_distortion': stability.period_distortion if stability else math.nan,
            'retries': self.protocol.retries,
            'ignored_messages': self.protocol.ignored_total,
            'ignored_by_reason': {verdict.value: count
                                  for verdict, count in self.protocol.ignored.items()},
            'ground_motion': (dict(definition.record_info) if len(definition.components) <= 1
                              else [dict(c.info) for c in definition.components]),
            'sites': list(definition.site_names),
            'initial_stiffness': (definition.initial_stiffness.tolist()
                                  if definition.initial_stiffness is not None else None),
            'initial_stiffness_probed': self.probe_stiffness is not None,
            'collapse': self.collapse.as_dict() if self.collapse is not None else None,
        }
        return info
