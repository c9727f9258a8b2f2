"""Tests of pd_specimen_sim.core.backbone: the curve, its validation and its loaders."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pd_common.specimen import (
    Backbone,
    BackboneError,
    HysteresisError,
    bilinear_backbone,
    load_backbone_csv,
    load_opensees_pushover,
)


@pytest.fixture
def curve() -> Backbone:
    # Segments: slope 1e5 N/m up to 0.01 m, then 500 N / 0.02 m = 2.5e4 N/m.
    return Backbone(np.array([0.0, 0.01, 0.03]), np.array([0.0, 1000.0, 1500.0]), source='c')


def test_interpolation_inside_the_curve(curve: Backbone) -> None:
    assert curve.force_at(0.0) == 0.0
    assert curve.force_at(0.005) == pytest.approx(500.0)
    assert curve.force_at(0.01) == pytest.approx(1000.0)
    assert curve.force_at(0.02) == pytest.approx(1250.0)
    assert curve.force_at(0.03) == pytest.approx(1500.0)
    assert curve.initial_stiffness == pytest.approx(1.0e5)
    assert curve.last_displacement == 0.03


def test_beyond_modes(curve: Backbone) -> None:
    # Last slope 2.5e4 N/m continued by 0.02 m: 1500 + 500.
    assert curve.force_at(0.05) == pytest.approx(2000.0)
    assert curve.force_at(0.05, 'extrapolate') == pytest.approx(2000.0)
    assert curve.force_at(0.05, 'plateau') == pytest.approx(1500.0)
    with pytest.raises(HysteresisError, match=r'0\.05 m is beyond the last backbone point 0\.03'):
        curve.force_at(0.05, 'error')
    assert curve.force_at(0.03, 'error') == pytest.approx(1500.0)
    with pytest.raises(BackboneError, match='beyond must be one of'):
        curve.force_at(0.05, 'clamp')


def test_negative_or_nan_displacement_is_rejected(curve: Backbone) -> None:
    with pytest.raises(HysteresisError, match='>= 0'):
        curve.force_at(-0.001)
    with pytest.raises(HysteresisError):
        curve.force_at(float('nan'))


def test_arrays_are_read_only_copies() -> None:
    d = np.array([0.0, 1.0])
    curve = Backbone(d, np.array([0.0, 2.0]))
    d[1] = 5.0
    assert curve.force_at(1.0) == 2.0
    with pytest.raises(ValueError):
        curve.displacement[1] = 3.0


@pytest.mark.parametrize(('d', 'f', 'message'), [
    ([0.0, 0.01, 0.01], [0.0, 1.0, 2.0], r'point 2: displacement 0\.01 m is not greater'),
    ([0.0, 0.02, 0.01], [0.0, 1.0, 2.0], 'point 2'),
    ([0.0, 0.01, 0.02], [0.0, float('nan'), 2.0], 'point 1: force is not finite'),
    ([0.0, float('inf')], [0.0, 1.0], 'point 1: displacement is not finite'),
    ([0.001, 0.01], [0.0, 1.0], r'point 0 must be \(0, 0\)'),
    ([0.0, 0.01], [5.0, 1.0], r'point 0 must be \(0, 0\)'),
    ([0.0], [0.0], 'at least 2 points'),
    ([0.0, 1.0, 2.0], [0.0, 1.0], 'equal length'),
])
def test_backbone_validation(d: list[float], f: list[float], message: str) -> None:
    with pytest.raises(BackboneError, match=message):
        Backbone(np.array(d), np.array(f), source='curve.csv')


def test_bilinear_backbone_points() -> None:
    bb = bilinear_backbone(1.0e5, 2.0e3, 0.05, 0.1)
    # d_y = 0.02 m; last force 2000 + 0.05 * 1e5 * (0.1 - 0.02) = 2400 N.
    np.testing.assert_allclose(bb.displacement, [0.0, 0.02, 0.1])
    np.testing.assert_allclose(bb.force, [0.0, 2000.0, 2400.0])
    assert bilinear_backbone(1.0e5, 2.0e3).displacement[-1] == pytest.approx(2.0)


@pytest.mark.parametrize(('args', 'message'), [
    ((-1.0e5, 2.0e3), 'stiffness must be a positive finite number'),
    ((1.0e5, float('nan')), 'yield_force must be a positive finite number'),
    ((1.0e5, 2.0e3, 1.0), r'hardening_ratio must be in \(-1, 1\)'),
    ((1.0e5, 2.0e3, -1.0), 'hardening_ratio'),
    ((1.0e5, 2.0e3, 0.01, None, 100.0), 'residual_force needs a negative hardening_ratio'),
    ((1.0e5, 2.0e3, -0.1, None, 2500.0), r'residual_force must be in \[0, yield_force=2000\]'),
    ((1.0e5, 2.0e3, 0.0, 0.01), 'must exceed the yield displacement'),
])
def test_bilinear_backbone_validation(args: tuple[float, ...], message: str) -> None:
    with pytest.raises(BackboneError, match=message):
        bilinear_backbone(*args)


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding='utf-8')
    return path


def test_csv_with_header_comments_and_commas(tmp_path: Path) -> None:
    path = _write(tmp_path / 'curve.csv',
                  '# pushover of column C1\n'
                  'displacement_m, force_N\n'
                  '\n'
                  '0.0, 0.0\n'
                  '0.01, 1000.0  # yield\n'
                  '0.03,1500\n')
    bb = load_backbone_csv(path)
    np.testing.assert_allclose(bb.displacement, [0.0, 0.01, 0.03])
    np.testing.assert_allclose(bb.force, [0.0, 1000.0, 1500.0])
    assert bb.source == str(path)


def test_csv_whitespace_and_origin_prepended(tmp_path: Path) -> None:
    path = _write(tmp_path / 'curve.txt', '0.01 1000\n0.03\t1500\n')
    bb = load_backbone_csv(path)
    np.testing.assert_allclose(bb.displacement, [0.0, 0.01, 0.03])
    np.testing.assert_allclose(bb.force, [0.0, 1000.0, 1500.0])


@pytest.mark.parametrize(('text', 'message'), [
    ('# only a comment\n\n', 'no data rows'),
    ('', 'no data rows'),
    ('d,f\n0.01,1000\n0.02,abc\n', "line 3: 'abc' is not a number"),
    ('0.01,1000\nd,f\n', "line 2: 'd' is not a number"),
    ('0.01,1000\n0.02,1100,5\n', 'line 2: expected 2 columns'),
    ('0.01,1000\n0.02\n', 'line 2: expected 2 columns'),
    ('0.01,1000\n0.02,1100\n0.015,1200\n', r'line 3: displacement 0\.015 m is not greater'),
    ('0.0,5.0\n0.01,1000\n', r'line 1: first point \(0, 5\) must be \(0, 0\)'),
    ('-0.01,-5.0\n0.01,1000\n', 'line 1: first point'),
    ('0.01,nan\n', 'line 1: values must be finite'),
])
def test_csv_errors_name_file_and_line(tmp_path: Path, text: str, message: str) -> None:
    path = _write(tmp_path / 'bad.csv', text)
    with pytest.raises(BackboneError, match=message) as info:
        load_backbone_csv(path)
    assert 'bad.csv' in str(info.value)


def test_csv_missing_file(tmp_path: Path) -> None:
    with pytest.raises(BackboneError, match=r'missing.csv.*cannot read file'):
        load_backbone_csv(tmp_path / 'missing.csv')


def _recorders(tmp_path: Path, n_gravity: int = 10, reaction_rows: int | None = None
               ) -> tuple[Path, Path]:
    """Write DFree.txt/RBase.txt: gravity rows, then a push to 0.03 m (reaction = -k d)."""
    disp_rows, react_rows = [], []
    for i in range(n_gravity):
        t = 0.1 * (i + 1)
        disp_rows.append(f'{t:.1f} {-1e-6 * (i + 1):.3e} 0.0')
        react_rows.append(f'{t:.1f} {500.0 * (i + 1):.1f} 7.0')
    for i, (d, r) in enumerate([(0.01, -50000.0), (0.02, -90000.0), (0.03, -100000.0)]):
        t = 1.0 + 0.1 * (i + 1)
        disp_rows.append(f'{t:.1f} {d} 0.0')
        react_rows.append(f'{t:.1f} {r} 7.0')
    if reaction_rows is not None:
        react_rows = react_rows[:reaction_rows]
    return (_write(tmp_path / 'DFree.txt', '\n'.join(disp_rows) + '\n'),
            _write(tmp_path / 'RBase.txt', '\n'.join(react_rows) + '\n'))


def test_opensees_pair_like_appendix_a(tmp_path: Path) -> None:
    disp, react = _recorders(tmp_path)
    bb = load_opensees_pushover(disp, react, force_scale=1.0 / 50.0)
    # D = [0; 0.01; 0.02; 0.03], R = [0; 50000; 90000; 100000] / 50.
    np.testing.assert_allclose(bb.displacement, [0.0, 0.01, 0.02, 0.03])
    np.testing.assert_allclose(bb.force, [0.0, 1000.0, 1800.0, 2000.0])
    assert bb.initial_stiffness == pytest.approx(1.0e5)


def test_opensees_sign_and_skip_rows(tmp_path: Path) -> None:
    disp, react = _recorders(tmp_path, n_gravity=3)
    bb = load_opensees_pushover(disp, react, skip_rows=3, force_sign=1.0, force_scale=2.0)
    np.testing.assert_allclose(bb.force, [0.0, -100000.0, -180000.0, -200000.0])


def test_opensees_origin_not_duplicated(tmp_path: Path) -> None:
    disp = _write(tmp_path / 'd.txt', '0.0 5.0\n1.0 0.0\n2.0 0.01\n')
    react = _write(tmp_path / 'r.txt', '0.0 3.0\n1.0 0.0\n2.0 -100.0\n')
    bb = load_opensees_pushover(disp, react, skip_rows=1)
    np.testing.assert_allclose(bb.displacement, [0.0, 0.01])
    np.testing.assert_allclose(bb.force, [0.0, 100.0])


def test_opensees_row_count_mismatch_names_both_files(tmp_path: Path) -> None:
    disp, react = _recorders(tmp_path, reaction_rows=12)
    with pytest.raises(BackboneError, match=r"DFree\.txt' has 13 rows but .*RBase\.txt' has 12"):
        load_opensees_pushover(disp, react)


def test_opensees_not_enough_rows(tmp_path: Path) -> None:
    disp, react = _recorders(tmp_path, n_gravity=10)
    with pytest.raises(BackboneError, match='none left after skipping 13'):
        load_opensees_pushover(disp, react, skip_rows=13)


def test_opensees_non_numeric_and_column(tmp_path: Path) -> None:
    disp = _write(tmp_path / 'd.txt', '0.0 0.0\n1.0 x\n')
    react = _write(tmp_path / 'r.txt', '0.0 0.0\n1.0 -5.0\n')
    with pytest.raises(BackboneError, match=r"d\.txt': line 2: 'x' is not a number"):
        load_opensees_pushover(disp, react, skip_rows=0)
    disp = _write(tmp_path / 'd2.txt', '0.0 0.0\n1.0 0.1\n')
    with pytest.raises(BackboneError, match=r'line 1: has 2 columns, column 2'):
        load_opensees_pushover(disp, react, skip_rows=0, column=2)


def test_opensees_displacement_must_increase(tmp_path: Path) -> None:
    disp = _write(tmp_path / 'd.txt', '0.5 0\n1 0.02\n2 0.01\n')
    react = _write(tmp_path / 'r.txt', '0.5 0\n1 -5.0\n2 -6.0\n')
    with pytest.raises(BackboneError, match=r'line 3: displacement 0\.01 m is not greater'):
        load_opensees_pushover(disp, react, skip_rows=1)
