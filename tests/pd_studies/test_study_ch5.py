"""The thesis's chapter 5 study (``study_ch5``): runs, figures, table, errors.

One study run (module fixture, 3 s of each record) on the shipped El Centro record and on a
synthetic PEER ``.AT2`` file (a 1.5 Hz, 0.3 g sine burst written here; no PEER file is in the
repository), given once as ``northridge=PATH`` and once as a bare path.

Measured when written (3 s, dt = 0.01 s, ω·Δt = 0.1109): the peak displacements of Newmark
explicit and the linear acceleration method differ by 0.26 % (El Centro) and 0.018 % (sine
burst); over the whole El Centro record by 0.28 %. The test asserts < 1 %.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from pd_studies import study_ch5, study_ch5_figures, study_ch5_records

DURATION = '3'
SCHEMES = ('newmark_explicit', 'linear_acceleration')
FIGURES = ('displacement.png', 'velocity.png', 'acceleration.png', 'force_deformation.png')
PEAK_DISPLACEMENT_BOUND = 0.01  # relative difference of the two schemes' peak displacements


def write_at2(path: Path, *, npts: int = 800, dt: float = 0.005, declared: int | None = None,
              amplitude_g: float = 0.3, frequency: float = 1.5, burst: float = 2.0) -> Path:
    """A PEER-style ``.AT2`` file: 4 header lines, then 5 values (g) per line."""
    values = [amplitude_g * math.sin(2.0 * math.pi * frequency * i * dt)
              if i * dt < burst else 0.0 for i in range(npts)]
    lines = ['PEER NGA STRONG MOTION DATABASE RECORD',
             'SYNTHETIC SINE BURST 1.5 HZ 0.30 G, TEST ONLY',
             'ACCELERATION TIME SERIES IN UNITS OF G',
             f'NPTS= {declared if declared is not None else npts:5d}, DT= {dt:9.4f} SEC']
    lines += [''.join(f'{value:15.7E}' for value in values[i:i + 5])
              for i in range(0, npts, 5)]
    path.write_text('\n'.join(lines) + '\n', encoding='ascii')
    return path


@pytest.fixture(scope='module')
def study(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int, str]:
    """Run the study once: El Centro, the sine burst as northridge=PATH and as a bare PATH."""
    root = tmp_path_factory.mktemp('study_ch5')
    record = write_at2(root / 'SINE_BURST.AT2')
    out = root / 'out'
    code = study_ch5.main(['--records', 'elcentro', f'northridge={record}', str(record),
                           '--duration', DURATION, '--out', str(out), '--no-run-figures',
                           '--quiet'])
    return out, code, str(record)


def read_table(out: Path) -> list[dict[str, str]]:
    with (out / study_ch5.TABLE_CSV).open(encoding='utf-8') as stream:
        return list(csv.DictReader(stream))


def test_runs_figures_and_tables_exist(study: tuple[Path, int, str]) -> None:
    out, code, _ = study
    assert code == 0
    for label in ('elcentro', 'northridge', 'SINE_BURST'):
        for figure in FIGURES:
            path = out / label / figure
            assert path.is_file(), path
            assert path.stat().st_size > 10_000  # a real plot, not an empty canvas
        for scheme in SCHEMES:
            summary = json.loads((out / label / scheme / 'summary.json').read_text())
            assert summary['state'] == 'finished'
            assert summary['scheme'] == scheme
            assert summary['steps'] == 300
            assert (out / label / scheme / 'bag').is_dir()
    assert (out / study_ch5.TABLE_CSV).is_file()
    markdown = (out / study_ch5.TABLE_MD).read_text(encoding='utf-8')
    assert '| elcentro | displacement | newmark_explicit |' in markdown
    assert 'ω·Δt' in markdown
    manifest = json.loads((out / study_ch5.STUDY_JSON).read_text(encoding='utf-8'))
    assert [item['label'] for item in manifest['records']] == ['elcentro', 'northridge',
                                                               'SINE_BURST']


def test_table_peaks_equal_the_run_summaries(study: tuple[Path, int, str]) -> None:
    out, _, _ = study
    rows = read_table(out)
    assert len(rows) == 3 * len(study_ch5_figures.QUANTITIES)
    for row in rows:
        reference = json.loads((out / row['record'] / row['reference_scheme']
                                / 'summary.json').read_text())
        other = json.loads((out / row['record'] / row['scheme'] / 'summary.json').read_text())
        ref_peak = reference['dofs'][row['dof']]['peaks'][row['quantity']]
        peak = other['dofs'][row['dof']]['peaks'][row['quantity']]
        assert float(row['reference_peak']) == ref_peak['abs']
        assert float(row['peak']) == peak['abs']
        assert float(row['time']) == peak['time']
        assert float(row['difference']) == peak['abs'] - ref_peak['abs']
        assert float(row['relative_difference']) == pytest.approx(
            (peak['abs'] - ref_peak['abs']) / ref_peak['abs'], rel=1e-12)
        assert float(row['omega_dt']) == reference['omega_max_dt']
        assert float(row['omega_dt']) == pytest.approx(math.sqrt(312559.0 / 2543.4) * 0.01)


def test_schemes_agree_for_small_omega_dt(study: tuple[Path, int, str]) -> None:
    out, _, _ = study
    displacement = [row for row in read_table(out) if row['quantity'] == 'displacement']
    assert len(displacement) == 3
    for row in displacement:
        assert float(row['omega_dt']) < 0.12
        assert float(row['reference_peak']) > 0.03  # the column yields (d_y = 32 mm)
        assert abs(float(row['relative_difference'])) < PEAK_DISPLACEMENT_BOUND, row


def test_bare_path_matching_a_record_name_uses_its_test_file(tmp_path: Path) -> None:
    kobe = write_at2(tmp_path / 'RSN1106_KOBE_KJM000.AT2')
    other = write_at2(tmp_path / 'my record.AT2')
    study = study_ch5_records.load_study(study_ch5_records.default_study_directory())
    resolved = study_ch5_records.resolve_records(study, [str(kobe), str(other), 'elcentro'])
    assert [(label, spec.name) for label, spec, _ in resolved] == [
        ('kobe', 'kobe'), ('my_record', 'elcentro'), ('elcentro', 'elcentro')]


def _error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    assert study_ch5.main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith('study_ch5: error: ')
    return lines[0]


def test_missing_record_file_exits_2_naming_it(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / 'NORTHRIDGE_MISSING.AT2'
    line = _error(capsys, ['--records', str(missing), '--out', str(tmp_path / 'out')])
    assert 'NORTHRIDGE_MISSING.AT2' in line
    assert 'not found' in line
    line = _error(capsys, ['--records', f'kobe={missing}', '--out', str(tmp_path / 'out')])
    assert 'NORTHRIDGE_MISSING.AT2' in line
    assert not (tmp_path / 'out').exists()  # nothing ran


def test_placeholder_record_exits_2_and_says_how(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    line = _error(capsys, ['--records', 'northridge', '--out', str(tmp_path / 'out')])
    assert 'NORTHRIDGE.AT2' in line
    assert '--records northridge=' in line


def test_invalid_record_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = write_at2(tmp_path / 'BAD_COUNT.AT2', declared=900)
    line = _error(capsys, ['--records', str(bad), '--out', str(tmp_path / 'out')])
    assert 'BAD_COUNT.AT2' in line
    assert 'NPTS' in line
    wrong_units = write_at2(tmp_path / 'CM_S2.AT2', amplitude_g=300.0)
    line = _error(capsys, ['--records', str(wrong_units), '--out', str(tmp_path / 'out')])
    assert 'CM_S2.AT2' in line
    assert 'implausible' in line


def test_bad_schemes_and_unknown_record_exit_2(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    assert 'unknown scheme' in _error(capsys, ['--schemes', 'newmark_explicit,nope'])
    assert 'at least two' in _error(capsys, ['--schemes', 'newmark_explicit'])
    assert 'no study record' in _error(capsys, ['--records', 'loma_prieta'])


def test_output_folder_with_runs_is_refused(study: tuple[Path, int, str],
                                            capsys: pytest.CaptureFixture[str]) -> None:
    out, _, _ = study
    line = _error(capsys, ['--records', 'elcentro', '--duration', DURATION, '--out', str(out)])
    assert 'already holds a run' in line
