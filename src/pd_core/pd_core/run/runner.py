"""Running a test without ROS, and rebuilding or resuming a run from its record alone.

:func:`run_offline` drives the same :class:`~.session.TestSession` as the integrator node, with
the same specimen models as the ``pd_specimen_sim`` node, in one process, and writes the same
run folder (journal, bag, ``response.csv``, ``summary.json``, figures); given each site's bridge
limits (:func:`~.bridge_limits.site_limits`) it holds where the bridges would
(:class:`~.bridge_limits.BridgeGate`). :func:`replay_run`
feeds a record's commands and feedback through the same step protocol and integrator: it
checks that every recomputed command equals the recorded one (bit for bit) and returns the
history. :func:`restore_dispatcher` does the same through the whole step loop (sites and
numerical elements included) to continue a killed run; :func:`load_run` reads a complete bag,
or the journal of a run whose bag was never finished.
"""

from __future__ import annotations

import json
import shutil
import time
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pd_common.errors import RthsError
from pd_common.protocol import Command, Feedback, TestState
from pd_common.rths import ContinuousSiteServer, continuous_from_config
from pd_common.specimen import (
    SiteGeometry,
    SpecimenError,
    SpecimenServer,
    server_from_config,
    site_geometry,
)

from ..errors import BagError, ConfigError, NothingToRecoverError
from .bridge_limits import BridgeGate, SiteLimits, limits_summary
from .definition import TestDefinition
from .loop.dispatch import StepDispatcher, refuse_fresh_state
from .loop.epochs import EpochGuard
from .loop.progress import ProgressMeter
from .loop.session import TestSession
from .record.actuators import ActuatorHistory, actuator_history, write_actuator_outputs
from .record.bag import TOPIC_BRIDGE_STATUS, TOPIC_STATUS, RecordedRun, read_bag, site_of
from .record.continuations import count_continuations
from .record.energy import energy_balance
from .record.journal import (
    JOURNAL_FILE,
    LEGACY_JOURNAL_FILE,
    Journal,
    journal_to_bag,
    read_journal,
)
from .record.outputs import (
    SUMMARY_JSON,
    draw_run_figures,
    summarize,
    tracking_history,
    write_run_outputs,
    write_summary,
)
from .record.signatures import check_signatures
from .test_file import from_json

#: What answers a site's commands in this process: a simulated specimen or a continuous
#: actuator (both with ``handle``).
SiteServer = SpecimenServer | ContinuousSiteServer

if TYPE_CHECKING:
    from collections.abc import Callable

    from pd_common.auth import Key

    from .record.figure_worker import FigureWorker

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


def check_new_run_folder(directory: str | Path) -> None:
    """Refuse an output folder that exists and is not an empty folder (before anything runs).

    A run writes its outputs (``summary.json``, ``response.csv``, figures, ...) into its
    folder; in a folder holding other files they would be mixed in, or replace files of the
    same names.

    Raises:
        ConfigError: it holds a run (the resume hint), or it is a file, or a folder with
            something in it.
    """
    directory = Path(directory)
    if not directory.exists():
        return
    _refuse_a_run(directory)
    if not directory.is_dir():
        msg = f'{directory}: not a folder; a run goes to a new or empty folder'
        raise ConfigError(msg)
    entries = sorted(entry.name for entry in directory.iterdir())
    if entries:
        shown = ', '.join(entries[:3]) + (', ...' if len(entries) > 3 else '')
        count = f'{len(entries)} entr{"y" if len(entries) == 1 else "ies"}'
        msg = (f'{directory}: not empty ({count}: {shown}); a run goes to a '
               'new or empty folder (default: runs/<test_id>-<UTC time>)')
        raise ConfigError(msg)


def prepare_run_directory(directory: str | Path) -> Path:
    """Create the run folder; refuse one that already holds a bag (nothing is overwritten).

    Raises:
        ConfigError: the folder already holds a run.
    """
    directory = Path(directory)
    _refuse_a_run(directory)
    directory.mkdir(parents=True, exist_ok=True)
    return directory


def _refuse_a_run(directory: Path) -> None:
    for held in (BAG_DIRECTORY, JOURNAL_FILE):
        if (directory / held).exists():
            msg = (f'{directory}: already holds a run ({held}); choose a new output folder '
                   '(or resume it: ./pd run --resume)')
            raise ConfigError(msg)


def finish_outputs(session: TestSession, directory: Path, *, wall_time: float,
                   figures: bool = True, record: RecordedRun | None = None,
                   figure_worker: FigureWorker | None = None,
                   before_summary: Callable[[], None] | None = None,
                   **extra: Any) -> dict[str, Any]:
    """Write a session's CSV files, ``summary.json`` and figures; return the summary.

    A test with force-controlled actuators also gets ``actuators.csv`` (and
    ``actuators.png``), read from ``record`` (default: the journal in ``directory``).
    ``before_summary`` (the node's journal-to-bag conversion) runs before the CSV files and
    ``summary.json`` are written, the figures come last. ``figure_worker`` (see
    :mod:`.figure_worker`) draws them meanwhile; if it fails, they are drawn here (and its
    ``error`` says why).
    """
    energy = None
    definition = session.definition
    actuators = _actuator_history(session, directory, record)
    if actuators is not None:
        extra.setdefault('actuators', actuators.summary())
    if definition.initial_stiffness is not None:  # (a probe that never finished: no damping)
        structure = definition.structure()
        energy = energy_balance(session.history, structure.mass, structure.damping,
                                structure.influence, loads=definition.loads(),
                                initial_stiffness=structure.initial_stiffness)
    tracking = tracking_history(session.history)
    # A test that did not finish (a fault, an abort, a crash) still gets its outputs, up to
    # its last committed step, marked partial.
    extra.setdefault('partial', session.state is not TestState.FINISHED)
    drawer = None  # the worker that took the figures
    if figures and figure_worker is not None and figure_worker.submit(
            session.history, directory, title=definition.test_id, energy=energy,
            tracking=tracking):
        drawer = figure_worker
    if before_summary is not None:
        before_summary()
    summary = summarize(session.history, **session.summary_info(), wall_time=wall_time,
                        energy=energy.summary() if energy is not None else None,
                        tracking=tracking.summary(), **extra)
    write_run_outputs(session.history, summary, directory, figures=False,
                      title=definition.test_id, energy=energy, tracking=tracking)
    if actuators is not None:
        write_actuator_outputs(actuators, directory, figures=figures, title=definition.test_id)
    if figures and (drawer is None or drawer.wait() is None):
        draw_run_figures(session.history, directory, title=definition.test_id, energy=energy,
                         tracking=tracking)
    return summary


def _actuator_history(session: TestSession, directory: Path, record: RecordedRun | None
                      ) -> ActuatorHistory | None:
    """The per-actuator history of a test with force-controlled actuators (else ``None``)."""
    model = session.definition.model
    if model is None or not any(model.site_mixed(site) for site in model.site_names):
        return None
    if record is None:
        journal = Path(directory) / JOURNAL_FILE
        if not journal.is_file():
            return None
        record = read_journal(journal)
    return actuator_history(record, model, session.definition.test_id, session.history)


def run_offline(definition: TestDefinition, directory: str | Path, *, figures: bool = True,
                progress: Callable[[str], None] | None = None,
                limits: Mapping[str, SiteLimits] | None = None,
                past_limits: bool = False) -> RunResult:
    """Run ``definition`` against its simulated specimen in this process (no ROS).

    With ``limits`` (per site, :func:`~.bridge_limits.site_limits`) each site's commands and
    measurements go through its bridge's checks (:class:`~.bridge_limits.BridgeGate`): the run
    holds where ``./pd run`` would, ``summary.json`` says ``state: held`` and ``bridge_limits``
    which limit held it at which step, with the bridge's message. ``past_limits`` checks
    without refusing: the run goes on, and ``bridge_limits`` says where the bridges would have
    held. Without ``limits`` nothing is checked (a specimen rehearsal, as ``--site direct``).

    Raises:
        ConfigError: the definition has no usable ``specimen`` section.
        StabilityError: ω_max·Δt is above the scheme's limit (nothing is commanded).
    """
    specimens = site_servers(definition)
    servers: dict[str, SiteServer | BridgeGate] = dict(specimens)
    gates: dict[str, BridgeGate] = {}
    if limits is not None:
        for site, server in specimens.items():
            gates[site] = BridgeGate(server, limits[site], len(limits[site].dof_names),
                                     apply=not past_limits)
        servers.update(gates)
    session = TestSession(definition)  # checks stability before anything moves
    directory = prepare_run_directory(directory)
    (directory / DEFINITION_JSON).write_text(definition.to_json(), encoding='utf-8')
    meter = ProgressMeter(definition.n_steps)
    start = time.perf_counter()
    queue: deque[tuple[str, Command]] = deque()
    def send(site: str, command: Command) -> None:
        queue.append((site, command))

    with Journal(directory / JOURNAL_FILE) as bag:
        dispatcher = StepDispatcher(session, send, bag)
        bag.write_definition(definition.to_json(), time.time_ns())
        bag.write_status(session.status(), time.time_ns())
        dispatcher.start()

        def report() -> None:
            if progress is not None and (line := meter.update(session.committed_step)):
                progress(line)

        serve_queue(queue, servers, dispatcher, after_answer=report)
        bag.write_status(dispatcher.status(), time.time_ns())
    wall_time = time.perf_counter() - start
    journal_to_bag(directory / JOURNAL_FILE, directory / BAG_DIRECTORY)
    extra: dict[str, Any] = {'bridge_limits': limits_summary(gates)} if gates else {}
    summary = finish_outputs(session, directory, wall_time=wall_time, figures=figures,
                             mode='offline', site_protocol=dispatcher.coordinator.summary(),
                             **extra)
    if (not past_limits and session.state is TestState.HOLDING
            and any(gate.held is not None for gate in gates.values())):
        # Held by a bridge: ./pd run holds there until an operator decides; nobody will here.
        summary['state'] = 'held'
        write_summary(summary, directory / 'summary.json')
    return RunResult(session=session, directory=directory, summary=summary)


def serve_queue(queue: deque[tuple[str, Command]],
                servers: Mapping[str, SiteServer | BridgeGate],
                dispatcher: StepDispatcher, *,
                after_answer: Callable[[], None] | None = None) -> bool:
    """Answer the queued commands with in-process specimens until none is left.

    Each command goes, in order, to its site's server; the answer is fed to ``dispatcher``,
    which queues the next commands (its ``send`` appends to ``queue``). ``after_answer`` runs
    after each answer is taken.

    Returns:
        ``False`` if a server ignored a command (which cannot happen for a fresh command): the
        session is then aborted; ``True`` once the queue is empty.
    """
    while queue:
        site, command = queue.popleft()
        answer = servers[site].handle(command.test_id, command.step, command.target_displacement,
                                      iteration=command.iteration,
                                      control_mode=command.control_mode,
                                      target_force=command.target_force)
        if answer is None:
            dispatcher.session.abort(f'specimen ignored step {command.step}')
            return False
        dispatcher.on_feedback(site, answer)
        if after_answer is not None:
            after_answer()
    return True


def site_servers(definition: TestDefinition, *, keep_samples: bool = False
                 ) -> dict[str, SiteServer]:
    """The simulated specimen of every site (``''``: the test's ``specimen`` section).

    A site with a ``transfer_system`` section is an actuator in continuous motion
    (:class:`~pd_common.rths.ContinuousSiteServer`, its controller samples kept with
    ``keep_samples``).

    Raises:
        ConfigError: a site has no ``specimen`` to simulate, or a bad ``transfer_system``.
    """
    servers: dict[str, SiteServer] = {}
    sections: dict[str, tuple[Any, tuple[str, ...], str]] = {}
    if definition.model is None:
        sections[''] = (definition.specimen, definition.dof_names, 'specimen')
    else:
        # The typed settings say what a site has; its builders take the sections as written.
        written = definition.sites or {}
        for site in definition.model.site_names:
            settings = definition.site_settings.get(site)
            if settings is not None and settings.transfer_system is not None:
                servers[site] = _continuous_site(
                    definition, site, written[site]['transfer_system'], keep_samples)
                continue
            section = (written[site]['specimen']
                       if settings is not None and settings.specimen is not None else None)
            sections[site] = (section, definition.model.actuator_names(site),
                              f'sites.{site}.specimen')
    for site, (section, names, path) in sections.items():
        if section is None:
            msg = f'{definition.source}: {path}: section is required for a simulated run'
            raise ConfigError(msg)
        try:
            # The specimen and its optional ``errors``, exactly as the pd_specimen_sim node
            # builds them: both inject the same, deterministic errors.
            geometry = _site_geometry(definition, site)
            servers[site] = server_from_config(
                section, base_dir=definition.base_dir, source=definition.source,
                dof_names=names, setup=geometry.setup,
                max_force_increment=geometry.max_force_increment)
        except SpecimenError as err:
            if not site:
                raise
            msg = str(err).replace(': specimen', f': sites.{site}.specimen', 1)
            raise ConfigError(msg) from None
    return servers


def _continuous_site(definition: TestDefinition, site: str, section: Any, keep_samples: bool
                     ) -> ContinuousSiteServer:
    """The continuous actuator of a site's ``transfer_system`` section."""
    assert definition.model is not None
    where = f'{definition.source}: sites.{site}.transfer_system'
    try:
        config = continuous_from_config(section, where)
        return ContinuousSiteServer(config, definition.dt,
                                    n_dof=len(definition.model.actuator_names(site)),
                                    keep_samples=keep_samples)
    except RthsError as err:
        text = str(err)
        msg = text if text.startswith(where) else f'{where}: {text}'
        raise ConfigError(msg) from None


def _site_geometry(definition: TestDefinition, site: str) -> SiteGeometry:
    """The setup and force ramp a simulated site takes from the test file.

    As the simulator node does: :func:`~pd_common.specimen.site_geometry`.

    """
    if not site or definition.model is None:
        return SiteGeometry()
    return site_geometry(definition.elements, definition.site_settings.get(site), site,
                         definition.source)


def _same_command(recorded: Command, computed: Command) -> bool:
    return (recorded.test_id == computed.test_id and recorded.key == computed.key
            and recorded.target_displacement == computed.target_displacement
            and tuple(recorded.control_mode) == tuple(computed.control_mode)
            and tuple(recorded.target_force) == tuple(computed.target_force))


def load_run(path: str | Path) -> RecordedRun:
    """A run's record: its bag if complete, else its journal (a killed run).

    ``path`` is a run folder, its bag folder or its journal file.

    Raises:
        BagError: neither a complete bag nor a journal is there.
    """
    path = Path(path)
    if path.is_file():
        return read_journal(path)
    run_dir = path.parent if path.name == BAG_DIRECTORY else path
    bag = run_dir / BAG_DIRECTORY if path == run_dir else path
    if (bag / 'metadata.yaml').is_file():
        return read_bag(bag)
    journal = run_dir / JOURNAL_FILE
    if journal.is_file():
        return read_journal(journal)
    _refuse_legacy_journal(run_dir)
    msg = f'{path}: no complete bag and no journal ({JOURNAL_FILE}): not a run folder'
    raise BagError(msg)


def _refuse_legacy_journal(run_dir: Path) -> None:
    """One line for a run folder an earlier version recorded (a JSON-lines journal).

    Raises:
        BagError: ``run_dir`` holds such a journal.
    """
    if (run_dir / LEGACY_JOURNAL_FILE).is_file():
        msg = (f'{run_dir}: its journal ({LEGACY_JOURNAL_FILE}) is of an earlier version (JSON '
               'lines): recover or replay it with that version')
        raise BagError(msg)


def replay_bag(bag_path: str | Path) -> TestSession:
    """:func:`replay_run` of :func:`load_run` (a bag, a run folder or a journal)."""
    return replay_run(load_run(bag_path), str(bag_path))


def replay_run(run: RecordedRun, source: str = 'record') -> TestSession:
    """Re-run a recorded test: same protocol, same integrator, recorded forces.

    Raises:
        BagError: a recomputed command differs from the recorded one (the record does not
            belong to this code or was altered).
    """
    definition = from_json(run.definition_json, source=Path(source).name)
    session = TestSession(definition)
    session.replay_external(item for _, item in run.events if isinstance(item, Command))
    epochs = EpochGuard()  # as the dispatcher: a fresh specimen's answers were refused
    for _, item in run.events:
        if isinstance(item, Feedback):
            reason = epochs.check('', item)
            if reason is not None:
                refuse_fresh_state(session, reason)
            else:
                session.on_feedback(item)
            continue
        pending = session.protocol.pending
        if pending is not None and _same_command(item, pending):
            if session.state in (TestState.HOLDING, TestState.PAUSED, TestState.INTERRUPTED):
                session.resume()  # the operator resumed: the pending command went out again
            else:
                session.protocol.on_timeout()  # a re-send after a feedback timeout
            continue
        if session.state in (TestState.HOLDING, TestState.PAUSED, TestState.INTERRUPTED):
            session.resume()
        computed = session.next_command()
        if computed is None or not _same_command(item, computed):
            msg = (f'{source}: recorded command for step {item.step} of {item.test_id!r} '
                   f'differs from the recomputed one ({computed!r})')
            raise BagError(msg)
    _apply_last_status(session, run)
    return session


def _apply_last_status(session: TestSession, run: RecordedRun) -> None:
    """End the re-run in the recorded final state (aborted, holding, paused, interrupted)."""
    last_status = run.statuses[-1][1] if run.statuses else None
    if last_status is None or session.state is TestState.FINISHED:
        return
    if last_status.state is TestState.ABORTED:
        session.abort(last_status.message)
    elif last_status.state in (TestState.HOLDING, TestState.PAUSED, TestState.INTERRUPTED):
        # (a pause stays a pause: a person paused it, a person resumes it)
        session.state = last_status.state
        session.message = last_status.message


def restore_dispatcher(run: RecordedRun, dispatcher: StepDispatcher, source: str = 'record'
                       ) -> list[tuple[str, Command]]:
    """Bring a new dispatcher (and its session) to where a recorded run stopped.

    The recorded site feedback is fed through the whole step loop — the session, the sites'
    protocols, the numerical elements — in the recorded order, and every command the loop
    computes is checked against the recorded one; re-sent commands (a timeout, a resume) are
    recognised as the pending ones. Nothing is sent or recorded
    (:meth:`.StepDispatcher.replaying`).

    Returns:
        The site commands the restored loop still owes (pending, unanswered): what a resumed
        run sends first.

    Raises:
        BagError: a recomputed command differs from the recorded one.
    """
    expected: deque[tuple[str, Command]] = deque()

    def capture(site: str, command: Command) -> None:
        expected.append((site, command))

    structured = not dispatcher.coordinator.passthrough
    session = dispatcher.session
    with dispatcher.replaying(capture):  # nothing leaves, nothing is recorded
        dispatcher.start()
        for topic, _, item, _ in run.ordered:
            if topic == TOPIC_STATUS or (structured and '/structure/' in topic):
                continue
            site = site_of(topic) if structured else ''
            if isinstance(item, Feedback):
                dispatcher.on_feedback(site, item)
                continue
            if not isinstance(item, Command):
                continue
            if expected and expected[0][0] == site and _same_command(item, expected[0][1]):
                expected.popleft()
                continue
            owed = session.protocol.pending
            if owed is None:
                msg = (f'{source}: recorded command for step {item.step} of {item.test_id!r} '
                       'is not one the restored run owes')
                if session.state is TestState.HOLDING:  # e.g. a served model's link failed
                    msg += f' (the restored run holds: {session.message})'
                raise BagError(msg)
            if session.state in (TestState.HOLDING, TestState.PAUSED, TestState.INTERRUPTED):
                dispatcher.resume()
            else:
                dispatcher.on_timeout()
            matches = [i for i, (s, c) in enumerate(expected)
                       if s == site and _same_command(item, c)]
            if not matches:
                msg = (f'{source}: recorded command for step {item.step} of {item.test_id!r} '
                       'differs from the recomputed one')
                raise BagError(msg)
            del expected[matches[0]]
        _apply_last_status(session, run)
    return _owed(dispatcher, list(expected))


def _owed(dispatcher: StepDispatcher, unrecorded: list[tuple[str, Command]]
          ) -> list[tuple[str, Command]]:
    """The site commands still unanswered.

    Those never recorded, and those recorded (sent: the specimen may have executed them) whose
    answer is not on record.
    """
    owed = list(unrecorded)
    coordinator = dispatcher.coordinator
    for site in dispatcher.sites:
        pending = (dispatcher.session.protocol.pending if coordinator.passthrough
                   else coordinator.protocols[site].pending)
        if pending is not None and not any(s == site and _same_command(c, pending)
                                           for s, c in owed):
            owed.append((site, pending))
    return owed


def rebuild_outputs(bag_path: str | Path, directory: str | Path, *, figures: bool = True,
                    key: Key | None = None) -> RunResult:
    """Rebuild ``response.csv``, ``summary.json`` and the figures from a bag alone.

    With ``key``, the recorded authentication codes are checked too (``summary.json``:
    ``signature_check``).
    """
    bag_path = Path(bag_path)
    run = load_run(bag_path)
    extra: dict[str, Any] = {}
    if key is not None:
        extra['signature_check'] = check_signatures(run, key).as_dict()
    if run.notes:
        extra['record_notes'] = run.notes
    if run.run_events:
        extra['run_events'] = run.run_events
        extra['restarts'], extra['resumes'] = count_continuations(run.run_events)
    session = replay_run(run, str(bag_path))
    times = [t for t, _ in run.events]
    wall_time = (max(times) - min(times)) / 1e9 if times else 0.0
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    bridge = [status.message for _, status in run.bridge_statuses if status.message]
    summary = finish_outputs(session, directory, wall_time=wall_time, figures=figures,
                             record=run, mode='replay', replayed_from=str(bag_path),
                             bridge_messages=bridge[-5:], bridge_topic=TOPIC_BRIDGE_STATUS,
                             **extra)
    return RunResult(session=session, directory=directory, summary=summary)


def _ended_state(run_dir: Path) -> str | None:
    """The state in the ``summary.json`` a run wrote as it ended; ``None`` if there is none.

    ``None`` too for a summary that ``recover_run`` wrote, or one that cannot be read.
    """
    path = run_dir / SUMMARY_JSON
    if not path.is_file():  # (none, or a FIFO or a device: never read)
        return None
    try:
        summary = json.loads(path.read_text(encoding='utf-8'))
    except (OSError, ValueError):
        return None
    if not isinstance(summary, dict) or summary.get('recovered'):
        return None
    return str(summary.get('state') or 'ended')


def recover_run(run_dir: str | Path, *, figures: bool = True) -> RunResult:
    """A killed run's folder made whole from its journal: the bag, and the outputs so far.

    Writes ``bag/`` (replacing a bag the crash left unfinished) and, in the run folder,
    ``response.csv``, ``summary.json`` (``recovered``: true) and the figures, up to the last
    committed step. The run can still be resumed afterwards (``./pd run --resume``).

    A folder whose run ended and wrote its bag and ``summary.json`` itself is left as it is:
    that summary holds what only the live run knew (its round trips, the sites' protocol and
    authentication, the specimen side), which a summary rebuilt from the journal would drop.

    Raises:
        BagError: the folder has no journal, or it cannot be read.
        NothingToRecoverError: the run ended and wrote its outputs (nothing written).
    """
    run_dir = Path(run_dir)
    journal = run_dir / JOURNAL_FILE
    if not journal.is_file():
        _refuse_legacy_journal(run_dir)
        msg = f'{run_dir}: no {JOURNAL_FILE}: nothing to recover from'
        raise BagError(msg)
    bag = run_dir / BAG_DIRECTORY
    ended = _ended_state(run_dir)
    if ended is not None and (bag / 'metadata.yaml').is_file():
        msg = (f'{run_dir}: nothing to recover: the run ended ({ended}) and wrote its bag and '
               f'outputs; ./pd replay {run_dir} --out DIR writes them again elsewhere')
        raise NothingToRecoverError(msg)
    if bag.exists() and not (bag / 'metadata.yaml').is_file():
        shutil.rmtree(bag)  # a bag the crash left unfinished: the journal has all of it
    made = not bag.exists()
    if made:
        journal_to_bag(journal, bag)
    try:
        result = rebuild_outputs(journal, run_dir, figures=figures)
    except Exception:
        if made:  # (a journal with no run in it: no bag of it left behind)
            shutil.rmtree(bag, ignore_errors=True)
        raise
    result.summary['recovered'] = True
    if result.summary.get('state') in ('running', 'paused'):
        # The record stops in the middle of the test: its process was killed.
        result.summary['state'] = 'interrupted'
        result.summary['message'] = (f'the run stopped after step {result.summary["steps"]} '
                                     'without ending (its process was killed); resumable')
    write_summary(result.summary, run_dir / 'summary.json')
    return result
