"""Answering step commands with a simulated specimen (transport-free).

The same :class:`SpecimenServer` serves the ``pd_specimen_sim`` node and the ROS-free runner,
so both compute the same forces from the same displacements.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .errors import SpecimenError

if TYPE_CHECKING:
    from collections.abc import Sequence

    from .specimen import Specimen

STATUS_OK = 0
STATUS_FAULT = 2


@dataclass(frozen=True)
class Answer:
    """The specimen's answer to one step command (mirrors ``pd_msgs/StepFeedback``)."""

    test_id: str
    step: int
    displacement: tuple[float, ...]
    force: tuple[float, ...]
    status: int = STATUS_OK
    message: str = ''
    iteration: int = 0


class SpecimenServer:
    """Moves a simulated specimen to commanded displacements and reports its forces.

    Commands are keyed by ``(step, iteration)`` (iteration 0 for explicit schemes).

    * A new step: the specimen goes to the target, its force is computed and committed; the
      measured displacement equals the target (an ideal actuator).
    * The step answered last, again (a re-sent command): the same answer, no motion.
    * An older step of the same test: ignored (``None``), counted in ``ignored``.
    * A target the model cannot take (wrong size, NaN, beyond a backbone with
      ``beyond_last_point: error``): a FAULT answer; the specimen stays where it was.

    A new test id starts fresh step bookkeeping; the specimen keeps its state (it is the same
    physical specimen, e.g. after the stiffness probe).
    """

    def __init__(self, specimen: Specimen) -> None:
        self.specimen = specimen
        self.position: tuple[float, ...] = (0.0,) * specimen.n_dof
        self.force: tuple[float, ...] = tuple(
            float(f) for f in specimen.restoring_force(np.zeros(specimen.n_dof)))
        specimen.revert_to_last_commit()
        self._last: Answer | None = None
        self.steps_served = 0
        self.repeated = 0
        self.ignored = 0
        self.faults = 0

    def handle(self, test_id: str, step: int, target: Sequence[float], *, iteration: int = 0
               ) -> Answer | None:
        """Answer the command for ``(step, iteration)`` of ``test_id``; ``None`` if ignored."""
        last = self._last
        if last is not None and last.test_id == test_id:
            key, last_key = (step, iteration), (last.step, last.iteration)
            if key == last_key:
                self.repeated += 1
                return last
            if key < last_key:
                self.ignored += 1
                return None
        answer = self._move(test_id, step, iteration, target)
        self._last = answer
        return answer

    def _move(self, test_id: str, step: int, iteration: int, target: Sequence[float]
              ) -> Answer:
        n = self.specimen.n_dof
        values = [float(value) for value in target]
        if len(values) != n or not all(math.isfinite(value) for value in values):
            return self._fault(test_id, step, iteration, f'invalid target displacement '
                               f'{values!r} (expected {n} finite values)')
        try:
            force = self.specimen.restoring_force(np.array(values))
        except SpecimenError as err:
            self.specimen.revert_to_last_commit()
            return self._fault(test_id, step, iteration, str(err))
        self.specimen.commit()
        self.position = tuple(values)
        self.force = tuple(float(f) for f in force)
        self.steps_served += 1
        return Answer(test_id=test_id, step=step, displacement=self.position, force=self.force,
                      iteration=iteration)

    def _fault(self, test_id: str, step: int, iteration: int, message: str) -> Answer:
        self.faults += 1
        return Answer(test_id=test_id, step=step, displacement=self.position, force=self.force,
                      status=STATUS_FAULT, message=message, iteration=iteration)
