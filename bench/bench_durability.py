"""The cost of durable recording (the run's journal), a long offline soak, and recovery.

    python bench/bench_durability.py [--quick] [--steps N] [--no-soak] [--no-recovery]
                                     [--graph-soak [--graph-steps N] [--domain-id 65]]
                                     [--keep DIR]

``./pd bench`` runs it after the other benches (with the same arguments: ``--quick``,
``--domain-id``). A measurement, not a test: it asserts nothing (a soak that fails, a record
that is unreadable or incomplete, a recovery that differs are reported, not raised). Figures
(printed as one plain-text table, and merged into ``bench/results.json`` under the names in
brackets; the keys of a section that ran replace that section's keys of an earlier run, other
benches' keys are kept):

1. Per-step cost of durability in the ROS-free core, default test
   (``config/default_test.yaml``, 3,118 steps; ``--quick``: its first 5 s, 500 steps), best of
   3, the variants interleaved: the step loop exactly as ``run_offline`` runs it
   (``TestSession`` + ``StepDispatcher`` + ``SpecimenServer``; the recorder opened, the
   definition and first/last status written and the recorder closed inside the timed part, as
   ``run_offline`` does) with

   * no recorder [``durability_none_us_per_step``],
   * the ``Journal`` at its default ``sync_interval`` of 1 s (what ``run_offline`` and the
     integrator node use) [``durability_journal_us_per_step``],
   * the ``Journal`` with ``sync_interval`` 0: ``fsync`` after every step
     [``durability_fsync_every_step_us_per_step``],
   * for comparison, the MCAP ``BagRecorder`` written directly during the loop (what the runs
     recorded before the journal; not durable) [``durability_bag_recorder_us_per_step``];

   the longest flush a step waits for when an ``fsync`` falls due (``sync_interval`` 10 ms),
   the ``fsync`` in the step against in a thread of its own, as the integrator node does
   [``durability_longest_flush_us_fsync_in_step``,
   ``durability_longest_flush_us_fsync_in_background``], and the same for a simulator's
   state file, the longest ``ServedRecord.add`` of a move
   [``durability_longest_state_add_us_fsync_in_step``,
   ``durability_longest_state_add_us_fsync_in_background``],
   the differences [``durability_journal_cost_us_per_step``: journal − none,
   ``durability_fsync_cost_us_per_step``: fsync every step − journal], the ``os.fsync`` calls
   counted in the best run of each variant [``durability_journal_fsyncs``,
   ``durability_fsync_every_step_fsyncs``, ``durability_bag_recorder_fsyncs``], the end-of-run
   ``journal_to_bag`` conversion [``durability_journal_to_bag_s``, best of 15: tens of ms, which
   this machine's hiccups would swamp in fewer] and the sizes
   [``durability_journal_bytes_per_step``, ``durability_bag_bytes_per_step``].
2. Soak (``--no-soak`` skips it): ``run_offline`` (journal + bag + outputs, no figures) of the
   default SDOF test with ``test.duration`` set for ``--steps`` steps (default 100,000: 1,000 s
   of dt 0.01 s, free vibration after the 31 s record; 10,000 with ``--quick``), in a fresh
   child process (this script with ``--soak-worker``) so that its memory is its own. Its VmRSS
   is sampled at every progress line (about once a second) and around the end-of-run phases;
   its peak is ``getrusage(RUSAGE_SELF).ru_maxrss`` at the end [``soak_rss_before_mb``
   (before ``run_offline``), ``soak_rss_start_mb`` (the first progress line, step 0),
   ``soak_rss_loop_end_mb``,
   ``soak_rss_loop_growth_mb``, ``soak_rss_loop_growth_bytes_per_step``,
   ``soak_rss_slope_mb_per_10k_steps`` (least squares over the loop's samples),
   ``soak_rss_peak_mb``, ``soak_rss_peak_growth_mb`` (peak − start), ``soak_rss_end_mb``, and
   per end-of-run phase ``soak_<phase>_s`` and ``soak_<phase>_peak_growth_mb``, phase
   ``journal_to_bag`` and ``outputs``]. Steps/s of the loop [``soak_steps_per_s``:
   ``summary.json`` steps / ``wall_time``, ``soak_loop_s``: that ``wall_time``;
   ``soak_run_offline_s``: the whole call], the
   ``fsync`` calls [``soak_fsyncs``], the sizes [``soak_journal_mb``, ``soak_bag_mb``,
   ``soak_journal_bytes_per_step``]. Then, in this process, the journal is read with
   ``read_journal`` and the run folder with ``load_run`` (the bag): are a command and a
   feedback of every step 0..N there, the definition and the final status? Do both give the
   same history? [``soak_journal_readable``, ``soak_bag_readable``,
   ``soak_journal_bag_identical``, ``soak_read_journal_s``, ``soak_load_run_s``].
3. Recovery (``--no-recovery`` skips it): a run killed mid-step, made by cutting a journal in
   the middle of a line (the bytes up to half of the first line after ``fraction`` of the
   file) into a new run folder with the run's ``test_definition.json`` and no bag, then
   ``runner.recover_run`` (what ``./pd recover RUN`` does: the bag from the journal, then
   ``response.csv`` and ``summary.json`` up to the last committed step; no figures):

   * the default test's journal (a ``run_offline`` run), cut at 50 %: best of 3 in this
     process [``recovery_default_s``, ``recovery_default_us_per_step``,
     ``recovery_default_steps``], and once through the command line, with its figures, as an
     operator runs it (``ros2 run pd_integrator recover RUN``: interpreter start-up and
     matplotlib included) [``recovery_default_cli_s``];
   * the soak's journal, cut at 90 % [``recovery_soak_s``, ``recovery_soak_us_per_step``,
     ``recovery_soak_steps``];

   each checked [``recovery_consistent``]: the recovered steps are the journal's last complete
   feedback, the cut line is reported (``record_notes``), the summary says ``recovered`` and
   ``partial``, and the recovered ``response.csv`` is, line for line, the start of the full
   run's.
4. Graph soak (only with ``--graph-soak``; not run by ``./pd bench``): the default test for
   ``--graph-steps`` steps (default 10,000; at ~200 steps/s through the bridge 100,000 would
   take 9 minutes) through ``run_test --site bridge --no-figures`` (integrator → bridge →
   simulator, one process each). Every 0.5 s the VmRSS (and VmHWM) of each node process (the
   launcher's children, from ``/proc``) is sampled: at the start (the first sample after the
   integrator reported step 1,000) and at the end (the last sample before the integrator
   exits; for the integrator also the last one before the bag conversion began)
   [``graph_soak_rss_start_mb_<node>``, ``graph_soak_rss_end_mb_<node>``,
   ``graph_soak_rss_growth_mb_<node>``, ``graph_soak_rss_peak_mb_<node>``]. Steps/s
   [``graph_soak_steps_per_s``: ``summary.json`` steps / ``wall_time``;
   ``graph_soak_loop_steps_per_s``: from the integrator's log, "running" to "finished"; first
   and last 10 %]. Then the bag is read with ``read_bag`` (every command and feedback of steps
   0..N there?) [``graph_soak_bag_readable``] and rebuilt with ``rebuild_outputs`` (what
   ``./pd replay`` does; its ``response.csv`` compared byte for byte with the run's)
   [``graph_soak_replay_s``, ``graph_soak_replay_consistent``]; sizes
   [``graph_soak_bag_mb``, ``graph_soak_journal_mb``] and the conversion of the soak's journal
   timed again in this process [``graph_soak_journal_to_bag_s``]. Every process it starts gets
   ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, the ``--domain-id`` and its own process group,
   and is stopped with SIGINT, then SIGKILL; Fast DDS ``/dev/shm`` segments of the domain that
   no process holds are removed at the end.

The work folder is a temporary folder (``--keep DIR``: DIR, kept); its file system is printed
(an ``fsync`` on tmpfs costs nothing).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from _results import RESULTS, merge_results
from bench_loop import (
    DEFAULT_TEST,
    QUICK_DURATION,
    REPO,
    machine_header,
    remove_stale_segments,
    shm_snapshot,
    stop_process,
)

LAUNCHER = REPO / 'ros2_ws' / 'install' / 'pd_bringup' / 'lib' / 'pd_bringup' / 'run_test'
RECOVER = REPO / 'ros2_ws' / 'install' / 'pd_integrator' / 'lib' / 'pd_integrator' / 'recover'
REPEATS = 3
CONVERSIONS = 15  # of the journal to a bag (~20 ms each)
SOAK_STEPS = 100_000
QUICK_SOAK_STEPS = 10_000
GRAPH_SOAK_STEPS = 100_000  # issue 33: the RSS slope and the rate over 1e5 steps
QUICK_GRAPH_SOAK_STEPS = 10_000
RECOVERY_CUT_DEFAULT = 0.5  # fraction of the default test's journal kept (then half a record)
RECOVERY_CUT_SOAK = 0.9  # the same for the soak's journal
START_STEP = 1000  # the graph soak's "start" RSS sample: the first after this step was reported
SAMPLE_PERIOD = 0.5  # s between the graph soak's RSS samples
STALL_TIMEOUT = 60.0  # s without journal growth while stepping: reported as a hold
NODES = ('pd_integrator', 'pd_actuator_bridge', 'pd_specimen_sim')
#: The results.json keys of each section (a section that ran replaces its old keys).
PREFIXES = {'core': 'durability_', 'soak': 'soak_', 'recovery': 'recovery_',
            'graph': 'graph_soak_'}
Figures = dict[str, float | int | bool | str | None]


# -- output -----------------------------------------------------------------------------------
@dataclass
class Table:
    """Rows of (section, figure, value, notes), printed at the end."""

    rows: list[tuple[str, str, str, str]] = field(default_factory=list)

    def add(self, section: str, figure: str, value: str, note: str = '') -> None:
        self.rows.append((section, figure, value, note))

    def render(self) -> str:
        header = ('section', 'figure', 'value', 'notes')
        cells = [header, *self.rows]
        widths = [max(len(cell[i]) for cell in cells) for i in range(3)]
        lines = []
        for index, cell in enumerate(cells):
            lines.append('  '.join([cell[0].ljust(widths[0]), cell[1].ljust(widths[1]),
                                    cell[2].rjust(widths[2]), cell[3]]).rstrip())
            if index == 0:
                lines.append('-' * len(lines[0]))
        return '\n'.join(lines)


def _filesystem(path: Path) -> str:
    """The file system type of the mount holding ``path`` (from /proc/mounts)."""
    best, kind = '', '?'
    with contextlib.suppress(OSError):
        resolved = str(path.resolve())
        for line in Path('/proc/mounts').read_text().splitlines():
            parts = line.split()
            if len(parts) > 2 and (resolved == parts[1] or resolved.startswith(
                    parts[1].rstrip('/') + '/')) and len(parts[1]) > len(best):
                best, kind = parts[1], parts[2]
    return f'{kind} ({best})' if best else kind


def _size(path: Path) -> int:
    """Bytes of a file, or of every file under a folder."""
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob('*') if p.is_file())


def _memory_kb(pid: int) -> tuple[int, int] | None:
    """VmRSS and VmHWM of a process [kB] (None: gone)."""
    try:
        text = Path(f'/proc/{pid}/status').read_text()
    except OSError:
        return None
    values = {}
    for line in text.splitlines():
        key, _, rest = line.partition(':')
        if key in ('VmRSS', 'VmHWM'):
            values[key] = int(rest.split()[0])
    if 'VmRSS' not in values:
        return None  # a zombie
    return values['VmRSS'], values.get('VmHWM', values['VmRSS'])


def _journal_name() -> str:
    """The journal's file name in a run folder (pd_core imported when needed, as elsewhere
    here: ``--help`` needs no workspace)."""
    from pd_core.run.record.journal import JOURNAL_FILE

    return JOURNAL_FILE


def _mb(kb: float) -> float:
    return kb / 1024.0


def _slope(points: list[tuple[int, float]]) -> float | None:
    """Least-squares slope dy/dx of ``points`` (None: fewer than 3 or one x only)."""
    if len(points) < 3:
        return None
    n = len(points)
    mean_x = sum(x for x, _ in points) / n
    mean_y = sum(y for _, y in points) / n
    sxx = sum((x - mean_x) ** 2 for x, _ in points)
    if sxx == 0:
        return None
    return sum((x - mean_x) * (y - mean_y) for x, y in points) / sxx


class FsyncCounter:
    """Counts ``os.fsync`` calls while entered (``os.fsync`` wrapped; restored on exit)."""

    def __init__(self) -> None:
        self.count = 0
        self._real = os.fsync

    def _fsync(self, fd: Any) -> None:
        self.count += 1
        self._real(fd)

    def __enter__(self) -> FsyncCounter:
        self._real = os.fsync
        os.fsync = self._fsync
        return self

    def __exit__(self, *exc: object) -> None:
        os.fsync = self._real


def check_record(run: Any, steps: int) -> tuple[bool, str]:
    """Whether a ``RecordedRun`` holds a command and a feedback of every step 0..``steps``,
    its definition and a final status of that step."""
    from pd_common.protocol import Command, Feedback

    commands = {item.step for _, item in run.events if isinstance(item, Command)}
    feedback = {item.step for _, item in run.events if isinstance(item, Feedback)}
    expected = set(range(steps + 1))
    missing_c, missing_f = expected - commands, expected - feedback
    last = run.statuses[-1][1] if run.statuses else None
    ok = (not missing_c and not missing_f and bool(run.definition_json)
          and last is not None and last.step == steps)
    note = (f'{len(run.events):,} commands + feedback (steps {min(commands, default=0)}..'
            f'{max(commands, default=0):,}), {len(run.statuses)} statuses, last '
            f'{last.state.name.lower() if last is not None else "none"} at step '
            f'{last.step if last is not None else "-"}')
    if missing_c or missing_f:
        note += (f'; MISSING steps: {len(missing_c)} commands (first {sorted(missing_c)[:3]}), '
                 f'{len(missing_f)} feedback (first {sorted(missing_f)[:3]})')
    if run.notes:
        note += f'; notes: {"; ".join(run.notes)}'
    return ok, note


# -- 1. the ROS-free core -------------------------------------------------------------------
def step_loop(definition: Any, recorder_factory: Callable[[], Any] | None
              ) -> tuple[float, int, int]:
    """The step loop of ``run_offline`` with a recorder (or none): seconds, steps, fsyncs."""
    from pd_core.run.loop.dispatch import StepDispatcher
    from pd_core.run.loop.session import TestSession
    from pd_core.run.runner import serve_queue, site_servers

    servers = site_servers(definition)
    session = TestSession(definition)
    queue: deque[tuple[str, Any]] = deque()

    def send(site: str, command: Any) -> None:
        queue.append((site, command))

    with FsyncCounter() as fsyncs:
        start = time.perf_counter()
        recorder = recorder_factory() if recorder_factory is not None else None
        dispatcher = StepDispatcher(session, send, recorder)
        if recorder is not None:
            recorder.write_definition(definition.to_json(), time.time_ns())
            recorder.write_status(session.status(), time.time_ns())
        dispatcher.start()
        serve_queue(queue, servers, dispatcher)
        if recorder is not None:
            recorder.write_status(dispatcher.status(), time.time_ns())
            recorder.close()
        elapsed = time.perf_counter() - start
    return elapsed, session.committed_step, fsyncs.count


def _remove(path: Path) -> None:
    if path.is_file():
        path.unlink()
    elif path.is_dir():
        shutil.rmtree(path)


def bench_core(table: Table, work: Path, overrides: dict[str, Any]) -> Figures:
    """Section 1: µs/step without and with the journal, fsync per step, the conversion."""
    from pd_core.run.record.bag import BagRecorder
    from pd_core.run.record.journal import Journal, journal_to_bag
    from pd_core.run.test_file import load_test_file

    definition = load_test_file(DEFAULT_TEST, overrides)
    work = work / 'core'
    work.mkdir()
    kept = work / 'journal-kept.pdj'
    variants: dict[str, Callable[[Path], Any] | None] = {
        'none': None,
        'journal': lambda path: Journal(path.with_suffix('.pdj'), sync_interval=1.0).open(),
        'fsync_every_step': lambda path: Journal(path.with_suffix('.pdj'),
                                                 sync_interval=0.0).open(),
        'bag_recorder': lambda path: BagRecorder(path.with_suffix('.bag')).open(),
    }
    times: dict[str, list[float]] = {name: [] for name in variants}
    syncs: dict[str, list[int]] = {name: [] for name in variants}
    steps = definition.n_steps
    for index in range(REPEATS):
        for name, factory in variants.items():
            path = work / f'{name}-{index}'
            make = None if factory is None else (lambda f=factory, p=path: f(p))
            elapsed, steps, count = step_loop(definition, make)
            times[name].append(elapsed)
            syncs[name].append(count)
            journal = path.with_suffix('.pdj')
            if name == 'journal' and not kept.exists():
                journal.rename(kept)
            _remove(journal)
            _remove(path.with_suffix('.bag'))
    best = {name: min(range(REPEATS), key=values.__getitem__) for name, values in times.items()}
    us = {name: times[name][best[name]] / steps * 1e6 for name in variants}
    fsyncs = {name: syncs[name][best[name]] for name in variants}
    conversions = []
    for index in range(CONVERSIONS):
        start = time.perf_counter()
        journal_to_bag(kept, work / f'converted-{index}')
        conversions.append(time.perf_counter() - start)
    conversion = min(conversions)
    journal_bytes = kept.stat().st_size
    bag_bytes = _size(work / 'converted-0')
    figures: Figures = {
        'durability_steps': steps,
        'durability_none_us_per_step': us['none'],
        'durability_journal_us_per_step': us['journal'],
        'durability_fsync_every_step_us_per_step': us['fsync_every_step'],
        'durability_bag_recorder_us_per_step': us['bag_recorder'],
        'durability_journal_cost_us_per_step': us['journal'] - us['none'],
        'durability_fsync_cost_us_per_step': us['fsync_every_step'] - us['journal'],
        'durability_journal_fsyncs': fsyncs['journal'],
        'durability_fsync_every_step_fsyncs': fsyncs['fsync_every_step'],
        'durability_bag_recorder_fsyncs': fsyncs['bag_recorder'],
        'durability_journal_to_bag_s': conversion,
        'durability_journal_to_bag_us_per_step': conversion / steps * 1e6,
        'durability_journal_bytes_per_step': journal_bytes / steps,
        'durability_bag_bytes_per_step': bag_bytes / steps,
    }
    section = '1 core'
    spread = {name: f'{min(v) / steps * 1e6:.0f}-{max(v) / steps * 1e6:.0f}'
              for name, v in times.items()}
    table.add(section, f'step loop, no recorder ({steps:,} steps)', f'{us["none"]:.1f} us/step',
              f'{steps / min(times["none"]):,.0f} steps/s; best of {REPEATS} '
              f'(all: {spread["none"]} us)')
    fsync_us = ((us['fsync_every_step'] - us['journal']) * steps
                / max(fsyncs['fsync_every_step'] - fsyncs['journal'], 1))
    table.add(section, 'step loop + journal (sync_interval 1 s)', f'{us["journal"]:.1f} us/step',
              f'+{us["journal"] - us["none"]:.1f} us/step over none; {fsyncs["journal"]} '
              f'fsync(s) (the loop lasts {min(times["journal"]):.2f} s; one at close); all: '
              f'{spread["journal"]} us')
    table.add(section, 'step loop + journal (sync_interval 0)',
              f'{us["fsync_every_step"]:.1f} us/step',
              f'fsync every step ({fsyncs["fsync_every_step"]:,} fsyncs, ~{fsync_us:.0f} us '
              f'each): +{us["fsync_every_step"] - us["journal"]:.1f} us/step '
              f'over the 1 s interval; all: {spread["fsync_every_step"]} us')
    table.add(section, 'step loop + MCAP BagRecorder (not durable)',
              f'{us["bag_recorder"]:.1f} us/step',
              f'the pre-journal recorder, for comparison: '
              f'{us["bag_recorder"] - us["none"]:+.1f} us/step over none; '
              f'{fsyncs["bag_recorder"]} fsync(s); all: {spread["bag_recorder"]} us')
    figures.update(_longest_flushes(table, definition, work))
    figures.update(_longest_state_adds(table, definition, work))
    table.add(section, 'journal -> bag conversion (end of run)', f'{conversion * 1e3:.0f} ms',
              f'{conversion / steps * 1e6:.1f} us/step; best of {CONVERSIONS}')
    table.add(section, 'journal size', f'{journal_bytes / steps:.0f} B/step',
              f'{journal_bytes / 1e6:.2f} MB (unsigned, offline); the bag '
              f'{bag_bytes / steps:.0f} B/step')
    return figures


def _longest_flushes(table: Table, definition: Any, work: Path) -> Figures:
    """The longest a step waits for the journal when an fsync falls due: the fsync in the
    step (``sync_in_background=False``, ``run_offline``'s journal) against in its own thread
    (the integrator node's), ``sync_interval`` 10 ms so that the short loop meets many; best
    of REPEATS, interleaved."""
    from pd_core.run.record.journal import Journal

    class TimedFlushes(Journal):
        longest = 0.0

        def flush(self, *, sync: bool = True) -> None:
            start = time.perf_counter()
            super().flush(sync=sync)
            self.longest = max(self.longest, time.perf_counter() - start)

    longest: dict[bool, list[float]] = {False: [], True: []}
    counts: dict[bool, list[int]] = {False: [], True: []}
    for index in range(REPEATS):
        for background in (False, True):
            path = work / f'flushes-{index}-{int(background)}.pdj'
            made: list[TimedFlushes] = []

            def make(path: Path = path, background: bool = background,
                     made: list[TimedFlushes] = made) -> TimedFlushes:
                journal = TimedFlushes(path, sync_interval=0.01, sync_in_background=background)
                journal.open()
                made.append(journal)
                return journal

            _, _, count = step_loop(definition, make)
            longest[background].append(made[0].longest)
            counts[background].append(count)
            _remove(path)
    in_thread = (f'what the integrator node does: {counts[True][0]} fsyncs (one at close); '
                 f'best of {REPEATS}')
    return _in_step_against_in_thread(
        table, 'longest journal flush, fsync in the step', longest,
        (f'sync_interval 10 ms: {counts[False][0]} fsyncs (one at close); best of {REPEATS}',
         in_thread), 'durability_longest_flush_us')


def _in_step_against_in_thread(table: Table, label: str, longest: dict[bool, list[float]],
                               notes: tuple[str, str], figure: str) -> Figures:
    """The two rows (``label``, then the same in its thread) and figures of the best times."""
    in_step, off_step = min(longest[False]) * 1e6, min(longest[True]) * 1e6
    table.add('1 core', label, f'{in_step:.0f} us', notes[0])
    table.add('1 core', label.rsplit(', ', 1)[0] + ', fsync in its thread', f'{off_step:.0f} us',
              notes[1])
    return {f'{figure}_fsync_in_step': in_step, f'{figure}_fsync_in_background': off_step}


def _longest_state_adds(table: Table, definition: Any, work: Path, moves: int = 4000
                        ) -> Figures:
    """The longest a simulator's move waits for its state file (``ServedRecord.add``, before
    the move is answered) when an fsync falls due: in the caller against in its own thread
    (the simulator node's), ``sync_interval`` 10 ms, the default test's specimen serving
    ``moves`` moves between the adds; best of REPEATS, interleaved."""
    from pd_common.specimen import ServedRecord
    from pd_core.run.runner import site_servers

    longest: dict[bool, list[float]] = {False: [], True: []}
    for index in range(REPEATS):
        for background in (False, True):
            path = work / f'state-{index}-{int(background)}.jsonl'
            server = site_servers(definition)['']
            record = ServedRecord(path, 'bench', sync_interval=0.01,
                                  sync_in_background=background)
            worst = 0.0
            for step in range(moves):
                target = (0.01 * math.sin(step / 50.0),)
                server.handle(definition.test_id, step, target)
                start = time.perf_counter()
                record.add(definition.test_id, step, 0, target)
                worst = max(worst, time.perf_counter() - start)
            record.close()
            longest[background].append(worst)
            _remove(path)
    return _in_step_against_in_thread(
        table, 'longest state-file add, fsync in the move', longest,
        (f'a simulator\'s record, sync_interval 10 ms, {moves:,} moves; best of {REPEATS}',
         f'what the simulator node does; best of {REPEATS}'), 'durability_longest_state_add_us')


# -- 2. the offline soak ----------------------------------------------------------------------
PROGRESS = re.compile(r'step\s+(\d+)/(\d+)')


def soak_definition(steps: int) -> Any:
    """The default test with ``test.duration`` for ``steps`` steps."""
    from pd_core.run.test_file import load_test_file

    dt = load_test_file(DEFAULT_TEST, {}).dt
    definition = load_test_file(DEFAULT_TEST, {'duration': steps * dt})
    if definition.n_steps != steps:
        msg = f'duration {steps * dt} s gives {definition.n_steps} steps, not {steps}'
        raise RuntimeError(msg)
    return definition


def _instrument(module: Any, name: str, label: str, phases: dict[str, dict[str, float]]
                ) -> None:
    """Wrap ``module.<name>`` to time each call and note the memory around it (a name the
    module no longer has is left out)."""
    original = getattr(module, name, None)
    if not callable(original):
        return

    def timed(*args: Any, **kwargs: Any) -> Any:
        pid = os.getpid()
        before = _memory_kb(pid) or (0, 0)
        start = time.perf_counter()
        try:
            return original(*args, **kwargs)
        finally:
            after = _memory_kb(pid) or (0, 0)
            phases[label] = {'s': time.perf_counter() - start, 'rss_before_kb': before[0],
                             'hwm_before_kb': before[1], 'rss_after_kb': after[0],
                             'hwm_after_kb': after[1]}

    setattr(module, name, timed)


def soak_worker(directory: Path, steps: int) -> int:
    """The soak's child process: ``run_offline`` of ``steps`` steps into ``directory``.

    Prints what it saw as one JSON line (the last line of its standard output).
    """
    from pd_core.run import runner

    definition = soak_definition(steps)
    phases: dict[str, dict[str, float]] = {}
    # The end of the run: journal -> bag, then the outputs (as run_offline calls them).
    _instrument(runner, 'journal_to_bag', 'journal_to_bag', phases)
    _instrument(runner, 'finish_outputs', 'outputs', phases)
    pid = os.getpid()
    samples: list[tuple[float, int, int]] = []  # (s since the call, step, VmRSS kB)
    before = _memory_kb(pid) or (0, 0)
    start = time.perf_counter()

    def progress(line: str) -> None:
        match = PROGRESS.match(line)
        memory = _memory_kb(pid)
        if match is not None and memory is not None:
            samples.append((time.perf_counter() - start, int(match.group(1)), memory[0]))

    with FsyncCounter() as fsyncs:
        result = runner.run_offline(definition, directory, figures=False, progress=progress)
    elapsed = time.perf_counter() - start
    end = _memory_kb(pid) or (0, 0)
    summary = result.summary
    print(json.dumps({
        'steps': summary.get('steps'), 'state': summary.get('state'),
        'message': summary.get('message'), 'wall_time': summary.get('wall_time'),
        'run_offline_s': elapsed, 'fsyncs': fsyncs.count,
        'rss_before_kb': before[0], 'hwm_before_kb': before[1], 'rss_end_kb': end[0],
        'maxrss_kb': resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
        'samples': samples, 'phases': phases,
    }))
    return 0


def _run_worker(out: Path, steps: int, timeout: float) -> tuple[dict[str, Any] | None, str]:
    """This script with ``--soak-worker``: its report, or None and why."""
    command = [sys.executable, str(Path(__file__).resolve()), '--soak-worker', str(out),
               '--steps', str(steps)]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout,
                              check=False)
    except subprocess.TimeoutExpired:
        return None, f'the soak did not end within {timeout:.0f} s'
    lines = done.stdout.strip().splitlines()
    if done.returncode != 0 or not lines:
        tail = ' | '.join(done.stderr.strip().splitlines()[-3:])
        return None, f'the soak exited with {done.returncode}: {tail}'
    try:
        return json.loads(lines[-1]), ''
    except json.JSONDecodeError:
        return None, f'the soak printed no report: {lines[-1][:200]}'


def bench_soak(table: Table, steps: int, work: Path) -> tuple[Figures, Path | None]:
    """Section 2: the offline soak, its memory, rate, and its journal and bag read back.

    Returns the figures and the soak's run folder (None: it failed).
    """
    from pd_core.run.record.journal import read_journal
    from pd_core.run.runner import load_run

    section = '2 soak'
    out = work / 'soak-run'
    timeout = 120.0 + steps / 250.0
    print(f'soak: {steps:,} steps of run_offline (journal + bag + outputs) in a child process '
          f'(gives up after {timeout:.0f} s) ...', file=sys.stderr, flush=True)
    report, why = _run_worker(out, steps, timeout)
    figures: Figures = {'soak_steps_requested': steps}
    problems = []
    if report is None:
        problems.append(why)
        table.add(section, 'PROBLEM', '-', why)
        figures['soak_problems'] = why
        return figures, None
    done = int(report['steps'] or 0)
    wall = float(report['wall_time'] or 0.0)
    figures['soak_steps'] = done
    figures['soak_state'] = report['state']
    figures['soak_steps_per_s'] = done / wall if wall > 0 else None
    figures['soak_loop_s'] = wall
    figures['soak_run_offline_s'] = report['run_offline_s']
    figures['soak_fsyncs'] = report['fsyncs']
    if report['state'] != 'finished' or done != steps:
        problems.append(f'state {report["state"]}: {report["message"]}')
    table.add(section, f'run_offline, {done:,} steps', f'{figures["soak_steps_per_s"] or 0:,.0f} '
              'steps/s', f'the loop (summary.json wall_time) {wall:.1f} s '
              f'({wall / max(done, 1) * 1e6:.0f} us/step); the whole call '
              f'{report["run_offline_s"]:.1f} s; state {report["state"]}; '
              f'{report["fsyncs"]} fsyncs (sync_interval 1 s)')
    phases: dict[str, dict[str, float]] = report['phases']
    labels = {'journal_to_bag': 'end of run: journal -> bag',
              'outputs': 'end of run: outputs (no figures)'}
    for name, label in labels.items():
        phase = phases.get(name)
        if phase is None:
            continue
        raised = _mb(phase['hwm_after_kb'] - phase['hwm_before_kb'])
        figures[f'soak_{name}_s'] = phase['s']
        figures[f'soak_{name}_peak_growth_mb'] = raised
        table.add(section, label, f'{phase["s"]:.1f} s',
                  f'{phase["s"] / max(done, 1) * 1e6:.0f} us/step; RSS '
                  f'{_mb(phase["rss_before_kb"]):.0f} -> {_mb(phase["rss_after_kb"]):.0f} MB, '
                  f'raised the peak by {raised:.0f} MB to {_mb(phase["hwm_after_kb"]):.0f} MB')

    # Memory: the first progress line (step 0) to the last (the last step), then the peak.
    samples = [(t, step, kb) for t, step, kb in report['samples']]
    if samples:
        start_kb, loop_end_kb = samples[0][2], samples[-1][2]
        growth = _mb(loop_end_kb - start_kb)
        peak = _mb(report['maxrss_kb'])
        figures['soak_rss_before_mb'] = _mb(report['rss_before_kb'])
        figures['soak_rss_start_mb'] = _mb(start_kb)
        figures['soak_rss_loop_end_mb'] = _mb(loop_end_kb)
        figures['soak_rss_loop_growth_mb'] = growth
        figures['soak_rss_loop_growth_bytes_per_step'] = (
            (loop_end_kb - start_kb) * 1024.0 / max(samples[-1][1] - samples[0][1], 1))
        figures['soak_rss_peak_mb'] = peak
        figures['soak_rss_peak_growth_mb'] = peak - _mb(start_kb)
        figures['soak_rss_end_mb'] = _mb(report['rss_end_kb'])
        figures['soak_rss_samples'] = len(samples)
        slope = _slope([(step, _mb(kb)) for _, step, kb in samples])
        figures['soak_rss_slope_mb_per_10k_steps'] = slope * 1e4 if slope is not None else None
        trace = ', '.join(f'{_mb(samples[round(q * (len(samples) - 1))][2]):.1f}'
                          for q in (0.0, 0.25, 0.5, 0.75, 1.0))
        slope_text = f'{slope * 1e4:+.2f} MB per 10k steps' if slope is not None else '-'
        table.add(section, 'RSS during the loop', f'{_mb(start_kb):.1f} -> '
                  f'{_mb(loop_end_kb):.1f} MB',
                  f'{growth:+.1f} MB ({figures["soak_rss_loop_growth_bytes_per_step"]:.0f} '
                  f'B/step; the history is kept in memory); least squares {slope_text}; at '
                  f'0/25/50/75/100 % of the loop: {trace} MB ({len(samples)} samples, one per '
                  'progress line)')
        table.add(section, 'RSS peak (ru_maxrss)', f'{peak:.1f} MB',
                  f'{peak - _mb(start_kb):+.1f} MB over the loop start; '
                  f'{_mb(report["rss_before_kb"]):.1f} MB before run_offline, '
                  f'{_mb(report["rss_end_kb"]):.1f} MB after it')

    # The journal and the bag read back.
    journal = out / _journal_name()
    bag = out / 'bag'
    figures['soak_journal_mb'] = _size(journal) / 1e6 if journal.is_file() else None
    figures['soak_bag_mb'] = _size(bag) / 1e6 if bag.is_dir() else None
    figures['soak_journal_bytes_per_step'] = (_size(journal) / done
                                              if done and journal.is_file() else None)
    runs = {}
    for name, reader, path in (('journal', read_journal, journal), ('bag', load_run, out)):
        start = time.perf_counter()
        try:
            run = reader(path)
        except Exception as err:  # noqa: BLE001  (reported, not raised)
            figures[f'soak_{name}_readable'] = False
            problems.append(f'{name} unreadable: {err}')
            continue
        elapsed = time.perf_counter() - start
        ok, note = check_record(run, steps)
        if name == 'bag' and not (bag / 'metadata.yaml').is_file():
            ok, note = False, f'no complete bag: load_run read the journal; {note}'
        runs[name] = run
        figures[f'soak_{name}_readable'] = ok
        figures['soak_read_journal_s' if name == 'journal' else 'soak_load_run_s'] = elapsed
        if not ok:
            problems.append(f'{name} incomplete: {note}')
        size = figures[f'soak_{name}_mb']
        table.add(section, 'journal (read_journal)' if name == 'journal' else 'bag (load_run)',
                  f'{size or 0:.1f} MB',
                  f'{"readable, every step" if ok else "NOT READABLE/COMPLETE"}: {note}; read '
                  f'in {elapsed:.1f} s' + (f'; {figures["soak_journal_bytes_per_step"]:.0f} '
                                           'B/step' if name == 'journal' else ''))
    if len(runs) == 2:
        same = (runs['journal'].events == runs['bag'].events
                and runs['journal'].statuses == runs['bag'].statuses)
        figures['soak_journal_bag_identical'] = same
        table.add(section, 'journal vs bag', 'identical' if same else 'DIFFERENT',
                  'the commands, feedback (with their time stamps) and statuses read from both')
        if not same:
            problems.append('the journal and the bag give different histories')
    runs.clear()
    for problem in problems:
        table.add(section, 'PROBLEM', '-', problem)
    figures['soak_problems'] = '; '.join(problems) or None
    return figures, out if journal.is_file() else None


# -- 3. recovery from a journal cut mid-line --------------------------------------------------
@dataclass
class KilledRun:
    """A run folder as a kill mid-step leaves it."""

    folder: Path
    kept_bytes: int
    cut_line_bytes: int  # bytes of the last, torn record kept
    committed: int  # the step of the last complete feedback record


def make_killed_run(run_dir: Path, folder: Path, fraction: float) -> KilledRun:
    """A new run folder with the start of ``run_dir``'s journal, cut in the middle of a line
    (the first after ``fraction`` of the file), its ``test_definition.json``, and no bag."""
    from pd_common.protocol import decode_feedback
    from pd_core.run.record.journal_format import RecordKind, iter_frames

    journal = run_dir / _journal_name()
    data = journal.read_bytes()
    committed = -1
    start = end = len(data)
    for record in iter_frames(journal):
        if record.offset >= int(len(data) * fraction):
            start, end = record.offset, record.end
            break
        if record.kind is RecordKind.FEEDBACK:
            committed = decode_feedback(record.payload).record.step
    cut = start + max(1, (end - start) // 2)
    folder.mkdir(parents=True)
    (folder / _journal_name()).write_bytes(data[:cut])
    definition = run_dir / 'test_definition.json'
    if definition.is_file():
        shutil.copy(definition, folder / definition.name)
    return KilledRun(folder, cut, cut - start, committed)


def check_recovered(killed: KilledRun, summary: dict[str, Any], full_run: Path) -> list[str]:
    """What is wrong with a recovered run folder (nothing: [])."""
    problems = []
    if summary.get('steps') != killed.committed:
        problems.append(f'{summary.get("steps")} steps recovered, the journal committed '
                        f'{killed.committed}')
    if not summary.get('recovered') or not summary.get('partial'):
        problems.append(f'summary: recovered {summary.get("recovered")}, partial '
                        f'{summary.get("partial")}')
    if not any('cut short' in note for note in summary.get('record_notes', [])):
        problems.append(f'the cut line is not reported (record_notes '
                        f'{summary.get("record_notes")})')
    if not (killed.folder / 'bag' / 'metadata.yaml').is_file():
        problems.append('no complete bag written')
    recovered = (killed.folder / 'response.csv').read_text(encoding='utf-8').splitlines()
    full = (full_run / 'response.csv').read_text(encoding='utf-8').splitlines()
    if len(recovered) != killed.committed + 2 or recovered != full[:len(recovered)]:
        problems.append(f'response.csv ({len(recovered):,} lines) is not the first '
                        f'{killed.committed + 2:,} lines of the full run\'s')
    return problems


def bench_recovery(table: Table, work: Path, overrides: dict[str, Any],
                   soak_run: Path | None) -> Figures:
    """Section 3: recover_run of a journal cut mid-line (default test, and the soak's)."""
    from pd_core.run.runner import recover_run, run_offline
    from pd_core.run.test_file import load_test_file

    section = '3 recovery'
    work = work / 'recovery'
    work.mkdir()
    figures: Figures = {}
    problems: list[str] = []
    reference = work / 'default-run'
    run_offline(load_test_file(DEFAULT_TEST, overrides), reference, figures=False)

    # The default test: best of REPEATS in this process, each on a fresh killed folder.
    times = []
    killed = None
    for index in range(REPEATS):
        killed = make_killed_run(reference, work / f'default-{index}', RECOVERY_CUT_DEFAULT)
        start = time.perf_counter()
        result = recover_run(killed.folder, figures=False)
        times.append(time.perf_counter() - start)
        if index == 0:
            problems += [f'default: {p}' for p in check_recovered(killed, result.summary,
                                                                  reference)]
    assert killed is not None
    best = min(times)
    steps = killed.committed
    figures['recovery_default_steps'] = steps
    figures['recovery_default_s'] = best
    figures['recovery_default_us_per_step'] = best / max(steps, 1) * 1e6
    table.add(section, f'recover_run, default test cut at {RECOVERY_CUT_DEFAULT:.0%}',
              f'{best * 1e3:.0f} ms',
              f'{steps:,} committed steps ({best / max(steps, 1) * 1e6:.0f} us/step; the cut '
              f'record kept {killed.cut_line_bytes} B); bag + response.csv + summary, no '
              f'figures; in this process, best of {REPEATS} (all: '
              f'{", ".join(f"{t * 1e3:.0f}" for t in times)} ms)')

    # The same through the command line, with its figures, as an operator runs it.
    killed = make_killed_run(reference, work / 'default-cli', RECOVERY_CUT_DEFAULT)
    command = ([str(RECOVER)] if RECOVER.is_file()
               else [sys.executable, '-m', 'pd_integrator.recover'])
    start = time.perf_counter()
    done = subprocess.run([*command, str(killed.folder)], capture_output=True, text=True,
                          timeout=300.0, check=False)
    cli = time.perf_counter() - start
    figures['recovery_default_cli_s'] = cli
    if done.returncode != 0:
        problems.append(f'recover CLI exited with {done.returncode}: '
                        f'{done.stderr.strip()[-200:]}')
        cli_note = 'FAILED'
    else:
        summary = json.loads((killed.folder / 'summary.json').read_text(encoding='utf-8'))
        problems += [f'CLI: {p}' for p in check_recovered(killed, summary, reference)]
        figures_made = len(list(killed.folder.glob('*.png')))
        cli_note = f'{figures_made} figures; "{done.stdout.strip()[:90]}..."'
    table.add(section, 'recover command line (with figures)', f'{cli:.1f} s',
              f'{Path(command[-1]).name} RUN: start-up, matplotlib and the figures included; '
              f'{cli_note}')

    # The soak's journal: a long run killed near its end.
    if soak_run is not None:
        killed = make_killed_run(soak_run, work / 'soak', RECOVERY_CUT_SOAK)
        print(f'recovery: recover_run of the soak journal cut at {RECOVERY_CUT_SOAK:.0%} '
              f'({killed.kept_bytes / 1e6:.0f} MB) ...', file=sys.stderr, flush=True)
        start = time.perf_counter()
        result = recover_run(killed.folder, figures=False)
        elapsed = time.perf_counter() - start
        problems += [f'soak: {p}' for p in check_recovered(killed, result.summary, soak_run)]
        steps = killed.committed
        figures['recovery_soak_steps'] = steps
        figures['recovery_soak_s'] = elapsed
        figures['recovery_soak_us_per_step'] = elapsed / max(steps, 1) * 1e6
        table.add(section, f'recover_run, soak cut at {RECOVERY_CUT_SOAK:.0%}',
                  f'{elapsed:.1f} s',
                  f'{steps:,} committed steps ({elapsed / max(steps, 1) * 1e6:.0f} us/step; '
                  f'journal {killed.kept_bytes / 1e6:.1f} MB); no figures; once')
    figures['recovery_consistent'] = not problems
    table.add(section, 'recovered runs checked', 'consistent' if not problems else 'PROBLEMS',
              'steps = the last complete feedback of the cut journal; the cut line reported; '
              'recovered + partial; a complete bag; response.csv = the start of the full '
              'run\'s, line for line')
    for problem in problems:
        table.add(section, 'PROBLEM', '-', problem)
    figures['recovery_problems'] = '; '.join(problems) or None
    return figures


# -- 4. the soak through the node graph (--graph-soak) ---------------------------------------
def soak_test_file(steps: int, directory: Path) -> Path:
    """The default test with ``test.duration`` for ``steps`` steps (absolute record path)."""
    from pd_core.run.test_file import load_test_file

    raw = yaml.safe_load(DEFAULT_TEST.read_text(encoding='utf-8'))
    raw['test']['duration'] = steps * float(raw['test']['dt'])
    raw['test']['id'] = f'soak-{steps}'
    motion = raw['ground_motion']
    motion['file'] = str((DEFAULT_TEST.parent / motion['file']).resolve())
    path = directory / f'soak_{steps}.yaml'
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    n_steps = load_test_file(path, {}).n_steps
    if n_steps != steps:
        msg = f'{path}: duration {raw["test"]["duration"]} gives {n_steps} steps, not {steps}'
        raise RuntimeError(msg)
    return path


def _children(pid: int) -> list[int]:
    found: list[int] = []
    with contextlib.suppress(OSError):
        for task in Path(f'/proc/{pid}/task').iterdir():
            with contextlib.suppress(OSError):
                found += [int(x) for x in (task / 'children').read_text().split()]
    return found


def _node_name(pid: int) -> str | None:
    try:
        argv = Path(f'/proc/{pid}/cmdline').read_bytes().split(b'\0')
    except OSError:
        return None
    for arg in argv[:3]:  # [python,] <prefix>/lib/<package>/main, as ``ros2 run`` runs it
        path = Path(arg.decode(errors='replace'))
        if path.parent.name in NODES and path.name == 'main':
            return path.parent.name
    return None


@dataclass
class Sample:
    """One look at the running graph."""

    t: float  # s since launch
    wall: float  # time.time() (to compare with the log's time stamps)
    step: int  # the last step the integrator reported (progress line)
    journal: int  # journal bytes
    converting: bool  # the bag folder exists: the loop is over, the conversion runs
    memory: dict[str, tuple[int, int]]  # node -> (VmRSS, VmHWM) kB


LOG_LINE = re.compile(r'\[(\w+)\] \[(\d+\.\d+)\] \[([^\]]*)\]: (.*)$')


@dataclass
class IntegratorLog:
    """What the integrator's console lines tell (ROS time stamps, s)."""

    running: float | None = None
    finished: float | None = None
    folder: float | None = None
    progress: list[tuple[float, int]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    def feed(self, line: str) -> None:
        match = LOG_LINE.search(line)
        if match is None:
            return
        level, stamp, logger, text = match.groups()
        if level in ('WARN', 'ERROR', 'FATAL'):
            self.warnings.append(f'{logger}: {text}'[:200])
        if not logger.endswith('pd_integrator'):
            return
        t = float(stamp)
        if text.startswith('running:') and self.running is None:
            self.running = t
        elif text.startswith('finished:'):
            self.finished = t
        elif text.startswith('run folder:'):
            self.folder = t
        elif (progress := PROGRESS.match(text)) is not None:
            self.progress.append((t, int(progress.group(1))))

    @property
    def step(self) -> int:
        return self.progress[-1][1] if self.progress else 0

    def rate_between(self, low: float, high: float, total: int) -> float | None:
        """Steps/s between the progress lines nearest ``low``·total and ``high``·total."""
        points = ([(self.running, 0)] if self.running else []) + self.progress
        if self.finished is not None:
            points.append((self.finished, total))
        if len(points) < 2:
            return None
        first = min(points, key=lambda p: abs(p[1] - low * total))
        last = min(points, key=lambda p: abs(p[1] - high * total))
        if last[0] <= first[0]:
            return None
        return (last[1] - first[1]) / (last[0] - first[0])


@dataclass
class SoakRun:
    """The soak's raw observations."""

    samples: list[Sample]
    log: IntegratorLog
    returncode: int | None
    killed: bool
    stalled: bool
    timed_out: bool
    launch_to_exit: float
    removed_shm: int


def run_soak(test: Path, out: Path, domain_id: int, timeout: float) -> SoakRun:
    """``run_test TEST --out OUT --no-figures`` (site bridge), sampled every SAMPLE_PERIOD."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    log_path = out.with_suffix('.log')
    journal = out / _journal_name()
    samples: list[Sample] = []
    log = IntegratorLog()
    names: dict[int, str] = {}
    stalled = timed_out = False
    before = shm_snapshot()
    start = time.monotonic()
    with log_path.open('wb') as sink, log_path.open('r', errors='replace') as reader:
        process = subprocess.Popen([str(LAUNCHER), str(test), '--out', str(out), '--no-figures'],
                                   stdout=sink, stderr=subprocess.STDOUT, env=env,
                                   start_new_session=True)
        partial = ''
        last_growth, last_size = time.monotonic(), -1
        try:
            while process.poll() is None:
                chunk = reader.read()
                if chunk:
                    lines = (partial + chunk).split('\n')
                    partial = lines.pop()
                    for line in lines:
                        log.feed(line)
                for pid in _children(process.pid):
                    if pid not in names and (name := _node_name(pid)) is not None:
                        names[pid] = name if name not in names.values() else f'{name}-{pid}'
                memory = {name: m for pid, name in names.items()
                          if (m := _memory_kb(pid)) is not None}
                size = journal.stat().st_size if journal.is_file() else 0
                converting = (out / 'bag').exists()
                now = time.monotonic()
                if 'pd_integrator' in memory:
                    samples.append(Sample(now - start, time.time(), log.step, size, converting,
                                          memory))
                if size != last_size:
                    last_growth, last_size = now, size
                elif (size > 0 and not converting and log.finished is None
                      and now - last_growth > STALL_TIMEOUT):
                    stalled = True
                    break
                if now - start > timeout:
                    timed_out = True
                    break
                time.sleep(SAMPLE_PERIOD)
        finally:
            stopped = stop_process(process)
            for line in (partial + reader.read()).split('\n'):
                log.feed(line)
    removed = remove_stale_segments(before, domain_id)
    return SoakRun(samples, log, stopped.returncode, stopped.killed, stalled, timed_out,
                   time.monotonic() - start, len(removed))


def check_bag(bag: Path, steps: int) -> tuple[bool, str, float]:
    """Whether ``read_bag`` reads it and it holds a command and a feedback for every step."""
    from pd_common.protocol import Command, Feedback
    from pd_core.run.record.bag import read_bag

    start = time.perf_counter()
    try:
        run = read_bag(bag)
    except Exception as err:  # noqa: BLE001  (reported, not raised)
        return False, f'read_bag failed: {err}', time.perf_counter() - start
    elapsed = time.perf_counter() - start
    commands = [item for _, item in run.events if isinstance(item, Command)]
    feedback = [item for _, item in run.events if isinstance(item, Feedback)]
    expected = set(range(steps + 1))
    missing_c = expected - {c.step for c in commands}
    missing_f = expected - {f.step for f in feedback}
    ok = not missing_c and not missing_f and bool(run.definition_json)
    note = (f'{len(commands):,} commands, {len(feedback):,} feedback, {len(run.statuses)} '
            f'statuses, {len(run.bridge_statuses)} bridge statuses')
    if missing_c or missing_f:
        note += (f'; MISSING steps: {len(missing_c)} commands (first {sorted(missing_c)[:3]}), '
                 f'{len(missing_f)} feedback (first {sorted(missing_f)[:3]})')
    return ok, note, elapsed


def _quantiles(samples: list[Sample]) -> list[Sample]:
    """The samples at 0, 25, 50, 75 and 100 % of a list."""
    if not samples:
        return []
    return [samples[round(q * (len(samples) - 1))] for q in (0.0, 0.25, 0.5, 0.75, 1.0)]


def bench_graph_soak(table: Table, steps: int, domain_id: int, work: Path) -> Figures:
    """Section 4: the graph soak, its memory, rate, bag and replay."""
    from pd_core.run.record.journal import journal_to_bag
    from pd_core.run.runner import rebuild_outputs

    section = '4 graph soak'
    test = soak_test_file(steps, work)
    out = work / 'graph-soak-run'
    timeout = 300.0 + steps / 40.0
    print(f'soak: {steps:,} steps through run_test --site bridge (ROS_DOMAIN_ID {domain_id}; '
          f'gives up after {timeout:.0f} s) ...', file=sys.stderr, flush=True)
    soak = run_soak(test, out, domain_id, timeout)
    figures: Figures = {'graph_soak_steps_requested': steps}
    summary_file = out / 'summary.json'
    summary = (json.loads(summary_file.read_text(encoding='utf-8'))
               if summary_file.is_file() else {})
    done = int(summary.get('steps', 0))
    wall = float(summary.get('wall_time') or 0.0)
    problems = []
    if soak.stalled:
        problems.append(f'HOLD: the journal stopped growing for {STALL_TIMEOUT:.0f} s at step '
                        f'~{soak.log.step}; stopped')
    if soak.timed_out:
        problems.append(f'TIMEOUT after {timeout:.0f} s at step ~{soak.log.step}')
    if soak.killed:
        problems.append('a process had to be killed')
    if not summary:
        problems.append(f'no summary.json (exit {soak.returncode})')
    elif summary.get('state') != 'finished' or done != steps:
        problems.append(f'state {summary.get("state")}: {summary.get("message")}')
    figures['graph_soak_steps'] = done
    figures['graph_soak_state'] = summary.get('state')
    figures['graph_soak_retries'] = summary.get('retries')
    figures['graph_soak_steps_per_s'] = done / wall if wall > 0 else None
    loop_rate = None
    if soak.log.running is not None and soak.log.finished is not None:
        loop_rate = done / (soak.log.finished - soak.log.running)
    figures['graph_soak_loop_steps_per_s'] = loop_rate
    figures['graph_soak_steps_per_s_first_10pct'] = soak.log.rate_between(0.0, 0.1, steps)
    figures['graph_soak_steps_per_s_last_10pct'] = soak.log.rate_between(0.9, 1.0, steps)
    finish = (soak.log.folder - soak.log.finished
              if soak.log.folder is not None and soak.log.finished is not None else None)
    figures['graph_soak_finish_s'] = finish
    rate_note = (f'summary.json: {done:,} steps / wall_time {wall:.1f} s (wall_time includes '
                 f'the end-of-run conversion and outputs)')
    table.add(section, 'steps/s (summary.json)',
              f'{figures["graph_soak_steps_per_s"]:,.0f} steps/s' if wall > 0 else '-', rate_note)
    first = figures['graph_soak_steps_per_s_first_10pct']
    last = figures['graph_soak_steps_per_s_last_10pct']
    table.add(section, 'steps/s of the step loop (log)',
              f'{loop_rate:,.0f} steps/s' if loop_rate else '-',
              f'"running" to "finished"; first 10 %: {first or 0:,.0f}, last 10 %: '
              f'{last or 0:,.0f} steps/s; state {summary.get("state")}, '
              f'{summary.get("retries")} re-sends, launch to exit {soak.launch_to_exit:.0f} s')
    table.add(section, 'end of run: conversion + outputs',
              f'{finish:.1f} s' if finish is not None else '-',
              '"finished" to "run folder" in the integrator log (journal -> bag, response.csv, '
              'energy, tracking, summary)')

    # Memory: start = first sample after START_STEP, end = last sample before the exit.
    samples = soak.samples
    start_step = min(START_STEP, steps // 10)
    begin = next((s for s in samples if s.step >= start_step), samples[0] if samples else None)
    end = samples[-1] if samples else None
    # The step loop: the samples before the integrator logged "finished" (its end: reading the
    # journal and writing the bag come after).
    finished = soak.log.finished
    looping = [s for s in samples
               if (s.wall < finished if finished is not None else not s.converting)]
    loop_end = looping[-1] if looping else None
    if begin is not None and end is not None:
        for name in sorted({name for s in samples for name in s.memory}):
            # Each node's own last sample: the bridge and the simulator stop before the
            # integrator has written the bag, so the run's last sample has no row for them.
            final = next((s for s in reversed(samples) if name in s.memory), None)
            if name not in begin.memory or final is None:
                continue
            rss0, rss1 = _mb(begin.memory[name][0]), _mb(final.memory[name][0])
            peak = _mb(max(s.memory[name][1] for s in samples if name in s.memory))
            figures[f'graph_soak_rss_start_mb_{name}'] = rss0
            figures[f'graph_soak_rss_end_mb_{name}'] = rss1
            figures[f'graph_soak_rss_growth_mb_{name}'] = rss1 - rss0
            figures[f'graph_soak_rss_peak_mb_{name}'] = peak
            note = (f'start: t {begin.t:.0f} s (step {begin.step:,}); end: t {final.t:.0f} s '
                    f'(its last sample before it exited); peak (VmHWM) {peak:.1f} MB')
            if name == 'pd_integrator' and loop_end is not None and loop_end is not end:
                rss_loop = _mb(loop_end.memory[name][0])
                figures['graph_soak_rss_loop_end_mb_pd_integrator'] = rss_loop
                span = max(loop_end.step - begin.step, 1)
                per_10k = (rss_loop - rss0) / span * 1e4
                figures['graph_soak_rss_loop_growth_mb_per_10k_steps_pd_integrator'] = per_10k
                note += (f'; at the end of the loop (t {loop_end.t:.0f} s, step '
                         f'{loop_end.step:,}) {rss_loop:.1f} MB: {per_10k:+.2f} MB per 10k '
                         'steps while stepping')
            slope = _slope([(s.step, _mb(s.memory[name][0])) for s in looping
                            if name in s.memory and s.step >= begin.step])
            if slope is not None:
                figures[f'graph_soak_rss_slope_mb_per_10k_steps_{name}'] = slope * 1e4
                trace = ', '.join(f'{_mb(s.memory[name][0]):.1f}' for s in _quantiles(
                    [s for s in looping if name in s.memory and s.step >= begin.step]))
                note += (f'; least-squares slope while stepping {slope * 1e4:+.2f} MB per '
                         f'10k steps; at 0/25/50/75/100 % of the loop: {trace} MB')
            table.add(section, f'RSS {name}', f'{rss0:.1f} -> {rss1:.1f} MB',
                      f'{rss1 - rss0:+.1f} MB; {note}')
    figures['graph_soak_rss_samples'] = len(samples)
    with (work / 'graph-soak-rss.csv').open('w', encoding='utf-8') as trace_file:
        nodes = sorted({name for s in samples for name in s.memory})
        trace_file.write(','.join(['t_s', 'step', 'journal_bytes', 'converting',
                                   *(f'{n}_rss_kb' for n in nodes)]) + '\n')
        for s in samples:
            trace_file.write(','.join([f'{s.t:.2f}', str(s.step), str(s.journal),
                                       str(int(s.converting)),
                                       *(str(s.memory.get(n, (0, 0))[0]) for n in nodes)])
                             + '\n')

    # The bag, the journal, the replay.
    bag = out / 'bag'
    journal = out / _journal_name()
    figures['graph_soak_bag_mb'] = _size(bag) / 1e6 if bag.exists() else None
    figures['graph_soak_journal_mb'] = _size(journal) / 1e6 if journal.exists() else None
    figures['graph_soak_journal_bytes_per_step'] = (_size(journal) / done
                                                    if done and journal.exists() else None)
    readable = False
    if (bag / 'metadata.yaml').is_file():
        readable, note, read_s = check_bag(bag, done or steps)
        figures['graph_soak_read_bag_s'] = read_s
        table.add(section, 'bag (read_bag)', f'{_size(bag) / 1e6:.1f} MB',
                  f'{"readable, complete" if readable else "NOT READABLE/COMPLETE"}: {note}; '
                  f'read in {read_s:.1f} s; journal {_size(journal) / 1e6:.1f} MB '
                  f'({figures["graph_soak_journal_bytes_per_step"] or 0:.0f} B/step, signed)')
    else:
        problems.append('no complete bag (bag/metadata.yaml missing)')
    figures['graph_soak_bag_readable'] = readable
    consistent = False
    if readable:
        start = time.perf_counter()
        try:
            replay = rebuild_outputs(bag, work / 'graph-soak-replay', figures=False)
            replay_s = time.perf_counter() - start
            same_csv = ((work / 'graph-soak-replay' / 'response.csv').read_bytes()
                        == (out / 'response.csv').read_bytes())
            consistent = same_csv and int(replay.summary['steps']) == done
            figures['graph_soak_replay_s'] = replay_s
            table.add(section, 'replay (rebuild_outputs of the bag)', f'{replay_s:.1f} s',
                      f'{replay.summary["steps"]:,} steps, state {replay.summary["state"]}; '
                      f'response.csv {"identical to" if same_csv else "DIFFERS from"} the run\'s')
        except Exception as err:  # noqa: BLE001  (reported, not raised)
            problems.append(f'replay failed: {err}')
    figures['graph_soak_replay_consistent'] = consistent
    if journal.is_file():
        start = time.perf_counter()
        journal_to_bag(journal, work / 'graph-soak-reconverted-bag')
        again = time.perf_counter() - start
        figures['graph_soak_journal_to_bag_s'] = again
        table.add(section, 'journal -> bag of the soak (again, here)', f'{again:.1f} s',
                  f'{again / max(done, 1) * 1e6:.0f} us/step; in this process, after the run')
    if soak.removed_shm:
        table.add(section, 'clean-up', '-', f'removed {soak.removed_shm} stale shm files')
    warnings = soak.log.warnings
    if warnings:
        table.add(section, 'warnings in the log', str(len(warnings)),
                  ' | '.join(warnings[:3]))
    for problem in problems:
        table.add(section, 'PROBLEM', '-', problem)
    figures['graph_soak_problems'] = '; '.join(problems) or None
    return figures



# -- main -------------------------------------------------------------------------------------
def _raise_interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


@contextlib.contextmanager
def _workdir(keep: str | None) -> Iterator[Path]:
    if keep:
        path = Path(keep)
        path.mkdir(parents=True, exist_ok=False)
        yield path
        return
    with tempfile.TemporaryDirectory(prefix='pd-bench-durability-') as name:
        yield Path(name)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """Command-line arguments."""
    parser = argparse.ArgumentParser(prog='bench_durability',
                                     description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true',
                        help=f'the core on a {QUICK_DURATION:g} s test, a '
                        f'{QUICK_SOAK_STEPS:,}-step soak (default {SOAK_STEPS:,})')
    parser.add_argument('--steps', type=int, default=None, help='steps of the offline soak')
    parser.add_argument('--no-soak', action='store_true', help='skip the offline soak')
    parser.add_argument('--no-recovery', action='store_true', help='skip the recovery')
    parser.add_argument('--graph-soak', action='store_true',
                        help='also soak the node graph (run_test --site bridge)')
    parser.add_argument('--graph-steps', type=int, default=None,
                        help=f'steps of the graph soak (default {GRAPH_SOAK_STEPS:,}; '
                        f'{QUICK_GRAPH_SOAK_STEPS:,} with --quick)')
    parser.add_argument('--domain-id', type=int, default=65,
                        help='ROS_DOMAIN_ID of the graph soak (default 65)')
    parser.add_argument('--keep', metavar='DIR', default=None,
                        help='work in DIR (new) and keep it: the runs, the recovered folders')
    parser.add_argument('--soak-worker', metavar='DIR', default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if not 0 <= args.domain_id <= 232:
        parser.error('--domain-id: expected 0..232')
    if args.steps is not None and args.steps < 100:
        parser.error('--steps: expected at least 100')
    if args.graph_steps is None:
        args.graph_steps = QUICK_GRAPH_SOAK_STEPS if args.quick else GRAPH_SOAK_STEPS
    if args.graph_steps < 100:
        parser.error('--graph-steps: expected at least 100')
    return args


def main(argv: list[str] | None = None) -> int:
    """Entry point."""
    args = parse_args(argv)
    steps = args.steps or (QUICK_SOAK_STEPS if args.quick else SOAK_STEPS)
    if args.soak_worker is not None:
        return soak_worker(Path(args.soak_worker), steps)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _raise_interrupt)
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ['ROS_DOMAIN_ID'] = str(args.domain_id)
    overrides: dict[str, Any] = {'duration': QUICK_DURATION} if args.quick else {}
    header = machine_header(args.domain_id).replace('pd bench_loop', 'pd bench_durability', 1)
    table = Table()
    figures: Figures = {}
    sections: list[str] = []
    started = time.perf_counter()
    interrupted = False
    with _workdir(args.keep) as work:
        print(header)
        print(f'work folder: {work}, file system {_filesystem(work)}'
              f'{" [--quick]" if args.quick else ""}')
        print(flush=True)
        try:
            figures.update(bench_core(table, work, overrides))
            sections.append('core')
            soak_run = None
            if not args.no_soak:
                soak, soak_run = bench_soak(table, steps, work)
                figures.update(soak)
                sections.append('soak')
            if not args.no_recovery:
                figures.update(bench_recovery(table, work, overrides, soak_run))
                sections.append('recovery')
            if args.graph_soak:
                figures.update(bench_graph_soak(table, args.graph_steps, args.domain_id, work))
                sections.append('graph')
        except KeyboardInterrupt:
            interrupted = True
            table.add('-', 'INTERRUPTED', '-', 'the figures above are all that was measured')
    print(table.render())
    load = ', '.join(f'{value:.2f}' for value in os.getloadavg())
    print(f'\n(benchmark wall time {time.perf_counter() - started:.0f} s; load average '
          f'after: {load})')
    if figures:
        merge_results(figures, drop_prefixes=tuple(PREFIXES[name] for name in sections))
        print(f'written to {RESULTS}')
    return 130 if interrupted else 0


if __name__ == '__main__':
    sys.exit(main())
