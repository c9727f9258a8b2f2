"""Answering step commands with a simulated specimen (transport-free).

The same :class:`SpecimenServer` serves the ``pd_specimen_sim`` node and the ROS-free runner,
so both compute the same forces from the same displacements.

Experimental errors (thesis section 3.4.3). An optional ``errors:`` mapping in the test file's
``specimen`` section makes the simulated actuator and load cell imperfect::

    specimen:
      elements: [...]
      errors:
        systematic: -0.05         # fraction of the increment: -0.05 = 5 % undershoot, + overshoot
        delay_steps: 0            # the actuator executes the target of that many steps earlier
        displacement_noise: 0.0   # m, std of the displacement measurement noise (Gaussian)
        force_noise: 0.0          # N, std of the force measurement noise (Gaussian)
        force_bias: 0.0           # N, constant load-cell offset
        seed: 1                   # noise generator seed (omit: a different draw every run)

The model is :class:`pd_common.experimental.ErrorModel`, the one the bridge's emulator driver
also takes from its ``driver_config``, and an :class:`~pd_common.experimental.ErrorInjector`
applies it. Per new step, with the
actuator at ``x_current`` (the displacement it reached at the previous step):

* ``x_imposed = x_delayed + systematic * (x_delayed - x_current)``, where ``x_delayed`` is the
  target of ``delay_steps`` steps earlier (the initial position before the first ones); the
  specimen really goes there and its force is evaluated there;
* one draw of ``2 n_dof`` standard normal numbers per step (first the displacements', then
  the forces'): ``x_measured = x_imposed + displacement_noise * z_x`` and
  ``f_measured = f(x_imposed) + force_bias + force_noise * z_f``.

The answer reports the *measured* displacement and force. A re-sent command gets the same
answer (no new draw), so a run is deterministic for a given seed, through the node graph or the
ROS-free runner alike. Without ``errors`` (or with every value zero) nothing changes, bit for
bit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import SpecimenConfigError, SpecimenError
from ..experimental.error_model import ERRORS_KEY, ErrorInjector, ErrorModel
from ..protocol.messages import Feedback, FeedbackStatus
from .config import load_specimen_section, specimen_from_config

if TYPE_CHECKING:
    from collections.abc import Sequence

    from .specimen import Specimen

#: When a simulated specimen commits its state (``specimen.commit``).
COMMIT_MODES = ('per_command', 'per_step')


def split_errors(section: Mapping[str, Any], source: str = 'test file'
                 ) -> tuple[Any, ErrorModel | None]:
    """Separate the ``errors`` mapping from the rest of a ``specimen`` section.

    Args:
        section: The parsed ``specimen:`` mapping.
        source: Name of the YAML file, used in error messages.

    Returns:
        The section without ``errors`` (for :func:`specimen_from_config`) and the errors
        (``None`` without an ``errors`` key).

    Raises:
        SpecimenConfigError: On an invalid ``errors`` mapping.
    """
    if not isinstance(section, Mapping):
        return section, None  # specimen_from_config reports it
    rest = {key: value for key, value in section.items() if key != ERRORS_KEY}
    if ERRORS_KEY not in section:
        return rest, None
    return rest, ErrorModel.from_mapping(section[ERRORS_KEY], source)


def server_from_config(section: Mapping[str, Any], *, base_dir: Path, source: str,
                       dof_names: Sequence[str]) -> SpecimenServer:
    """The server of the specimen (and errors) described by a ``specimen:`` section.

    Args:
        section: The parsed ``specimen:`` mapping, optionally with ``errors``.
        base_dir: Directory against which relative file paths resolve.
        source: Name of the YAML file, used in error messages.
        dof_names: Names of the test's DOFs.

    Returns:
        A server around the virgin specimen.

    Raises:
        SpecimenConfigError: One line naming ``source`` and the parameter path.
    """
    rest, errors = split_errors(section, source)
    specimen = specimen_from_config(rest, base_dir=Path(base_dir), source=source,
                                    dof_names=dof_names)
    commit = rest.get('commit', 'per_command') if isinstance(rest, Mapping) else 'per_command'
    try:
        return SpecimenServer(specimen, errors=errors, commit=commit)
    except SpecimenError as err:  # names the key: 'commit: ...'
        msg = f'{source}: specimen.{err}'
        raise SpecimenConfigError(msg) from None


def load_site_server(test_file: str | Path, site: str = '',
                     dof_names: Sequence[str] | None = None
                     ) -> tuple[SpecimenServer, dict[str, Any], list[str]]:
    """The simulated specimen of a test file (or of one of its sites), as the simulator runs it.

    Args:
        test_file: the YAML test file.
        site: a site of a substructured test ('' for the test's ``specimen`` section).
        dof_names: the specimen's DOF names (default: ``structure.dof_names``, or ``a1, a2,
            ...`` for a site).

    Returns:
        The server, the specimen section and the DOF names.

    Raises:
        SpecimenError: one line naming the file and the key.
    """
    section, names = load_specimen_section(test_file, site)
    if dof_names:
        names = list(dof_names)
    elif names is None:
        elements = section.get('elements')
        names = [f'a{i + 1}' for i in range(len(elements) if isinstance(elements, list)
                                              else 1)]
    path = Path(test_file)
    try:
        server = server_from_config(section, base_dir=path.resolve().parent, source=path.name,
                                    dof_names=names)
    except SpecimenError as err:
        if not site:
            raise
        msg = str(err).replace(': specimen', f': sites.{site}.specimen', 1)
        raise SpecimenError(msg) from None
    return server, section, names


class SpecimenServer:
    """Moves a simulated specimen to commanded displacements and reports its forces.

    Commands are keyed by ``(step, iteration)`` (iteration 0 for explicit schemes).

    * A new step: the specimen goes to the target, its force is computed and committed; the
      measured displacement equals the target (an ideal actuator), unless ``errors`` are
      injected (see the module docstring).
    * The step answered last, again (a re-sent command): the same answer, no motion.
    * An older step of the same test: ignored (``None``), counted in ``ignored``.
    * A target the model cannot take (wrong size, NaN, beyond a backbone with
      ``beyond_last_point: error``): a FAULT answer; the specimen stays where it was.

    A new test id starts fresh step bookkeeping; the specimen keeps its state (it is the same
    physical specimen, e.g. after the stiffness probe).

    ``commit`` says when the specimen's state is committed:

    * ``'per_command'`` (default): at every command, as a physical specimen is — an
      iteration that overshoots and comes back has unloaded the specimen;
    * ``'per_step'``: the iterations of one step are *trials* from the state at the end of
      the previous step (OpenSees's trial/commit), and the last one is committed when a
      command of a later step (or another test) arrives. An implicit scheme with
      ``forward_only: false`` then converges to the implicit solution. A rehearsal setting:
      no physical specimen behaves so.
    """

    def __init__(self, specimen: Specimen, errors: ErrorModel | None = None,
                 commit: str = 'per_command') -> None:
        """Create the server.

        Args:
            specimen: The specimen, in the state the test starts from.
            errors: Experimental errors to inject; ``None`` (or all zero): an ideal actuator.
            commit: ``'per_command'`` or ``'per_step'`` (see the class docstring).

        Raises:
            SpecimenError: an unknown ``commit``, or ``'per_step'`` with injected errors (the
                message starts with ``commit:``).
        """
        if commit not in COMMIT_MODES:
            msg = f"commit: must be one of {', '.join(COMMIT_MODES)}, got {commit!r}"
            raise SpecimenError(msg)
        self.commit_mode = commit
        self._pending: tuple[str, int] | None = None  # (test id, step) of an uncommitted trial
        self.specimen = specimen
        self.position: tuple[float, ...] = (0.0,) * specimen.n_dof
        self.force: tuple[float, ...] = tuple(
            float(f) for f in specimen.restoring_force(np.zeros(specimen.n_dof)))
        specimen.revert_to_last_commit()
        self._last: Feedback | None = None
        self.steps_served = 0
        self.repeated = 0
        self.ignored = 0
        self.faults = 0
        self.errors = errors
        self._inject = errors is not None and not errors.is_ideal
        if self._inject and commit == 'per_step':
            msg = ('commit: per_step cannot be combined with errors (the error model moves the '
                   'specimen at every command)')
            raise SpecimenError(msg)
        self._injector = (ErrorInjector(errors, np.zeros(specimen.n_dof))
                          if errors is not None else None)

    @property
    def last(self) -> Feedback | None:
        """The answer to the command served last (what a repeat of it gets)."""
        return self._last

    @property
    def imposed(self) -> tuple[float, ...]:
        """The displacement the specimen really holds (``position`` is the measured one)."""
        if not self._inject or self._injector is None:
            return self.position
        return tuple(float(x) for x in self._injector.current)

    def handle(self, test_id: str, step: int, target: Sequence[float], *, iteration: int = 0
               ) -> Feedback | None:
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
              ) -> Feedback:
        n = self.specimen.n_dof
        values = [float(value) for value in target]
        if len(values) != n or not all(math.isfinite(value) for value in values):
            return self._fault(test_id, step, iteration, f'invalid target displacement '
                               f'{values!r} (expected {n} finite values)')
        if self._inject:
            return self._move_with_errors(test_id, step, iteration, np.array(values))
        per_step = self.commit_mode == 'per_step'
        if per_step and self._pending is not None and self._pending != (test_id, step):
            self.specimen.commit()  # the last trial of the previous step
            self._pending = None
        try:
            force = self.specimen.restoring_force(np.array(values))
        except SpecimenError as err:
            self.specimen.revert_to_last_commit()
            if self._pending is not None:  # back to the step's last accepted trial
                self.specimen.restoring_force(np.array(self.position))
            return self._fault(test_id, step, iteration, str(err))
        if per_step:
            self._pending = (test_id, step)
        else:
            self.specimen.commit()
        self.position = tuple(values)
        self.force = tuple(float(f) for f in force)
        self.steps_served += 1
        return Feedback(test_id=test_id, step=step, measured_displacement=self.position,
                        restoring_force=self.force, iteration=iteration)

    def _move_with_errors(self, test_id: str, step: int, iteration: int, target: np.ndarray
                          ) -> Feedback:
        """A new step through the error model (delay, systematic error, noise, bias)."""
        injector = self._injector
        assert injector is not None
        try:
            erroneous = injector.step(target, self.specimen.restoring_force)
        except SpecimenError as err:
            self.specimen.revert_to_last_commit()  # no motion: the delay line stays as it was
            return self._fault(test_id, step, iteration, str(err))
        self.specimen.commit()
        self.position = tuple(float(x) for x in erroneous.displacement)
        self.force = tuple(float(f) for f in erroneous.force)
        self.steps_served += 1
        return Feedback(test_id=test_id, step=step, measured_displacement=self.position,
                        restoring_force=self.force, iteration=iteration)

    def _fault(self, test_id: str, step: int, iteration: int, message: str) -> Feedback:
        self.faults += 1
        return Feedback(test_id=test_id, step=step, measured_displacement=self.position,
                        restoring_force=self.force, status=FeedbackStatus.FAULT, message=message,
                        iteration=iteration)
