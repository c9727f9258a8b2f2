"""OpenSees as the integrator: the ``opensees_element`` scheme serves a ``genericClient``.

The structure is modelled and integrated in OpenSees; its tested part is a ``genericClient``
element (``ops.element('genericClient', tag, '-node', ..., '-dof', ..., '-server', port,
'127.0.0.1')``) whose DOFs are the test's DOFs, in order. This scheme is the element's server
(:mod:`pd_common.opensees`): each force the element asks for at a new trial displacement is one
command of the step protocol, ``(step, iteration)``, so the bridge's limits, the journal, the
bag and the run folder are those of every test.

Step semantics (read from OpenSees's ``GenericClient.cpp`` and checked with openseespy):

* the first ``getForce`` after a commit opens step ``k + 1`` (iteration 0); each later
  ``getForce`` at another displacement within the step is the next iteration (Newton on
  ``Newmark`` sends several); a ``getForce`` at the displacement just measured is answered
  with that measurement, without a command;
* ``commitState`` commits step ``k + 1`` with the element's trial displacement, velocity and
  acceleration (OpenSees's time must be ``(k + 1)·dt``: the test's ``dt``);
* ``DIE`` (the element is destroyed: ``wipe()`` or the end of the script) ends the test;
* queries are answered at once: ``getInitialStiff``/``getTangentStiff`` with the test's
  ``initial_stiffness``, ``getDamp``/``getMass`` with zeros (they stay in the model).

A dropped connection, a malformed or out-of-order message holds the test with the reason (the
record holds every committed step) and closes the listener: a reconnect is refused.
``forward_only`` (for physical specimens under Newton) answers an iteration that would move a
DOF back within the step with the last measured force corrected by the initial stiffness,
without commanding it (OpenFresco's advice for physical specimens: an explicit or
fixed-iteration integrator).
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

from pd_common.opensees import (
    COMMIT,
    END,
    FORCE,
    ElementLink,
    ElementProtocolError,
    Trial,
    allow_list,
)
from pd_common.registry import Parameter

from ..errors import AnalysisEndedError, ElementLinkError, IntegratorError
from .base import COMMITTED, CORRECTED, ITERATING, PREDICTED, Integrator

__all__ = ['OpenSeesElement']

LOG = logging.getLogger('pd.element_server')


class OpenSeesElement(Integrator):
    """Serve OpenSees's ``genericClient``: OpenSees integrates, the test measures the forces."""

    name = 'opensees_element'
    stability_limit = math.inf
    needs_initial_stiffness = True
    accuracy_order = 2
    external = True
    softening_note = 'OpenSees integrates: its own integrator and algorithm decide'
    PARAMETERS = (
        Parameter('port', 44000, 'TCP port of the element (its -server PORT); 0: any free one',
                  low=0, high=65535, integer=True),
        Parameter('host', '127.0.0.1', 'address to bind; another than loopback needs '
                  'allow_remote and allow'),
        Parameter('allow', '', 'client addresses that may connect, comma separated'),
        Parameter('allow_remote', False, 'bind a non-loopback address (the link has no '
                  'authentication)'),
        Parameter('timeout', 600.0, 'seconds to wait for the element or its next message',
                  low=0.0, high=1e6, low_open=True),
        Parameter('forward_only', False, 'never command an iteration that moves a DOF back '
                  'within a step (answer it with the initial stiffness)'),
    )

    def _apply_parameters(self, parameters: Any) -> None:
        self._port = int(parameters['port'])
        self._host = str(parameters['host'])
        self._allow = allow_list(str(parameters['allow']))
        self._allow_remote = bool(parameters['allow_remote'])
        self._timeout = float(parameters['timeout'])
        self._forward_only_flag = bool(parameters['forward_only'])

    def _setup(self) -> None:
        self._link: ElementLink | None = None
        self._pending: Trial | None = None  # a force request read ahead (next iteration)
        self._measured: tuple[np.ndarray, np.ndarray] | None = None  # (x, r) in this step
        self._start: np.ndarray | None = None  # committed x when the step began
        self._direction: np.ndarray | None = None
        self.held_iterations = 0
        self.serving: str = ''
        #: Called about every half second while the server waits for the element (its
        #: connection, its next message): a node's heartbeat goes on while OpenSees builds its
        #: model or computes a step.
        self.idle: Callable[[], None] | None = None
        self._recorded: deque[tuple[int, tuple[float, ...]]] | None = None
        self._recorded_open: tuple[int, tuple[float, ...]] | None = None

    def replay(self, commands: Iterable[tuple[int, int, tuple[float, ...]]]) -> None:
        """Take the element's trials from a record, not from OpenSees (replay, recover).

        ``commands`` are the recorded ``(step, iteration, target)`` of the test, in order
        (re-sends are taken once). Each is a force request; a later step's first command
        commits the step before it with its last target. OpenSees's committed velocity and
        acceleration are not in the record: they are NaN. A step with no later command is not
        known to be committed: the replay ends before it.
        """
        seen: set[tuple[int, int]] = set()
        queue: deque[tuple[int, tuple[float, ...]]] = deque()
        for step, iteration, target in commands:
            if step >= 1 and (step, iteration) not in seen:
                seen.add((step, iteration))
                queue.append((step, tuple(target)))
        self._recorded = queue
        self._recorded_open = None

    def _recorded_event(self, queue: deque[tuple[int, tuple[float, ...]]]
                        ) -> tuple[str, Trial | None]:
        unknown = (math.nan,) * self._n
        opened = self._recorded_open
        if opened is not None and (not queue or queue[0][0] > opened[0]):
            if not queue:
                return END, None
            self._recorded_open = None
            return COMMIT, Trial(opened[1], unknown, unknown, opened[0] * self._dt)
        if not queue:
            return END, None
        self._recorded_open = queue.popleft()
        step, target = self._recorded_open
        return FORCE, Trial(target, unknown, unknown, step * self._dt)

    # -- the link -----------------------------------------------------------------------------
    def open(self) -> ElementLink:
        """Bind the server socket (once); returns the link (its ``port`` is the bound one).

        Raises:
            IntegratorError: The address, the allow-list or the port is refused.
        """
        if self._link is None:
            try:
                self._link = ElementLink(self._host, self._port, self._allow,
                                         self._allow_remote, self._timeout)
            except ElementProtocolError as err:
                msg = f'scheme_parameters.{err}'
                raise IntegratorError(msg) from None
            for warning in self._link.warnings:
                LOG.warning('%s', warning)
            self.serving = f'{self._host}:{self._link.port}'
        self._link.idle = self.idle
        return self._link

    def connect(self) -> None:
        """Bind (once) and wait for the element's connection and size message.

        Raises:
            IntegratorError: The address is refused, no element connected within ``timeout``,
                or its size message is refused (the listener is then closed).
        """
        link = self.open()
        if not link.connected:
            try:
                link.accept(self._stiffness)
            except ElementProtocolError as err:
                raise self._fault(err) from None

    def close(self) -> None:
        """Close the connection and the listener (a later client is refused)."""
        if self._link is not None:
            self._link.shutdown()

    def _fault(self, err: ElementProtocolError) -> ElementLinkError:
        self.close()
        return ElementLinkError(f'OpenSees element: {err}')

    def _stiffness(self, n: int) -> list[list[float]]:
        if n != self._n:
            msg = f'the genericClient element has {n} DOFs, the test {self._n}'
            raise ElementProtocolError(msg)
        assert self._initial_stiffness is not None
        stiffness: list[list[float]] = self._initial_stiffness.tolist()
        return stiffness

    def _next_event(self) -> tuple[str, Trial | None]:
        if self._recorded is not None:
            return self._recorded_event(self._recorded)
        link = self.open()
        try:
            if not link.connected:
                link.accept(self._stiffness)
            event = link.next_event()
        except ElementProtocolError as err:
            raise self._fault(err) from None
        return event.kind, event.trial

    # -- the scheme ---------------------------------------------------------------------------
    def _initial_acceleration(self, x0: Any, v0: Any, p0: Any, r0: Any) -> Any:
        return 0.0 if self._scalar else np.zeros(self._n)

    def _on_initialize(self) -> None:
        self._pending = None
        self._measured = None

    def _value(self, values: tuple[float, ...]) -> Any:
        return float(values[0]) if self._scalar else np.array(values, dtype=float)

    def _predict(self) -> Any:
        if self._pending is not None:
            pending, self._pending = self._pending, None
            return self._value(pending.displacement)
        kind, trial = self._next_event()
        while kind == FORCE and trial is not None and self._committed_query(trial):
            self._answer(np.atleast_1d(np.asarray(self._r, dtype=float)),
                         np.array(trial.displacement, dtype=float))
            kind, trial = self._next_event()
        if kind == END:
            self.close()
            msg = f'OpenSees ended the analysis after step {self._step}'
            raise AnalysisEndedError(msg)
        if kind != FORCE or trial is None:  # the exchange refuses a commit before a force
            msg = f'OpenSees element: unexpected {kind} before a getForce'
            raise IntegratorError(msg)
        self._start = np.atleast_1d(np.asarray(self._x, dtype=float)).copy()
        self._direction = None
        self._measured = None
        return self._value(trial.displacement)

    def _committed_query(self, trial: Trial) -> bool:
        """A ``getForce`` at the committed state (a recorder, ``eleResponse``): no new step."""
        if self._step == 0 or trial.time > self._step * self._dt + 1e-9 * self._dt:
            return False
        committed = np.atleast_1d(np.asarray(self._x, dtype=float))
        return bool(np.array_equal(np.array(trial.displacement, dtype=float), committed))

    def _correct(self, restoring_force: Any, load: Any) -> tuple[Any, Any]:
        raise NotImplementedError  # correct() is the scheme's own (see below)

    def correct(self, restoring_force: Any, load: Any) -> None:
        """Answer the element's ``getForce`` with the measured force; read on to its next act.

        The phase becomes ``'iterating'`` (the element asks for a force elsewhere) or
        ``'corrected'`` (it committed the step).

        Raises:
            IntegratorError: Before :meth:`predict`, on a fault of the link, or if OpenSees's
                time is not the test's. :class:`~..errors.AnalysisEndedError` if the element ended
                before committing.
        """
        if self._status != 'running' or self._phase != PREDICTED:
            msg = f'correct: step {self._step + 1} has not been predicted'
            raise IntegratorError(msg)
        force = np.atleast_1d(self._vector(restoring_force, 'restoring_force')).copy()
        target = np.atleast_1d(np.asarray(self._xt, dtype=float)).copy()
        self._measured = (target, force)
        self._update_direction(target)
        self._answer(force, target)
        while True:
            kind, trial = self._next_event()
            if kind == END:
                self.close()
                msg = f'OpenSees ended the analysis within step {self._step + 1}'
                raise AnalysisEndedError(msg)
            assert trial is not None
            if kind == COMMIT:
                self._commit_trial(trial, force, load)
                return
            displacement = np.array(trial.displacement, dtype=float)
            if np.array_equal(displacement, target):
                self._answer(force, target)  # the same displacement: no command
                continue
            held = self._held_force(displacement)
            if held is not None:
                self._answer(held, displacement)
                continue
            self._pending = trial
            self._iteration += 1
            self._phase = ITERATING
            return

    def _answer(self, force: np.ndarray, displacement: np.ndarray) -> None:
        if self._recorded is not None:
            return  # a replay: OpenSees is not there
        assert self._link is not None
        try:
            self._link.answer_force(force.tolist(), displacement.tolist())
        except ElementProtocolError as err:
            raise self._fault(err) from None

    def _update_direction(self, target: np.ndarray) -> None:
        if self._start is None:
            return
        move = np.sign(target - self._start)
        if self._direction is None:
            self._direction = move
        else:
            self._direction = np.where(self._direction == 0.0, move, self._direction)

    def _held_force(self, displacement: np.ndarray) -> np.ndarray | None:
        """With ``forward_only``: the force answered to an iteration moving a DOF back."""
        if not self._forward_only_flag or self._measured is None or self._direction is None:
            return None
        last_x, last_r = self._measured
        back = np.sign(displacement - last_x) * self._direction < 0.0
        if not bool(np.any(back)):
            return None
        assert self._initial_stiffness is not None
        self.held_iterations += 1
        held: np.ndarray = last_r + np.asarray(self._initial_stiffness) @ (displacement - last_x)
        return held

    def _commit_trial(self, trial: Trial, force: np.ndarray, load: Any) -> None:
        time = (self._step + 1) * self._dt
        if abs(trial.time - time) > 1e-6 * self._dt:
            self.close()
            msg = (f'OpenSees element: step {self._step + 1} committed at t = {trial.time:.9g} '
                   f's, the test expects {time:.9g} s: use the test\'s dt ({self._dt:g} s) in '
                   'analyze()')
            raise IntegratorError(msg)
        self._xt = self._value(trial.displacement)
        self._vt = self._value(trial.velocity)
        self._at = self._value(trial.acceleration)
        self._rt = self._value(tuple(force.tolist()))
        self._pt = load
        self._phase = CORRECTED

    def _on_commit(self) -> None:
        self._pending = None

    def _on_revert(self) -> None:
        self._pending = None
        self._phase = COMMITTED
