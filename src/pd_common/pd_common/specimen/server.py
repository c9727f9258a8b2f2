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

Mixed control and the site's geometry (issue 16). A command may give per actuator a control
mode (``control_mode``: 0 displacement, 1 force) and a target force (``target_force`` [N]); the
server may have a ``setup`` (an :class:`~pd_common.experimental.ExperimentalSetup`: the
actuators' strokes ``d(b)`` of the specimen's basic displacement ``b``; without one each
actuator is one basic DOF). The server finds the basic displacement ``b`` at which every
displacement-controlled actuator ``i`` is at its target, ``d_i(b) = target_displacement_i``,
and every force-controlled one ``j`` holds its force, ``f_j(b) = target_force_j``, with the
actuator forces ``f(b) = J(b)^{-T} R(b)`` (``J = ∂d/∂b``, ``R`` the specimen's restoring force
in basic coordinates): Newton iterations on trial evaluations of the specimen, started from the
basic displacement the specimen holds, with the specimen's trial tangent and the setup's
geometric stiffness ``∂(Jᵀ f)/∂b`` (central differences of ``J``), converged to
``|d_i − target_i| <= 1e-13 (1 + max |target|)`` m and ``|f_j − target_j| <= 1e-10 (1 +
max(|target_force|, |f|))`` N. For a one-to-one site the displacement-controlled DOFs are set
to their targets exactly and the iterations solve for the force-controlled ones only. It
answers ``measured_displacement = d(b)`` and ``restoring_force = f(b)``; if the iterations do
not converge (or the model cannot take a trial) the answer is a FAULT of one line and the
specimen stays where it was. A force-controlled DOF's ``target_displacement`` is the
displacement last measured there: checked finite, never imposed.

The specimen's own force controller never jumps: with ``max_force_increment`` > 0 a force
change goes from the force the actuator *holds* (its last commanded force, 0 at the start) to
the target through :func:`~pd_common.experimental.force_ramp.force_ramp` sub-steps, each
actuator along its own ramp (one that arrives earlier holds its target), the
displacement-controlled actuators at the command's targets from the first sub-step; each
sub-step is a committed specimen state and the answer is the last one's. A fault in the
middle of a ramp leaves the specimen at the last sub-step reached (the states before it were
really gone through; the held forces are theirs). Plain commands (no force-controlled
actuator) to a one-to-one site are served exactly as before, bit for bit.

Not combined: injected ``errors`` (which act on a one-to-one specimen's actuators) with a
setup are refused at construction and with a force-controlled command by a FAULT answer;
``commit: per_step`` with ``max_force_increment`` > 0 is refused at construction (a ramp
commits every sub-step).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..config.schema_test_file import ExperimentalElement, SiteSettings
from ..config.test_file import TestFile
from ..errors import SetupError, SpecimenConfigError, SpecimenError
from ..experimental.error_model import ERRORS_KEY, ErrorInjector, ErrorModel
from ..experimental.force_ramp import force_ramp
from ..experimental.setups import ExperimentalSetup, OneToOneSetup, setup_from_config
from ..protocol.answers import KeyedAnswers
from ..protocol.frozen import feedback_of
from ..protocol.messages import Command, Feedback, FeedbackStatus, StateOrigin
from .config import (
    load_specimen_section,
    model_from_config,
    read_specimen_test_file,
)

if TYPE_CHECKING:
    from collections.abc import Sequence

    from numpy.typing import NDArray

    from ..config.schema_test_file import Element
    from .column import ColumnSpecimen
    from .specimen import Specimen

#: When a simulated specimen commits its state (``specimen.commit``).
COMMIT_MODES = ('per_command', 'per_step')
#: Newton iterations of a mixed command before it is a FAULT.
NEWTON_ITERATIONS = 50
#: Convergence: ``|d_i − target_i| <= DISPLACEMENT_TOLERANCE (1 + max |target|)`` [m].
DISPLACEMENT_TOLERANCE = 1.0e-13
#: Convergence: ``|f_j − target_j| <= FORCE_TOLERANCE (1 + max(|target|, |f|))`` [N].
FORCE_TOLERANCE = 1.0e-10
#: Central-difference step [m, rad] of the setup's geometric stiffness.
GEOMETRY_STEP = 1.0e-6


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
                       dof_names: Sequence[str], setup: ExperimentalSetup | None = None,
                       max_force_increment: float = 0.0) -> SpecimenServer:
    """The server of the specimen (and errors) described by a ``specimen:`` section.

    Args:
        section: The parsed ``specimen:`` mapping, optionally with ``errors``.
        base_dir: Directory against which relative file paths resolve.
        source: Name of the YAML file, used in error messages.
        dof_names: Names of the DOFs served (the site's actuators).
        setup: The site's setup (actuator strokes of the specimen's basic DOFs); ``None``:
            one actuator per basic DOF. See :func:`site_geometry`.
        max_force_increment: [N] the largest force change of one sub-step (0: no ramp).

    Returns:
        A server around the virgin specimen.

    Raises:
        SpecimenConfigError: One line naming ``source`` and the parameter path.
    """
    rest, errors = split_errors(section, source)
    specimen = model_from_config(rest, base_dir=Path(base_dir), source=source,
                                 dof_names=dof_names)
    names = list(dof_names)
    served = specimen.n_dof if setup is None else setup.n_actuators
    if setup is not None and setup.n_basic != specimen.n_dof:
        msg = (f'{source}: specimen: the setup has {setup.n_basic} basic DOFs but the '
               f'specimen {specimen.n_dof}')
        raise SpecimenConfigError(msg)
    if len(names) != served:
        msg = (f'{source}: specimen: {served} actuators but {len(names)} DOF names {names}')
        raise SpecimenConfigError(msg)
    commit = rest.get('commit', 'per_command') if isinstance(rest, Mapping) else 'per_command'
    try:
        return SpecimenServer(specimen, errors=errors, commit=commit, setup=setup,
                              max_force_increment=max_force_increment)
    except SpecimenError as err:  # names the key: 'commit: ...'
        key = str(err).split(':', 1)[0]
        msg = f'{source}: {err}' if '.' in key else f'{source}: specimen.{err}'
        raise SpecimenConfigError(msg) from None


@dataclass(frozen=True)
class SiteGeometry:
    """What a simulated site takes from the test file besides its ``specimen`` section.

    Attributes:
        setup: the setup of the site's experimental element (``None``: one-to-one).
        max_force_increment: [N] ``sites.<site>.bridge.max_force_increment``, 0 without one
            (and for the test's own specimen).
        actuators: the element's ``actuators`` names, when the test file gives them.
    """

    setup: ExperimentalSetup | None = None
    max_force_increment: float = 0.0
    actuators: tuple[str, ...] | None = None


def site_geometry(elements: Sequence[Element] | None, settings: SiteSettings | None,
                  site: str, source: str) -> SiteGeometry:
    """The setup and force ramp of ``site`` ('' for the test's own specimen) in a test file.

    Read from the typed test file (:class:`~pd_common.config.TestFileModel`): its
    ``structure.elements`` and the site's settings (``sites.<site>``), whose values the schema
    has checked (``bridge.max_force_increment`` a number >= 0 [N], an element's ``dofs`` a
    non-empty list, its ``actuators`` names).

    The setup is the ``setup`` of the ``structure.elements`` entry of type ``experimental``
    whose ``site`` is ``site`` (built by
    :func:`~pd_common.experimental.setups.setup_from_config` with as many basic DOFs as the
    element's ``dofs``): one source of truth for the integrator and the simulator. A site with
    several experimental elements is simulated one-to-one (each must have a ``one_to_one``
    setup). A one-to-one setup is ``None``.

    The simulator emulates the setup's geometry only for a specimen given in basic coordinates
    (a ``column`` specimen); a specimen of ``elements`` is given per actuator, as it always
    was, and is simulated without a setup (its force-controlled actuators, if any, hold their
    forces on their own elements). One rule for the simulator node and the ROS-free runs.

    Args:
        elements: the typed ``structure.elements`` (``None``: a test without elements).
        settings: the typed ``sites.<site>`` (``None``: none given).
        site: the site ('' for the test's own specimen: no setup, no ramp).
        source: the test file's name, for messages.

    Raises:
        SpecimenConfigError: one line naming ``source`` and the key.
    """
    if not site:
        return SiteGeometry()
    bridge = settings.bridge if settings is not None else None
    increment = bridge.max_force_increment if bridge is not None else 0.0
    mine = [(index, item) for index, item in enumerate(elements or ())
            if isinstance(item, ExperimentalElement) and item.site == site]
    setups: list[ExperimentalSetup] = []
    names: list[str] = []
    named = True
    for index, item in mine:
        path = f'{source}: structure.elements[{index}]'
        given = None if item.setup is None else item.setup.model_dump(exclude_unset=True)
        try:
            setups.append(setup_from_config(given, len(item.dofs), f'{path}.setup'))
        except SetupError as err:
            raise SpecimenConfigError(str(err)) from None
        if item.actuators is not None:
            names.extend(item.actuators)
        else:
            named = False
        if len(mine) > 1 and not isinstance(setups[-1], OneToOneSetup):
            msg = (f'{path}.setup: site {site!r} has {len(mine)} experimental elements: its '
                   'simulator takes one_to_one setups only')
            raise SpecimenConfigError(msg)
    setup = setups[0] if len(setups) == 1 and not isinstance(setups[0], OneToOneSetup) else None
    specimen = settings.specimen if settings is not None else None
    if specimen is None or specimen.column is None:
        setup = None  # a specimen per actuator
    return SiteGeometry(setup, increment, tuple(names) if mine and named else None)


def load_site_server(test_file: str | Path | TestFile, site: str = '',
                     dof_names: Sequence[str] | None = None
                     ) -> tuple[SpecimenServer, dict[str, Any], list[str]]:
    """The simulated specimen of a test file (or of one of its sites), as the simulator runs it.

    Args:
        test_file: the YAML test file, or the file read already (``read_test_file``).
        site: a site of a substructured test ('' for the test's ``specimen`` section).
        dof_names: the specimen's DOF names (default: ``structure.dof_names``; for a site its
            experimental element's ``actuators``, else ``a1, a2, ...``).

    Returns:
        The server (with the site's setup and force ramp, see :func:`site_geometry`), the
        specimen section and the DOF names.

    Raises:
        SpecimenError: one line naming the file and the key.
    """
    test = (test_file if isinstance(test_file, TestFile)
            else read_specimen_test_file(test_file))
    section, names = load_specimen_section(test, site)
    path = test.path
    model = test.model
    settings = (model.sites or {}).get(site) if site else None
    geometry = site_geometry(model.structure.elements, settings, site, path.name)
    if dof_names:
        names = list(dof_names)
    elif names is None:
        if geometry.actuators is not None:
            names = list(geometry.actuators)
        else:
            specimen = settings.specimen if settings is not None else None
            count = (geometry.setup.n_actuators if geometry.setup is not None
                     else 1 if specimen is None  # (load_specimen_section has refused it)
                     else len(specimen.elements) if specimen.elements is not None
                     else 2 if specimen.column is not None else 1)
            names = [f'a{i + 1}' for i in range(count)]
    try:
        server = server_from_config(section, base_dir=path.resolve().parent, source=path.name,
                                    dof_names=names, setup=geometry.setup,
                                    max_force_increment=geometry.max_force_increment)
    except SpecimenError as err:
        if not site:
            raise
        msg = str(err).replace(': specimen', f': sites.{site}.specimen', 1)
        raise SpecimenError(msg) from None
    return server, section, names


class _NoSolutionError(Exception):
    """A mixed command the specimen cannot take (its one-line reason)."""


class SpecimenServer(KeyedAnswers):
    """Moves a simulated specimen to commanded displacements and reports its forces.

    Commands are keyed by ``(step, iteration)`` (iteration 0 for explicit schemes).

    * A new step: the specimen goes to the target, its force is computed and committed; the
      measured displacement equals the target (an ideal actuator), unless ``errors`` are
      injected (see the module docstring).
    * The step answered last, again (a re-sent command): the same answer, no motion.
    * An older step of the same test: ignored (``None``), counted in ``ignored``.
    * A target the model cannot take (wrong size, NaN, beyond a backbone with
      ``beyond_last_point: error``): a FAULT answer; the specimen stays where it was.
    * Force-controlled actuators and a setup: see the module docstring (mixed control).

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

    def __init__(self, specimen: Specimen | ColumnSpecimen, errors: ErrorModel | None = None,
                 commit: str = 'per_command', *, setup: ExperimentalSetup | None = None,
                 max_force_increment: float = 0.0) -> None:
        """Create the server.

        Args:
            specimen: The specimen, in the state the test starts from.
            errors: Experimental errors to inject; ``None`` (or all zero): an ideal actuator.
            commit: ``'per_command'`` or ``'per_step'`` (see the class docstring).
            setup: The actuators' strokes of the specimen's (basic) DOFs; ``None``: one
                actuator per DOF.
            max_force_increment: [N] the largest force change of one sub-step (0: none).

        Raises:
            SpecimenError: an unknown ``commit``, ``'per_step'`` with injected errors or with a
                force ramp (the message starts with ``commit:``), errors with a setup
                (``errors:``), a setup of another size (``setup:``) or a negative
                ``max_force_increment``.
        """
        super().__init__()
        if commit not in COMMIT_MODES:
            msg = f"commit: must be one of {', '.join(COMMIT_MODES)}, got {commit!r}"
            raise SpecimenError(msg)
        increment = max_force_increment
        if isinstance(increment, bool) or not isinstance(increment, (int, float)) or not (
                math.isfinite(increment) and increment >= 0.0):
            msg = f'max_force_increment: must be a number >= 0 [N], got {increment!r}'
            raise SpecimenError(msg)
        if setup is not None and (setup.n_basic != specimen.n_dof
                                  or setup.n_actuators != setup.n_basic):
            msg = (f'setup: {setup.n_actuators} actuators and {setup.n_basic} basic DOFs for a '
                   f'specimen of {specimen.n_dof} DOFs (needs as many of each)')
            raise SpecimenError(msg)
        self.commit_mode = commit
        self._pending: tuple[str, int] | None = None  # (test id, step) of an uncommitted trial
        self.specimen = specimen
        self.setup = None if isinstance(setup, OneToOneSetup) else setup
        self.max_force_increment = float(increment)
        n = specimen.n_dof
        self.position: tuple[float, ...] = (0.0,) * n
        if self.setup is None:
            self.force: tuple[float, ...] = tuple(
                float(f) for f in specimen.restoring_force(np.zeros(n)))
        else:
            zero = np.zeros(n)
            self.position = tuple(float(d) for d in self.setup.actuator_targets(zero))
            self.force = tuple(float(f) for f in np.linalg.solve(
                self.setup.jacobian(zero).T, specimen.restoring_force(zero)))
        specimen.revert_to_last_commit()
        #: The specimen's basic displacement [m] (its DOFs), of the state it holds.
        self.basic: tuple[float, ...] = (0.0,) * n
        #: Per actuator, the force it holds [N]: the last force commanded to it (0 at start).
        self.held: tuple[float, ...] = (0.0,) * n
        self.steps_served = 0
        #: Specimen states a force ramp went through (each committed), over all commands.
        self.ramp_substeps = 0
        self.faults = 0
        self.errors = errors
        self._inject = errors is not None and not errors.is_ideal
        if self._inject and commit == 'per_step':
            msg = ('commit: per_step cannot be combined with errors (the error model moves the '
                   'specimen at every command)')
            raise SpecimenError(msg)
        if commit == 'per_step' and self.max_force_increment > 0.0:
            msg = ('commit: per_step cannot be combined with a force ramp (max_force_increment '
                   '> 0 commits every sub-step)')
            raise SpecimenError(msg)
        if self._inject and self.setup is not None:
            msg = ('errors: injected errors cannot be combined with a setup (the error model '
                   "acts on a one-to-one specimen's actuators)")
            raise SpecimenError(msg)
        self._injector = (ErrorInjector(errors, np.zeros(specimen.n_dof))
                          if errors is not None else None)

    @property
    def imposed(self) -> tuple[float, ...]:
        """The displacement the specimen really holds (``position`` is the measured one)."""
        if not self._inject or self._injector is None:
            return self.position
        return tuple(float(x) for x in self._injector.current)

    @property
    def geometry(self) -> dict[str, Any] | None:
        """The setup and force ramp, as data (``None``: one-to-one, no ramp).

        Part of the specimen's fingerprint
        (:func:`~pd_common.specimen.served.specimen_fingerprint`).
        """
        if self.setup is None and self.max_force_increment == 0.0:
            return None
        setup = None if self.setup is None else {
            'type': type(self.setup).__name__,
            **{key: value.tolist() if isinstance(value, np.ndarray) else value
               for key, value in sorted(vars(self.setup).items()) if not key.startswith('_')}}
        return {'setup': setup, 'max_force_increment': self.max_force_increment}

    def _move(self, test_id: str, step: int, iteration: int, target: Sequence[float],
              control_mode: Sequence[int], target_force: Sequence[float]) -> Feedback:
        n = self.specimen.n_dof
        values = [float(value) for value in target]
        if len(values) != n or not all(map(math.isfinite, values)):
            return self._fault(test_id, step, iteration, f'invalid target displacement '
                               f'{values!r} (expected {n} finite values)')
        command: Command | None = None
        if control_mode or target_force or self.setup is not None:
            # (none of them: every DOF displacement-controlled, one-to-one: nothing more to
            # check, and no Command to build)
            try:
                command = Command(test_id=test_id, step=step, test_time=0.0, dof_names=(),
                                  target_displacement=tuple(values), iteration=iteration,
                                  control_mode=tuple(int(mode) for mode in control_mode),
                                  target_force=tuple(float(force) for force in target_force))
            except (TypeError, ValueError) as err:
                return self._fault(test_id, step, iteration, f'invalid control: {err}')
            problem = command.control_error()
            if problem is not None:
                return self._fault(test_id, step, iteration, f'invalid control: {problem}')
        if command is not None and (command.mixed or self.setup is not None):
            if command.mixed and self._inject:
                return self._fault(test_id, step, iteration, 'force control cannot be combined '
                                   'with injected errors (specimen.errors)')
            return self._move_solved(test_id, step, iteration, values,
                                     command.force_controlled(), command.target_force)
        if self._inject:
            return self._move_with_errors(test_id, step, iteration, np.array(values))
        per_step = self.commit_mode == 'per_step'
        if per_step and self._pending is not None and self._pending != (test_id, step):
            self.specimen.commit()  # the last trial of the previous step
            self._pending = None
        try:
            force = self.specimen.restoring_force(values)  # checked there (it is public)
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
        self.basic = self.position
        self.force = tuple(np.asarray(force, dtype=float).tolist())
        self.steps_served += 1
        return feedback_of(test_id, step, self.position, self.force, FeedbackStatus.OK, '',
                           iteration, '', StateOrigin.FRESH)

    def _move_solved(self, test_id: str, step: int, iteration: int, targets: list[float],
                     force_controlled: tuple[bool, ...], forces: tuple[float, ...]
                     ) -> Feedback:
        """A command solved for the basic displacement (mixed control or a setup)."""
        per_step = self.commit_mode == 'per_step'
        if per_step and self._pending is not None and self._pending != (test_id, step):
            self.specimen.commit()  # the last trial of the previous step
            self._pending = None
        controlled = [j for j, flag in enumerate(force_controlled) if flag]
        ramps = {j: force_ramp(self.held[j], forces[j], self.max_force_increment)
                 for j in controlled}
        count = max([1, *(len(ramp) for ramp in ramps.values())])
        for sub in range(count):
            held = list(self.held)
            for j, ramp in ramps.items():
                held[j] = ramp[min(sub, len(ramp) - 1)] if ramp else forces[j]
            try:
                basic, strokes, actuator_force = self._solve(targets, controlled, held)
            except (_NoSolutionError, SpecimenError) as err:
                self.specimen.revert_to_last_commit()
                if self._pending is not None:  # back to the step's last accepted trial
                    self.specimen.restoring_force(np.array(self.basic))
                where = f' (force ramp sub-step {sub + 1} of {count})' if count > 1 else ''
                return self._fault(test_id, step, iteration, f'{err}{where}')
            if per_step:
                self._pending = (test_id, step)
            else:
                self.specimen.commit()
            if count > 1:
                self.ramp_substeps += 1
            self.basic = tuple(float(x) for x in basic)
            self.position = tuple(float(d) for d in strokes)
            self.force = tuple(float(f) for f in actuator_force)
            self.held = tuple(held)
        self.steps_served += 1
        return feedback_of(test_id, step, self.position, self.force, FeedbackStatus.OK, '',
                           iteration, '', StateOrigin.FRESH)

    def _solve(self, targets: list[float], controlled: list[int], forces: list[float]
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The basic displacement, strokes and actuator forces of one (sub-)step.

        Leaves the specimen's trial state at the solution.

        Raises:
            _NoSolutionError: the iterations did not converge.
            SpecimenError: the model cannot take a trial on the way.
        """
        if self.setup is None:
            return self._solve_one_to_one(targets, controlled, forces)
        setup = self.setup
        free = [i for i in range(len(targets)) if i not in controlled]
        target = np.array(targets)
        wanted = np.array(forces)
        b = np.array(self.basic, dtype=float)
        d_tolerance = DISPLACEMENT_TOLERANCE * (1.0 + float(np.max(np.abs(target[free]),
                                                                   initial=0.0)))
        for _ in range(NEWTON_ITERATIONS):
            strokes = np.asarray(setup.actuator_targets(b), dtype=float)
            jacobian = np.asarray(setup.jacobian(b), dtype=float)
            restoring = np.asarray(self.specimen.restoring_force(b), dtype=float)
            try:
                actuator_force = np.linalg.solve(jacobian.T, restoring)
            except np.linalg.LinAlgError:
                break
            d_residual = strokes[free] - target[free]
            f_residual = actuator_force[controlled] - wanted[controlled]
            f_scale = 1.0 + max(float(np.max(np.abs(wanted[controlled]), initial=0.0)),
                                float(np.max(np.abs(actuator_force))))
            if (float(np.max(np.abs(d_residual), initial=0.0)) <= d_tolerance
                    and float(np.max(np.abs(f_residual), initial=0.0))
                    <= FORCE_TOLERANCE * f_scale):
                return b, strokes, actuator_force
            stiffness = self.specimen.tangent(b) - self._geometric_stiffness(b, actuator_force)
            d_force = np.linalg.solve(jacobian.T, stiffness)  # ∂f/∂b
            system = np.vstack((jacobian[free], d_force[controlled]))
            try:
                b = b - np.linalg.solve(system, np.concatenate((d_residual, f_residual)))
            except np.linalg.LinAlgError:
                break
            if not np.all(np.isfinite(b)):
                break
        raise _NoSolutionError(self._no_solution(targets, controlled, forces))

    def _solve_one_to_one(self, targets: list[float], controlled: list[int],
                          forces: list[float]
                          ) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                     NDArray[np.float64]]:
        """Displacement-controlled DOFs at their targets exactly; Newton on the others."""
        b = np.array(targets, dtype=float)
        start = np.array(self.basic, dtype=float)
        b[controlled] = start[controlled]
        wanted = np.array(forces)[controlled]
        for _ in range(NEWTON_ITERATIONS):
            restoring = np.asarray(self.specimen.restoring_force(b), dtype=float)
            residual = restoring[controlled] - wanted
            scale = 1.0 + max(float(np.max(np.abs(wanted), initial=0.0)),
                              float(np.max(np.abs(restoring))))
            if float(np.max(np.abs(residual), initial=0.0)) <= FORCE_TOLERANCE * scale:
                return b, b.copy(), restoring
            stiffness = self.specimen.tangent(b)[np.ix_(controlled, controlled)]
            try:
                b[controlled] = b[controlled] - np.linalg.solve(stiffness, residual)
            except np.linalg.LinAlgError:
                break
            if not np.all(np.isfinite(b)):
                break
        raise _NoSolutionError(self._no_solution(targets, controlled, forces))

    def _geometric_stiffness(self, b: NDArray[np.float64], force: NDArray[np.float64]
                             ) -> NDArray[np.float64]:
        """``∂(J(b)ᵀ f)/∂b`` at fixed actuator forces ``f`` (central differences of ``J``)."""
        assert self.setup is not None
        n = len(b)
        out = np.zeros((n, n))
        for k in range(n):
            step = GEOMETRY_STEP * (1.0 + abs(float(b[k])))
            ahead, behind = b.copy(), b.copy()
            ahead[k] += step
            behind[k] -= step
            change = (np.asarray(self.setup.jacobian(ahead)) - np.asarray(
                self.setup.jacobian(behind))) / (2.0 * step)
            out[:, k] = change.T @ force
        return out

    def _no_solution(self, targets: list[float], controlled: list[int], forces: list[float]
                     ) -> str:
        held = ', '.join(f'actuator {j + 1} at {forces[j]:g} N' for j in controlled)
        free = ', '.join(f'actuator {i + 1} at {targets[i]:g} m' for i in range(len(targets))
                         if i not in controlled)
        parts = '; '.join(part for part in (free, held) if part)
        return (f'no specimen state found for the command ({parts}): the Newton iterations did '
                f'not converge in {NEWTON_ITERATIONS}')

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
        return feedback_of(test_id, step, self.position, self.force, FeedbackStatus.OK, '',
                           iteration, '', StateOrigin.FRESH)

    def _fault(self, test_id: str, step: int, iteration: int, message: str) -> Feedback:
        self.faults += 1
        return Feedback(test_id=test_id, step=step, measured_displacement=self.position,
                        restoring_force=self.force, status=FeedbackStatus.FAULT, message=message,
                        iteration=iteration)
