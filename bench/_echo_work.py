"""Work a ping-pong's echo does before each answer (``bench_wakeup``), and its hot cost.

``echo_work(spec)`` returns a function of no arguments the echo calls before it publishes:

- ``spin:US``: a busy wait of ``US`` µs (time spent, almost no code: the cost of a later answer
  alone);
- ``steps:K``: ``K`` times a simulator's step work with the nodes' own pieces, as in the graph
  (``bench/_wire_loop.py``): a command signed by the integrator's :class:`~pd_common.auth.Signer`
  (signed beforehand, in batches: not part of the work) is decoded, admitted by a
  :class:`~pd_common.auth.CommandGate`, served by the default test's simulated specimen, and
  answered with a reply encoded and signed as the simulator signs it. The node does a little
  more (the run's tag, the state file's line, its reply's fields): this is a lower bound.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from _wire_loop import opened_gate
from pd_common.auth import (
    WIRE_COMMAND,
    WIRE_FEEDBACK,
    Signer,
    command_payload,
    new_key,
    sign_wire_reply,
)
from pd_common.protocol import (
    Command,
    decode_command,
    encode_command,
    encode_feedback,
)
from pd_common.specimen import SpecimenServer, specimen_from_config
from pd_core.run.test_file import load_test_file

BATCH = 10_000  # commands signed ahead; a new batch (a new session and specimen) when used up
DEFAULT_TEST = (Path(__file__).resolve().parents[1] / 'src' / 'pd_integrator' / 'config'
                / 'default_test.yaml')


def _spin(microseconds: float) -> Callable[[], None]:
    seconds = microseconds * 1e-6
    clock = time.perf_counter

    def work() -> None:
        end = clock() + seconds
        while clock() < end:
            pass

    return work


class SimulatorStep:
    """One simulator step's work per call, on commands signed ahead in batches."""

    def __init__(self, test_file: Path = DEFAULT_TEST) -> None:
        self.definition = load_test_file(test_file, {})
        self._commands: list[bytes] = []
        self._next = 0
        self._batch()

    def _batch(self) -> None:
        """A new session, gate and specimen, and BATCH commands signed in that session."""
        definition = self.definition
        self.key = key = new_key()
        signer = Signer(key)
        self.gate = opened_gate(key, signer, definition.test_id)
        self.server = SpecimenServer(specimen_from_config(
            definition.specimen, base_dir=definition.base_dir, source=definition.source,
            dof_names=definition.dof_names))
        names = tuple(definition.dof_names)
        self._commands = []
        for step in range(BATCH):
            command = Command(definition.test_id, step, step * definition.dt, names,
                              tuple(1e-5 * (step % 1000) for _ in names))
            data, _ = signer.sign_wire(
                WIRE_COMMAND, lambda bare, c=command: encode_command(c, 0, bare))
            self._commands.append(data)
        self._next = 0

    def __call__(self) -> bytes:
        """Serve the next command; the reply's bytes."""
        if self._next == len(self._commands):
            self._batch()
        data = self._commands[self._next]
        self._next += 1
        decoded = decode_command(data)
        refused = self.gate.admit(command_payload(decoded.covered), decoded.signature)
        assert refused is None, refused
        command = decoded.record
        answer = self.server.handle(command.test_id, command.step, command.target_displacement,
                                    iteration=command.iteration,
                                    control_mode=command.control_mode,
                                    target_force=command.target_force)
        assert answer is not None
        stamp = time.time_ns()
        reply, _ = sign_wire_reply(self.key, WIRE_FEEDBACK,
                                   lambda bare: encode_feedback(answer, stamp, bare),
                                   decoded.signature)
        return reply


def _steps(count: int) -> Callable[[], None]:
    step = SimulatorStep()
    step()  # imports and first-call set-up done before the first ping

    def work() -> None:
        for _ in range(count):
            step()

    return work


def echo_work(spec: str) -> Callable[[], None]:
    """The work named by ``spec`` (``spin:US`` or ``steps:K``)."""
    kind, _, value = spec.partition(':')
    if kind == 'spin':
        return _spin(float(value))
    if kind == 'steps':
        return _steps(int(value))
    msg = f'echo work {spec!r}: expected spin:US or steps:K'
    raise ValueError(msg)


def hot_cost_us(spec: str, calls: int = 300, repeats: int = 5) -> float:
    """The work's cost per call run back to back in one process [µs], best of ``repeats``."""
    work = echo_work(spec)
    best = float('inf')
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(calls):
            work()
        best = min(best, time.perf_counter() - start)
    return best / calls * 1e6
