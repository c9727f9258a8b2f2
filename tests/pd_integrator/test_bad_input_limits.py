"""Every command tells the truth: bad input is one line naming the file and the parameter.

Each class of input goes through the real entry points (``offline``, ``pretest``, ``run_test``,
``replay``, ``recover``, ``console``, ``rths_benchmark``) in a subprocess: exit code 2 (1 for a
run whose files could not be written), one line on stderr, nothing on stdout, no traceback,
within seconds, nothing written (the run folder is not made). The inputs: YAML nested
thousands of levels deep, a test of 1e11 steps, files that are no files (``/dev/zero``, a
FIFO, a directory), binary test files, damaged journals and a symbolic link loop as a run
folder, numbers that overflow, booleans where numbers belong, keys given twice, a read-only
folder and a full disk.
"""

from __future__ import annotations

import json
import os
import re
import resource
import shutil
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

from support import journals
from support.paths import DEFAULT_TEST, INSTALL

#: The modules of the entry points (when the workspace is not installed).
MODULES = {'run_test': 'pd_bringup.launcher', 'offline': 'pd_integrator.offline',
           'pretest': 'pd_pretest.pretest', 'replay': 'pd_integrator.replay',
           'recover': 'pd_integrator.recover', 'console': 'pd_console.console',
           'journal': 'pd_integrator.journal', 'control': 'pd_bringup.control',
           'schema': 'pd_common.config.schema_cli', 'keygen': 'pd_bringup.keygen',
           'study_ch5': 'pd_studies.study_ch5', 'analyze': 'pd_scheme_analysis.analyze',
           'rths_benchmark': 'pd_rths_benchmark.rths_benchmark'}
#: Seconds a refusal may take (a process start with numpy and scipy is about one).
PROMPT = 10.0
#: The test-file commands, with options that keep them from writing anywhere but ``--out``.
TEST_FILE_COMMANDS = {'offline': ['--quiet', '--no-figures'], 'pretest': ['--no-figures'],
                      'run_test': ['--no-authentication']}


@dataclass(frozen=True)
class Result:
    code: int
    stdout: str
    stderr: str
    seconds: float


def command(program: str) -> list[str]:
    """The entry point ``./pd <program>`` runs (or its module, without the install)."""
    package = MODULES[program].split('.')[0]
    executable = INSTALL / package / 'lib' / package / program
    if executable.is_file():
        return [str(executable)]
    return [sys.executable, '-m', MODULES[program]]


def run(program: str, *args: str, cwd: Path, limit_file_size: int | None = None,
        full_disk: Path | None = None) -> Result:
    """Run ``program`` in ``cwd``; it must end within ``PROMPT`` seconds (a hang fails).

    ``full_disk``: a folder on which the program sees a 4 KiB tmpfs (``unshare``: a mount
    namespace, and a user namespace when not root, of the program alone).
    """
    env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
    wrap: list[str] = []
    if full_disk is not None:
        wrap = ['unshare', '--mount', '--propagation', 'private',
                *([] if os.geteuid() == 0 else ['--map-root-user']), 'sh', '-c',
                f'mount -t tmpfs -o size=4k pd-full-disk {full_disk} && exec "$@"', 'sh']

    def limits() -> None:  # a full disk, for files past the size: writes fail with EFBIG
        if limit_file_size is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit_file_size, limit_file_size))

    start = time.monotonic()
    completed = subprocess.run([*wrap, *command(program), *args], cwd=cwd, env=env, text=True,
                               capture_output=True, stdin=subprocess.DEVNULL,
                               timeout=PROMPT + 20.0, preexec_fn=limits, check=False)
    seconds = time.monotonic() - start
    return Result(completed.returncode, completed.stdout, completed.stderr, seconds)


def refused(result: Result, program: str, pattern: str, *, code: int = 2) -> str:
    """``result`` is one line ``<program>: error: <pattern>`` on stderr, and nothing else."""
    assert 'Traceback' not in result.stderr, result.stderr
    assert 'Warning' not in result.stderr, result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert re.match(rf'^{program}: error: {pattern}', lines[0]), lines[0]
    assert result.code == code, result
    assert result.stdout == '', result.stdout
    assert result.seconds < PROMPT, result.seconds
    return lines[0]


def default_text(**values: str) -> str:
    """The default test file (its record's path absolute), with ``key: value`` lines replaced
    (the first line of each key)."""
    text = DEFAULT_TEST.read_text(encoding='utf-8').replace(
        'file: ../data/', f'file: {DEFAULT_TEST.parent}/../data/')
    for key, value in values.items():
        text, count = re.subn(rf'^(\s*){key}: .*$', rf'\g<1>{key}: {value}', text, count=1,
                              flags=re.MULTILINE)
        assert count == 1, key
    return text


def write(folder: Path, name: str, text: str) -> str:
    (folder / name).write_text(text, encoding='utf-8')
    return name


def run_test_file(program: str, test_file: str, cwd: Path) -> Result:
    """``program`` on ``test_file``, its outputs in ``cwd/out`` (which must not appear)."""
    result = run(program, test_file, '--out', str(cwd / 'out'), *TEST_FILE_COMMANDS[program],
                 cwd=cwd)
    assert not (cwd / 'out').exists()
    return result


def every_command_and(*cases: str) -> list[tuple[str, str]]:
    """``(program, case)``: the first case through every test-file command, the others
    through ``offline`` (they take the same path: the one loader)."""
    return ([(program, cases[0]) for program in sorted(TEST_FILE_COMMANDS)]
            + [('offline', case) for case in cases[1:]])


# -- 1. YAML nested thousands of levels deep ------------------------------------------------
NESTINGS = {
    'lists': 'a: ' + '[' * 5000 + ']' * 5000,
    'flow-mappings': 'a: ' + '{b: ' * 5000 + '1' + '}' * 5000,
    'block-mappings': ''.join(f'{" " * level}k{level}:\n' for level in range(200))
                      + ' ' * 200 + 'v: 1',
}


@pytest.mark.parametrize(('program', 'nesting'),
                         every_command_and('lists', 'flow-mappings', 'block-mappings'))
def test_yaml_nested_thousands_deep_is_one_line(tmp_path: Path, program: str,
                                                nesting: str) -> None:
    name = write(tmp_path, 'deep.yaml', NESTINGS[nesting] + '\n')
    result = run_test_file(program, name, tmp_path)
    refused(result, program, r'deep\.yaml: line \d+: nesting deeper than 64 levels$')


# -- 2. more steps than memory holds ----------------------------------------------------------
STEPS = {
    'duration': ({'duration': '1e9'}, (r'case\.yaml: test\.duration: 1e\+09 s at dt 0\.01 s is '
                                       r'1e\+11 steps; at most 5e\+07$')),
    'dt': ({'dt': '1e-9'}, (r"case\.yaml: test\.dt: 1e-09 s over the 31\.18 s of the record "
                            r"'elcentro_1940_ns_chopra\.csv' is 3\.118e\+10 steps; at most "
                            r'5e\+07$')),
}


@pytest.mark.parametrize(('program', 'case'), every_command_and('duration', 'dt'))
def test_a_test_of_more_steps_than_memory_holds_is_one_line(tmp_path: Path, program: str,
                                                            case: str) -> None:
    values, message = STEPS[case]
    name = write(tmp_path, 'case.yaml', default_text(**values))
    refused(run_test_file(program, name, tmp_path), program, message)


# -- 3. files that are no files: devices, FIFOs, folders ------------------------------------
@pytest.fixture
def fifo(tmp_path: Path) -> Path:
    path = tmp_path / 'pipe'
    os.mkfifo(path)
    return path


@pytest.mark.parametrize(('program', 'kind'),
                         [*every_command_and('fifo', 'folder'), ('run_test', 'device')])
def test_a_test_file_that_is_no_file_is_refused_before_it_is_read(
        tmp_path: Path, fifo: Path, program: str, kind: str) -> None:
    path = {'device': '/dev/zero', 'fifo': str(fifo), 'folder': str(tmp_path)}[kind]
    what = {'device': 'a character device', 'fifo': 'a FIFO', 'folder': 'a directory'}[kind]
    result = run_test_file(program, path, tmp_path)
    refused(result, program,
            rf'{re.escape(path)}: cannot read the test file \(not a regular file but {what}\)$')


@pytest.mark.parametrize(('program', 'kind'), every_command_and('fifo', 'device'))
def test_a_record_that_is_no_file_is_refused_before_it_is_read(
        tmp_path: Path, fifo: Path, program: str, kind: str) -> None:
    path = {'device': '/dev/zero', 'fifo': str(fifo)}[kind]
    what = {'device': 'a character device', 'fifo': 'a FIFO'}[kind]
    name = write(tmp_path, 'case.yaml', default_text(file=path))
    refused(run_test_file(program, name, tmp_path), program,
            rf"case\.yaml: ground_motion: ground motion '{re.escape(path)}': cannot read file: "
            rf'not a regular file but {what}$')


def test_files_too_large_are_refused_before_they_are_read(tmp_path: Path) -> None:
    with (tmp_path / 'huge.yaml').open('wb') as file:  # sparse: nothing on the disk
        file.truncate(5 * 2**30)
    refused(run_test_file('offline', 'huge.yaml', tmp_path), 'offline',
            r'huge\.yaml: cannot read the test file \(5 GiB, more than the 4 MiB a test file '
            r'may have\)$')
    with (tmp_path / 'huge.csv').open('wb') as file:
        file.truncate(5 * 2**30)
    name = write(tmp_path, 'case.yaml', default_text(file=str(tmp_path / 'huge.csv')))
    refused(run_test_file('pretest', name, tmp_path), 'pretest',
            r"case\.yaml: ground_motion: ground motion '.*huge\.csv': cannot read file: 5 GiB, "
            r'more than the 32 MiB a ground-motion record may have$')


# -- 4. binary and non-UTF-8 test files -------------------------------------------------------
NOT_UTF8 = {
    'binary': (b'\xff\xfe\x00\x01binary\x80\x81',
               r'line 1: not UTF-8 text, byte 0xff at offset 0'),
    'latin-1': ('test: {}\n# caf\xe9\n'.encode('latin-1'),
                r'line 2: not UTF-8 text, byte 0xe9 at offset 14'),
}


@pytest.mark.parametrize(('program', 'case'), every_command_and('binary', 'latin-1'))
def test_a_test_file_that_is_not_utf8_is_one_line_naming_it(tmp_path: Path, program: str,
                                                            case: str) -> None:
    content, where = NOT_UTF8[case]
    (tmp_path / 'case.yaml').write_bytes(content)
    refused(run_test_file(program, 'case.yaml', tmp_path), program,
            rf'case\.yaml: cannot read the test file \({where}\)$')


# -- 5. damaged run folders and journals --------------------------------------------------
_EVENT = 6
#: Damaged journals (by the documented layout) and what the line says after the file's name.
JOURNALS = {
    'garbage': (b'hello, not a journal\n',
                r'not a journal of this version \(no journal header\)'),
    'not-utf8': (journals.HEADER + journals.frame(1, 1, b'', b'\xff\xfe garbage \x80'),
                 r'record 1 at byte 16: malformed def record \(.*can.t decode byte 0xff.*\)'),
    'deep': (journals.HEADER + journals.frame(_EVENT, 1, b'', b'[' * 100_000 + b']' * 100_000),
             r'record 1 at byte 16: malformed ev record \(JSON nested too deep\)'),
    'a-list': (journals.HEADER + journals.frame(_EVENT, 1, b'', b'[1, 2]'),
               r'record 1 at byte 16: malformed ev record \(not an event: .*\)'),
    'no-command': (journals.HEADER + journals.frame(2, 1, b'/pd/step_command',
                                                    b'\x00\x01\x00\x00' + b'\xff' * 12),
                   r'record 1 at byte 16: malformed cmd record \(.+\)'),
    'crc': (journals.HEADER + journals.frame(_EVENT, 1, b'', b'{"what": "x"}')[:-1] + b'y'
            + journals.frame(_EVENT, 2, b'', b'{"what": "y"}'),
            r'record 1 at byte 16: damaged \(CRC mismatch\)'),
}


@pytest.mark.parametrize(('program', 'journal'), [
    *((program, journal) for program in ('console', 'recover', 'replay', 'journal')
      for journal in ('not-utf8', 'deep', 'crc')),
    *(('replay', journal) for journal in ('garbage', 'a-list', 'no-command'))])
def test_a_damaged_journal_is_one_line_naming_the_record(tmp_path: Path, program: str,
                                                         journal: str) -> None:
    content, reason = JOURNALS[journal]
    folder = tmp_path / 'run'
    folder.mkdir()
    (folder / 'journal.pdj').write_bytes(content)
    args = {'console': ['--port', '0'], 'journal': []}.get(program, ['--no-figures'])
    result = run(program, 'run', *args, cwd=tmp_path)
    refused(result, program, rf'run/journal\.pdj: {reason}$')
    assert sorted(p.name for p in folder.iterdir()) == ['journal.pdj']  # no bag, no output


@pytest.mark.parametrize(('program', 'message'), [
    ('replay', r'loop: a symbolic link loop$'),
    ('recover', r'loop: no journal\.pdj: nothing to recover from$'),
    ('console', r'loop: no complete bag and no journal \(journal\.pdj\): not a run folder$'),
], ids=['replay', 'recover', 'console'])
def test_a_run_folder_that_is_a_symbolic_link_loop_is_one_line(tmp_path: Path, program: str,
                                                               message: str) -> None:
    (tmp_path / 'loop').symlink_to('other')
    (tmp_path / 'other').symlink_to('loop')
    args = ['--port', '0'] if program == 'console' else ['--no-figures']
    refused(run(program, 'loop', *args, cwd=tmp_path), program, message)


def test_a_journal_that_is_a_fifo_or_a_device_never_hangs(tmp_path: Path, fifo: Path) -> None:
    for target in (fifo, Path('/dev/zero')):
        folder = tmp_path / f'run-{target.name}'
        folder.mkdir()
        (folder / 'journal.pdj').symlink_to(target)
        refused(run('replay', folder.name, '--no-figures', cwd=tmp_path), 'replay',
                rf'{folder.name}: no complete bag and no journal')


# -- 6. numbers that overflow -----------------------------------------------------------------
def test_an_intensity_that_overflows_is_one_line(tmp_path: Path) -> None:
    result = run('rths_benchmark', '--intensity', '1e308', '--out', str(tmp_path / 'out'),
                 cwd=tmp_path)
    refused(result, 'rths_benchmark', r"--intensity: 1e\+308 takes the record's peak "
                                      r'3\.128 m/s2 to inf m/s2; at most 981 m/s2 \(100 g\)$')
    assert not (tmp_path / 'out').exists()


@pytest.mark.parametrize('program', ['offline', 'pretest'])
def test_a_scale_that_overflows_is_one_line_without_warnings(tmp_path: Path,
                                                             program: str) -> None:
    name = write(tmp_path, 'case.yaml', default_text(scale='1e308'))
    refused(run_test_file(program, name, tmp_path), program,
            r"case\.yaml: ground_motion\.scale: 1e\+308 × the record's peak 3\.128 m/s2 is "
            r'beyond the largest number$')


def test_scales_that_overflow_are_one_line_without_warnings(tmp_path: Path) -> None:
    result = run('pretest', '--scales', '1e308', '--out', str(tmp_path / 'out'),
                 '--no-figures', cwd=tmp_path)
    refused(result, 'pretest', r'--scales: 1e\+308 × the peak 3\.128 m/s2 of '
                               r'elcentro_1940_ns_chopra\.csv is beyond the largest number$')


# -- 7. what was accepted silently: booleans, keys given twice -----------------------------
BOOLEANS = {
    'mass': ({'mass': 'true'}, (r'case\.yaml: structure\.mass: expected a number or an array '
                                r'of numbers, got a boolean \(true\)$')),
    'influence': ({'influence': '[true]'}, (r'case\.yaml: structure\.influence: must be a list '
                                            r'of 1 numbers, got \[True\]$')),
    # (the typed schema's message: its dotted path, pd_common.config.schema)
    'specimen': ({'stiffness': 'true'}, (r'case\.yaml: specimen\.elements\.0\.backbone\.'
                                         r'bilinear\.stiffness: must be a number, got true$')),
}


@pytest.mark.parametrize(('program', 'case'), [('offline', 'mass'), ('run_test', 'mass'),
                                               ('offline', 'influence'),
                                               ('offline', 'specimen')])
def test_a_boolean_where_a_number_belongs_is_refused(tmp_path: Path, program: str,
                                                     case: str) -> None:
    values, message = BOOLEANS[case]
    name = write(tmp_path, 'case.yaml', default_text(**values))
    refused(run_test_file(program, name, tmp_path), program, message)


@pytest.mark.parametrize('program', sorted(TEST_FILE_COMMANDS))
def test_a_key_given_twice_is_refused_with_its_line(tmp_path: Path, program: str) -> None:
    text = default_text().replace('  mass: 2543.4', '  mass: 2543.4\n  mass: 1000.0', 1)
    line = next(number for number, row in enumerate(text.splitlines(), start=1)
                if row.startswith('  mass: 1000.0'))
    name = write(tmp_path, 'case.yaml', text)
    refused(run_test_file(program, name, tmp_path), program,
            rf'case\.yaml: line {line}: structure\.mass: given twice \(first on line '
            rf'{line - 1}\)$')


# -- 8. a folder that cannot be written, a full disk ------------------------------------------
#: A folder no one can make (/proc/self holds no folders of ours), whoever runs the tests.
UNWRITABLE = '/proc/self/pd-run'


def test_offline_into_a_folder_that_cannot_be_made_is_one_line(tmp_path: Path) -> None:
    result = run('offline', '--out', UNWRITABLE, '--quiet', cwd=tmp_path)
    refused(result, 'offline', rf'{UNWRITABLE}: cannot write \(No such file or directory\)$',
            code=1)


def test_run_test_into_a_folder_that_cannot_be_made_says_so_before_anything(
        tmp_path: Path) -> None:
    result = run('run_test', '--out', UNWRITABLE, '--no-authentication', cwd=tmp_path)
    refused(result, 'run_test', rf'--out {UNWRITABLE}: cannot write the run folder '
                                r'\(No such file or directory\)$')  # no 'run folder:' line


def test_offline_on_a_full_disk_is_one_line(tmp_path: Path) -> None:
    # A real full file system: a 4 KiB tmpfs in a mount namespace of the run's own (the run
    # folder is made, its first file, the test definition, does not fit: ENOSPC).
    disk = tmp_path / 'disk'
    disk.mkdir()
    out = disk / 'out'
    result = run('offline', '--out', str(out), '--quiet', cwd=tmp_path, full_disk=disk)
    refused(result, 'offline', rf'{out}: cannot write \(No space left on device\)$', code=1)


def test_offline_whose_journal_cannot_grow_says_how_to_recover(tmp_path: Path) -> None:
    out = tmp_path / 'out'
    result = run('offline', '--out', str(out), '--quiet', '--no-figures', cwd=tmp_path,
                 limit_file_size=100_000)
    refused(result, 'offline', rf'{out}/journal\.pdj: cannot write the journal \(File too '
                               rf'large\); the run stops, .*: once there is room, ./pd recover '
                               rf'{out} rebuilds its outputs$', code=1)
    assert not (out / 'bag').exists()
    # As the line says: the journal on disk is the run up to its last step.
    recovered = run('recover', str(out), '--no-figures', cwd=tmp_path)
    assert recovered.code == 0, recovered.stderr
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['recovered'] and summary['steps'] > 0


def test_recover_of_a_run_that_ended_says_there_is_nothing_to_do(tmp_path: Path) -> None:
    """A finished run's folder is whole: ./pd recover writes nothing (its summary keeps what
    only the live run knew), says so in one line and how to write the outputs elsewhere."""
    out = tmp_path / 'out'
    finished = run('offline', '--out', str(out), '--quiet', '--no-figures', cwd=tmp_path)
    assert finished.code == 0, finished.stderr
    before = {path: path.read_bytes() for path in out.rglob('*') if path.is_file()}
    result = run('recover', str(out), '--no-figures', cwd=tmp_path)
    assert (result.code, result.stderr) == (0, '')
    assert result.stdout == (f'recover: {out}: nothing to recover: the run ended (finished) and '
                             f'wrote its bag and outputs; ./pd replay {out} --out DIR writes '
                             'them again elsewhere\n')
    assert {path: path.read_bytes() for path in out.rglob('*') if path.is_file()} == before


# -- the options of the tools: out of range, or a place that cannot be used -------------------
@pytest.fixture(scope='module')
def finished_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The default test's run folder, run offline to its end (read only by the tests)."""
    where = tmp_path_factory.mktemp('finished')
    finished = run('offline', '--out', str(where / 'out'), '--quiet', '--no-figures', cwd=where)
    assert finished.code == 0, finished.stderr
    return where / 'out'


@pytest.mark.parametrize(('args', 'message'), [
    (['--port', '-1'], r'port: must be 0 \(any free port\) to 65535, got -1'),
    (['--port', '99999'], r'port: must be 0 \(any free port\) to 65535, got 99999'),
    (['--port', '0', '--max-points', '0'],
     r'max_points: must be at least 2 rows per series, got 0'),
    (['--port', '0', '--update-rate', 'nan'],
     r'update_rate: must be a positive number of frames per second, got nan'),
    (['--port', '0', '--foxglove', '70000'],
     r'foxglove_port: must be 1 to 65535 \(0: off\), got 70000'),
    (['--port', '0', '--host', '192.0.2.1'], r'cannot listen on 192\.0\.2\.1:0 \(.+\)'),
], ids=['port-negative', 'port-too-large', 'max-points', 'update-rate', 'foxglove-port',
        'not-this-hosts-address'])
def test_a_console_setting_it_cannot_serve_with_is_one_line(
        tmp_path: Path, finished_run: Path, args: list[str], message: str) -> None:
    refused(run('console', str(finished_run), *args, cwd=tmp_path), 'console', rf'{message}$')


def test_a_console_whose_port_is_taken_is_one_line(tmp_path: Path, finished_run: Path) -> None:
    out = finished_run
    with socket.socket() as taken:
        taken.bind(('127.0.0.1', 0))
        taken.listen()
        port = taken.getsockname()[1]
        refused(run('console', str(out), '--port', str(port), cwd=tmp_path), 'console',
                rf'cannot listen on 127\.0\.0\.1:{port} \(.*address already in use\)$')


@pytest.mark.parametrize('live', [False, True], ids=['finished-run', 'live'])
def test_a_console_file_named_that_cannot_be_used_is_one_line(
        tmp_path: Path, finished_run: Path, live: bool) -> None:
    """A bridge parameter file or a key asked for by name and unusable is refused, not taken
    as none (gauges without limits, a console that cannot steer); only the defaults may be
    missing."""
    run_folder = [] if live else [str(finished_run)]
    refused(run('console', *run_folder, '--port', '0', '--bridge-params',
                str(tmp_path / 'nope.yaml'), cwd=tmp_path), 'console',
            rf'bridge_params: {tmp_path}/nope\.yaml: cannot read the bridge parameter file')
    if live:  # (a finished run's console sends nothing: it reads no key)
        key = tmp_path / 'test.key'
        key.write_text('pd-hmac-sha256 v1 ' + '0123456789abcdef' * 4 + '\n')
        key.chmod(0o644)
        refused(run('console', '--port', '0', '--key', str(key), cwd=tmp_path), 'console',
                rf'key_file: {key}: key file is accessible to group or others')


@pytest.mark.parametrize('into', ['the-run', 'another-run'])
def test_replay_never_writes_over_a_run_folder(tmp_path: Path, finished_run: Path,
                                               into: str) -> None:
    """A replay's outputs into a run's own folder would replace its summary (what only the
    live run knew) and response: refused, nothing written."""
    run_copy = tmp_path / 'run'
    shutil.copytree(finished_run, run_copy)
    target = run_copy if into == 'the-run' else tmp_path / 'other'
    if into == 'another-run':
        shutil.copytree(finished_run, target)
    before = {path: path.read_bytes() for path in target.rglob('*') if path.is_file()}
    refused(run('replay', str(run_copy), '--out', str(target), '--no-figures', cwd=tmp_path),
            'replay', rf'{target}: a run folder \(journal\.pdj in it\): its outputs are not '
                      r'replaced; --out a new folder')
    assert {path: path.read_bytes() for path in target.rglob('*') if path.is_file()} == before
    again = run('replay', str(run_copy), '--no-figures', cwd=tmp_path)  # its own replay/: fine
    assert again.code == 0 and (run_copy / 'replay' / 'response.csv').is_file(), again.stderr


@pytest.mark.parametrize('content', ['', '{}\n', '# nothing yet\n'])
def test_a_bridge_parameter_file_that_sets_nothing_is_refused_before_anything(
        tmp_path: Path, content: str) -> None:
    """An empty parameter file passes ROS and the schema, and the bridge would start with no
    configuration: no test, a 30 s wait for a specimen side, a run folder left."""
    params = tmp_path / 'bridge.yaml'
    params.write_text(content)
    out = tmp_path / 'out'
    refused(run('run_test', str(DEFAULT_TEST), '--bridge-params', str(params), '--out',
                str(out), '--no-figures', cwd=tmp_path), 'run_test',
            rf'{params}: no bridge parameters in it \(an empty file\?\); start from .*'
            r'bridge\.yaml$')
    assert not out.exists()


def test_a_rig_file_that_is_not_yaml_is_one_line(tmp_path: Path) -> None:
    rig = tmp_path / 'rig.yaml'
    rig.write_text('test: [unclosed\n  id: x: y\n')
    refused(run('run_test', str(DEFAULT_TEST), '--rig', str(rig), '--out', str(tmp_path / 'o'),
                cwd=tmp_path), 'run_test',
            rf"{rig}: cannot read the rig file \(line 2: expected ',' or '\]', but got ':'\)$")


@pytest.mark.parametrize('program', ['replay', 'console'])
def test_a_bag_whose_metadata_is_not_yaml_is_one_line(tmp_path: Path, finished_run: Path,
                                                      program: str) -> None:
    bag = tmp_path / 'bag'
    shutil.copytree(finished_run / 'bag', bag)
    (bag / 'metadata.yaml').write_text('[\n')
    args = ['--port', '0'] if program == 'console' else ['--out', str(tmp_path / 'o')]
    refused(run(program, str(bag), *args, cwd=tmp_path), program,
            rf'.*{bag}: cannot read the bag \(.*metadata\.yaml.*\)$')


@pytest.mark.parametrize(('program', 'args', 'message'), [
    ('pretest', [str(DEFAULT_TEST), '--scales', '0.01:1000:1e-6'],
     r"--scales: 999,990,001 values from '0\.01:1000:1e-6'; at most 10,000$"),
    ('pretest', [str(DEFAULT_TEST), '--vary', 'structure.mass=1:2:100000000'],
     r"--vary: 100,000,000 values from 'structure\.mass=1:2:100000000'; at most 10,000$"),
    ('pretest', [str(DEFAULT_TEST), '--scales', '0.1:10:0.01', '--vary',
                 'structure.mass=1:2:2000'],
     (r'default_test\.yaml: 1,982,000 analyses \(1 record\(s\) × 991 scale\(s\) × the '
      r'--vary values\); at most 100,000$')),
    ('analyze', ['--points', '1000000000'],
     r'--points: at most 100,000 values of Ω, got 1,000,000,000$'),
    ('rths_benchmark', ['--perturbed', '100000000'],
     r'--perturbed: must be 0 to 10,000 plants, got 100,000,000$'),
], ids=['scales', 'vary', 'product', 'points', 'perturbed'])
def test_a_count_no_survey_needs_is_one_line_at_once(tmp_path: Path, program: str,
                                                     args: list[str], message: str) -> None:
    """A typo's extra zeros would allocate and compute for hours: refused before anything."""
    out = tmp_path / 'out'
    refused(run(program, *args, '--out', str(out), '--no-figures', cwd=tmp_path), program,
            message)
    assert not out.exists()


@pytest.mark.parametrize('what', ['folder', 'fifo'])
def test_a_benchmark_record_that_is_no_file_says_so(tmp_path: Path, fifo: Path,
                                                    what: str) -> None:
    record = tmp_path if what == 'folder' else fifo
    refused(run('rths_benchmark', '--record', str(record), '--out', str(tmp_path / 'o'),
                cwd=tmp_path), 'rths_benchmark', rf'--record {record}: not a regular file$')


def test_recover_of_a_journal_without_a_run_leaves_no_bag(tmp_path: Path) -> None:
    folder = tmp_path / 'run'
    folder.mkdir()
    (folder / 'journal.pdj').write_bytes(b'')
    refused(run('recover', str(folder), '--no-figures', cwd=tmp_path), 'recover',
            r'.*journal\.pdj: no /pd/test_definition record')
    assert sorted(path.name for path in folder.iterdir()) == ['journal.pdj']


def test_keygen_never_replaces_what_is_not_a_key_file(tmp_path: Path, fifo: Path) -> None:
    for target in (fifo, Path('/dev/null')):
        refused(run('keygen', '--out', str(target), '--force', cwd=tmp_path), 'keygen',
                rf'{target}: not a regular file; a key file is replaced only by a key file$')


@pytest.mark.parametrize('where', ['a-file', 'under-a-file'])
def test_study_ch5_into_a_folder_that_cannot_be_made_is_one_line(tmp_path: Path,
                                                                 where: str) -> None:
    (tmp_path / 'a-file').write_text('mine\n')
    target = tmp_path / 'a-file' if where == 'a-file' else tmp_path / 'a-file' / 'sub'
    reason = 'File exists' if where == 'a-file' else 'Not a directory'
    refused(run('study_ch5', '--duration', '1', '--out', str(target), cwd=tmp_path),
            'study_ch5', rf'{target}: cannot make the output folder \({reason}\)$')
    assert (tmp_path / 'a-file').read_text() == 'mine\n'


def test_a_journal_tail_beyond_any_journal_prints_all_of_it(tmp_path: Path,
                                                            finished_run: Path) -> None:
    out = finished_run
    every = run('journal', str(out), cwd=tmp_path)
    huge = run('journal', str(out), '--tail', '9' * 30, cwd=tmp_path)
    assert (huge.code, huge.stderr) == (0, '')
    assert huge.stdout == every.stdout and every.stdout.count('\n') > 100


def test_a_journal_with_no_records_says_so(tmp_path: Path) -> None:
    """An empty file (a run killed as it made its journal) is a journal of no records: said
    on stderr, not an empty silence."""
    journal = tmp_path / 'journal.pdj'
    journal.write_bytes(b'')
    result = run('journal', str(journal), cwd=tmp_path)
    assert (result.code, result.stdout) == (0, '')
    assert result.stderr == f'journal: {journal}: no records\n'


@pytest.mark.parametrize('where', ['a-file', 'under-a-file'])
def test_schema_written_where_it_cannot_be_is_one_line(tmp_path: Path, where: str) -> None:
    (tmp_path / 'a-file').write_text('mine\n')
    target = tmp_path / 'a-file' if where == 'a-file' else tmp_path / 'a-file' / 'sub'
    reason = 'File exists' if where == 'a-file' else 'Not a directory'
    refused(run('schema', '--write', str(target), cwd=tmp_path), 'schema',
            rf'{target}: cannot write \({reason}\)$')
    assert (tmp_path / 'a-file').read_text() == 'mine\n'  # nothing lost


@pytest.mark.parametrize('timeout', ['inf', 'nan', '0', '-1'])
def test_a_control_timeout_that_is_no_time_is_one_line(tmp_path: Path, timeout: str) -> None:
    refused(run('control', 'pause', '--timeout', timeout, cwd=tmp_path), 'control',
            rf'--timeout: must be a positive number of seconds, got {timeout}$')


@pytest.mark.parametrize(('param', 'message'), [
    ('dt:=', r"--param 'dt:=': no value after := \(e\.g\. dt:=0\.5\)"),
    ('dt:=  ', r"--param 'dt:=  ': no value after :="),
    (':=1', r"--param ':=1': expected NAME:=VALUE"),
    ('d t:=1', r"--param 'd t:=1': expected NAME:=VALUE"),
    ('sync_interval:=-1',
     r"parameter sync_interval: must be a number of seconds, 0 or more \(.*\); got -1$"),
    ('sync_interval:=abc',
     r"parameter sync_interval: must be a number of seconds, 0 or more \(.*\); got 'abc'$"),
    ('sync_interval:=.inf', r"parameter sync_interval: .*; got inf$"),
    ('sync_interval:=true', r"parameter sync_interval: .*; got True$"),
    ('sync_interval:=1' + '0' * 400, r"parameter sync_interval: .*; got 1000000000+\.\.\.$"),
    ('progress_interval:=0',
     r"parameter progress_interval: must be a number of seconds, more than 0 \(.*\); got 0$"),
    ('confirm_resume:=true',
     (r"--param confirm_resume: not a parameter \./pd run takes \(the test's: test_id, .*; "
      r"the integrator's: sync_interval, progress_interval\)$")),
], ids=['empty', 'blank', 'no-name', 'space-in-name', 'sync-negative', 'sync-text', 'sync-inf',
        'sync-boolean', 'sync-huge', 'progress-zero', 'not-a-test-parameter'])
@pytest.mark.parametrize('program', ['run_test', 'offline'])
def test_an_override_ros_cannot_parse_is_refused_before_anything(
        tmp_path: Path, program: str, param: str, message: str) -> None:
    """The integrator's ROS arguments would fail to parse in the child (a traceback, a run
    folder left): run_test refuses the override first, and nothing is made; so does
    ./pd offline, which takes the test's parameters as run_test does (and no other)."""
    if program == 'offline' and param.partition(':=')[0] in ('sync_interval',
                                                              'progress_interval',
                                                              'confirm_resume'):
        message = (rf"DEFAULT:.*parameter '{param.partition(':=')[0]}' is not a test "
                   r"parameter \(one of test_id, .*\)$")
    message = message.replace('DEFAULT:', re.escape(f'{DEFAULT_TEST.name}: '))
    out = tmp_path / 'out'
    refused(run(program, str(DEFAULT_TEST), '-p', param, '--out', str(out), '--no-figures',
                cwd=tmp_path), program, rf'{message}.*$')
    assert not out.exists()


# -- 9. a run folder whose launch plan is no file -------------------------------------------
def test_resume_of_a_folder_whose_launch_plan_is_a_fifo_never_hangs(tmp_path: Path) -> None:
    folder = tmp_path / 'run'
    folder.mkdir()
    os.mkfifo(folder / 'launch.json')
    refused(run('run_test', '--resume', 'run', cwd=tmp_path), 'run_test',
            r'run/launch\.json: unreadable launch plan \(not a regular file but a FIFO\)$')
