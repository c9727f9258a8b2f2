"""Running a test without ROS, and rebuilding a run's outputs from its bag alone.

:func:`run_offline` drives the same :class:`~.session.TestSession` as the integrator node, with
the same specimen models as the ``pd_specimen_sim`` node, in one process, and writes the same
run folder (bag, ``response.csv``, ``summary.json``, figures). :func:`replay_bag` feeds a bag's
recorded commands and feedback through the same step protocol and integrator: it checks that
every recomputed command equals the recorded one (bit for bit) and returns the history.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pd_common.protocol import Command, Feedback, TestState
from pd_common.specimen import SpecimenError, SpecimenServer, server_from_config

from ..errors import BagError, ConfigError
from .bag import TOPIC_BRIDGE_STATUS, BagRecorder, read_bag
from .definition import TestDefinition
from .dispatch import StepDispatcher
from .energy import energy_balance
from .outputs import summarize, tracking_history, write_run_outputs
from .progress import ProgressMeter
from .session import TestSession
from .signatures import check_signatures
from .test_file import from_json

if TYPE_CHECKING:
    from collections.abc import Callable

    from pd_common.auth import Key

BAG_DIRECTORY = 'bag'
DEFINITION_JSON = 'test_definition.json'


@dataclass
class RunResult:
    """A finished (or stopped) run.

    Attributes:
        session: the session, with its history and counters.
        directory: the run folder.
        summary: what ``summary.json`` holds.
    """

    session: TestSession
    directory: Path
    summary: dict[str, Any]

    @property
    def bag_path(self) -> Path:
        """The run's bag directory."""
        return self.directory / BAG_DIRECTORY


def default_run_directory(root: str | Path, test_id: str) -> Path:
    """``<root>/<test_id>-<UTC timestamp>`` (a new folder per run)."""
    stamp = datetime.now(tz=UTC).strftime('%Y%m%d-%H%M%S')
    return Path(root) / f'{test_id}-{stamp}'


def prepare_run_directory(directory: str | Path) -> Path:
    """Create the run folder; refuse one that already holds a bag (nothing is overwritten).

    Raises:
        ConfigError: the folder already holds a run.
    """
    directory = Path(directory)
    if (directory / BAG_DIRECTORY).exists():
        msg = f'{directory}: already holds a run (bag/); choose a new output folder'
        raise ConfigError(msg)
    directory.mkdir(parents=True, exist_ok=True)
    return directory


def finish_outputs(session: TestSession, directory: Path, *, wall_time: float,
                   figures: bool = True, **extra: Any) -> dict[str, Any]:
    """Write a session's CSV files, ``summary.json`` and figures; return the summary."""
    energy = None
    definition = session.definition
    if definition.initial_stiffness is not None:  # (a probe that never finished: no damping)
        structure = definition.structure()
        energy = energy_balance(session.history, structure.mass, structure.damping,
                                structure.influence, loads=definition.loads())
    tracking = tracking_history(session.history)
    summary = summarize(session.history, **session.summary_info(), wall_time=wall_time,
                        energy=energy.summary() if energy is not None else None,
                        tracking=tracking.summary(), **extra)
    write_run_outputs(session.history, summary, directory, figures=figures,
                      title=definition.test_id, energy=energy, tracking=tracking)
    return summary


def run_offline(definition: TestDefinition, directory: str | Path, *, figures: bool = True,
                progress: Callable[[str], None] | None = None) -> RunResult:
    """Run ``definition`` against its simulated specimen in this process (no ROS).

    Raises:
        ConfigError: the definition has no usable ``specimen`` section.
        StabilityError: ω_max·Δt is above the scheme's limit (nothing is commanded).
    """
    servers = site_servers(definition)
    session = TestSession(definition)  # checks stability before anything moves
    directory = prepare_run_directory(directory)
    (directory / DEFINITION_JSON).write_text(definition.to_json(), encoding='utf-8')
    meter = ProgressMeter(definition.n_steps)
    start = time.perf_counter()
    queue: deque[tuple[str, Command]] = deque()
    with BagRecorder(directory / BAG_DIRECTORY) as bag:
        dispatcher = StepDispatcher(session, lambda site, command: queue.append((site, command)),
                                    bag)
        bag.write_definition(definition.to_json(), time.time_ns())
        bag.write_status(session.status(), time.time_ns())
        dispatcher.start()
        while queue:
            site, command = queue.popleft()
            answer = servers[site].handle(command.test_id, command.step,
                                          command.target_displacement,
                                          iteration=command.iteration)
            if answer is None:  # cannot happen for a fresh command; keep the protocol honest
                session.abort(f'specimen ignored step {command.step}')
                break
            dispatcher.on_feedback(site, answer)
            if progress is not None and (line := meter.update(session.committed_step)):
                progress(line)
        bag.write_status(dispatcher.status(), time.time_ns())
    wall_time = time.perf_counter() - start
    summary = finish_outputs(session, directory, wall_time=wall_time, figures=figures,
                             mode='offline', site_protocol=dispatcher.coordinator.summary())
    return RunResult(session=session, directory=directory, summary=summary)


def site_servers(definition: TestDefinition) -> dict[str, SpecimenServer]:
    """The simulated specimen of every site (``''``: the test's ``specimen`` section).

    Raises:
        ConfigError: a site has no ``specimen`` to simulate.
    """
    sections: dict[str, tuple[Any, tuple[str, ...], str]] = {}
    if definition.model is None:
        sections[''] = (definition.specimen, definition.dof_names, 'specimen')
    else:
        sites = definition.sites or {}
        for site in definition.model.site_names:
            settings = sites.get(site)
            section = settings.get('specimen') if isinstance(settings, dict) else None
            sections[site] = (section, definition.model.actuator_names(site),
                              f'sites.{site}.specimen')
    servers = {}
    for site, (section, names, path) in sections.items():
        if not isinstance(section, dict):
            msg = f'{definition.source}: {path}: section is required for a simulated run'
            raise ConfigError(msg)
        try:
            # The specimen and its optional ``errors``, exactly as the pd_specimen_sim node
            # builds them: both inject the same, deterministic errors.
            servers[site] = server_from_config(section, base_dir=definition.base_dir,
                                               source=definition.source, dof_names=names)
        except SpecimenError as err:
            if not site:
                raise
            msg = str(err).replace(': specimen', f': sites.{site}.specimen', 1)
            raise ConfigError(msg) from None
    return servers


def _same_command(recorded: Command, computed: Command) -> bool:
    return (recorded.test_id == computed.test_id and recorded.key == computed.key
            and recorded.target_displacement == computed.target_displacement)


def replay_bag(bag_path: str | Path) -> TestSession:
    """Re-run a recorded test from its bag: same protocol, same integrator, recorded forces.

    Raises:
        BagError: the bag is unreadable, or a recomputed command differs from the recorded one
            (the bag does not belong to this code or was altered).
    """
    run = read_bag(bag_path)
    definition = from_json(run.definition_json, source=f'{Path(bag_path).name}')
    session = TestSession(definition)
    for _, item in run.events:
        if isinstance(item, Feedback):
            session.on_feedback(item)
            continue
        pending = session.protocol.pending
        if pending is not None and _same_command(item, pending):
            if session.state in (TestState.HOLDING, TestState.PAUSED):
                session.resume()  # the operator resumed: the pending command went out again
            else:
                session.protocol.on_timeout()  # a re-send after a feedback timeout
            continue
        if session.state in (TestState.HOLDING, TestState.PAUSED):
            session.resume()
        computed = session.next_command()
        if computed is None or not _same_command(item, computed):
            msg = (f'{bag_path}: recorded command for step {item.step} of {item.test_id!r} '
                   f'differs from the recomputed one ({computed!r})')
            raise BagError(msg)
    last_status = run.statuses[-1][1] if run.statuses else None
    if last_status is not None and last_status.state is TestState.ABORTED:
        session.abort(last_status.message)
    elif (last_status is not None and last_status.state is TestState.HOLDING
          and session.state is not TestState.FINISHED):
        session.state = TestState.HOLDING
        session.message = last_status.message
    return session


def rebuild_outputs(bag_path: str | Path, directory: str | Path, *, figures: bool = True,
                    key: Key | None = None) -> RunResult:
    """Rebuild ``response.csv``, ``summary.json`` and the figures from a bag alone.

    With ``key``, the recorded authentication codes are checked too (``summary.json``:
    ``signature_check``).
    """
    bag_path = Path(bag_path)
    run = read_bag(bag_path)
    extra: dict[str, Any] = {}
    if key is not None:
        extra['signature_check'] = check_signatures(run, key).as_dict()
    session = replay_bag(bag_path)
    times = [t for t, _ in run.events]
    wall_time = (max(times) - min(times)) / 1e9 if times else 0.0
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    bridge = [status.message for _, status in run.bridge_statuses if status.message]
    summary = finish_outputs(session, directory, wall_time=wall_time, figures=figures,
                             mode='replay', replayed_from=str(bag_path),
                             bridge_messages=bridge[-5:], bridge_topic=TOPIC_BRIDGE_STATUS,
                             **extra)
    return RunResult(session=session, directory=directory, summary=summary)
