"""Tests of pd_core.dynamics.ground_motion: the record, its transforms, the readers."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from pd_core.dynamics.ground_motion import G_STANDARD, GroundMotion
from pd_core.dynamics.record_readers import (
    read_at2,
    read_ground_motion,
    read_multi_column,
    read_single_column,
    read_two_column,
)
from pd_core.errors import GroundMotionError, PdIntegratorError
from support.paths import REPO

ELCENTRO_NAME = 'elcentro_1940_ns_chopra.csv'
ELCENTRO_CANDIDATES = (
    REPO / 'data' / 'ground_motions' / ELCENTRO_NAME,
    REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / ELCENTRO_NAME,
)

G = 9.81


def write(tmp_path: Path, name: str, text: str) -> Path:
    """Write ``text`` to ``tmp_path / name`` and return the path."""
    path = tmp_path / name
    path.write_text(text)
    return path


def at2_text(line4: str, body: str) -> str:
    """A synthetic PEER NGA AT2 file with the given line 4 and data body."""
    return (
        'PEER NGA STRONG MOTION DATABASE RECORD\n'
        'SYNTHETIC TEST RECORD, COMPONENT 000\n'
        'ACCELERATION TIME SERIES IN UNITS OF G\n'
        f'{line4}\n'
        f'{body}'
    )


def midpoint_scheme(a: np.ndarray) -> np.ndarray:
    """Halve the time step as the thesis's MATLAB does: samples at even, averages at odd."""
    out = np.empty(2 * a.size - 1)
    for i in range(a.size - 1):
        out[2 * i] = a[i]
        out[2 * i + 1] = (a[i] + a[i + 1]) * 0.5
    out[-1] = a[-1]
    return out


# ---------------------------------------------------------------------- GroundMotion


def test_ground_motion_properties():
    motion = GroundMotion(0.02, [0.0, 1.0, -3.0, 2.0], 'inline')
    assert motion.n_samples == 4
    assert motion.duration == pytest.approx(0.06, abs=1e-15)
    np.testing.assert_allclose(motion.time, [0.0, 0.02, 0.04, 0.06], rtol=0, atol=1e-15)
    assert motion.pga == 3.0
    assert motion.source == 'inline'
    assert motion.acceleration.dtype == np.float64


def test_ground_motion_default_source_is_inline():
    assert GroundMotion(0.1, [0.0, 1.0]).source == 'inline'


def test_acceleration_is_a_read_only_copy():
    raw = np.array([0.0, 1.0, 2.0])
    motion = GroundMotion(0.01, raw, 'inline')
    raw[1] = 99.0
    assert motion.acceleration[1] == 1.0
    with pytest.raises(ValueError):
        motion.acceleration[0] = 5.0
    with pytest.raises(AttributeError):
        motion.dt = 0.5  # type: ignore[misc]


@pytest.mark.parametrize('dt', [0.0, -0.01, math.inf, math.nan])
def test_ground_motion_rejects_bad_dt(dt):
    with pytest.raises(GroundMotionError, match=r"'rec\.txt'.*dt"):
        GroundMotion(dt, [0.0, 1.0], 'rec.txt')


def test_ground_motion_rejects_too_few_samples():
    with pytest.raises(GroundMotionError, match='at least 2 samples'):
        GroundMotion(0.01, [1.0], 'inline')


def test_ground_motion_rejects_2d():
    with pytest.raises(GroundMotionError, match='1-D'):
        GroundMotion(0.01, np.zeros((3, 2)), 'inline')


def test_ground_motion_names_source_and_first_bad_index():
    with pytest.raises(GroundMotionError, match=r"'quake\.csv'.*index 2\b"):
        GroundMotion(0.01, [0.0, 1.0, math.nan, math.inf], 'quake.csv')


def test_errors_hierarchy():
    assert issubclass(GroundMotionError, PdIntegratorError)
    assert issubclass(GroundMotionError, ValueError)


def test_scaled():
    motion = GroundMotion(0.01, [0.0, 1.0, -2.0], 'a.txt')
    scaled = motion.scaled(-1.5)
    np.testing.assert_array_equal(scaled.acceleration, [0.0, -1.5, 3.0])
    assert scaled.dt == 0.01 and scaled.source == 'a.txt'
    np.testing.assert_array_equal(motion.acceleration, [0.0, 1.0, -2.0])
    with pytest.raises(GroundMotionError, match='finite'):
        motion.scaled(math.nan)


# ---------------------------------------------------------------------- resampling


def test_resample_same_dt_is_identical_copy():
    motion = GroundMotion(0.02, np.random.default_rng(1).normal(size=50), 'r.csv')
    copy = motion.resampled(0.02)
    assert copy == motion
    assert copy.dt == motion.dt
    assert copy.acceleration.tobytes() == motion.acceleration.tobytes()
    assert copy.acceleration is not motion.acceleration


def test_resample_halving_matches_matlab_midpoints_bit_for_bit():
    acc = np.random.default_rng(7).normal(scale=3.0, size=1001)
    motion = GroundMotion(0.02, acc, 'r.csv')
    fine = motion.resampled(0.01)
    assert fine.dt == 0.01
    assert fine.n_samples == 2 * acc.size - 1
    expected = midpoint_scheme(acc)
    assert fine.acceleration.tobytes() == expected.tobytes()
    # Same thing written vectorised, independently of the loop above.
    assert np.array_equal(fine.acceleration[0::2], acc)
    assert np.array_equal(fine.acceleration[1::2], (acc[:-1] + acc[1:]) * 0.5)


def test_resample_elcentro_halving_matches_matlab_midpoints():
    motion = read_ground_motion(elcentro_path())
    fine = motion.resampled(0.01)
    assert fine.acceleration.tobytes() == midpoint_scheme(motion.acceleration).tobytes()
    assert fine.duration == pytest.approx(motion.duration, abs=1e-9)


def test_resample_non_integer_ratio_is_linear_interpolation():
    acc = np.random.default_rng(3).normal(size=200)
    motion = GroundMotion(0.02, acc, 'r.csv')
    resampled = motion.resampled(0.015)
    duration = 199 * 0.02
    n_new = math.floor(duration / 0.015 + 1e-9) + 1
    assert resampled.n_samples == n_new == 266
    assert resampled.dt == 0.015
    t_old = np.arange(200) * 0.02
    t_new = np.arange(n_new) * 0.015
    np.testing.assert_allclose(resampled.acceleration, np.interp(t_new, t_old, acc), atol=1e-12)
    assert resampled.duration <= motion.duration + 1e-12
    assert motion.duration - resampled.duration < 0.015


def test_resample_integer_ratio_three_keeps_original_samples():
    acc = np.random.default_rng(4).normal(size=40)
    motion = GroundMotion(0.03, acc, 'r.csv')
    fine = motion.resampled(0.01)
    assert fine.n_samples == 3 * 39 + 1
    assert np.array_equal(fine.acceleration[::3], acc)
    t_old = np.arange(40) * 0.03
    t_new = np.arange(fine.n_samples) * 0.01
    np.testing.assert_allclose(fine.acceleration, np.interp(t_new, t_old, acc), atol=1e-12)
    assert fine.duration == pytest.approx(motion.duration, abs=1e-12)


def test_resample_coarser_takes_every_other_sample():
    acc = np.arange(11, dtype=float) ** 2
    coarse = GroundMotion(0.01, acc, 'r.csv').resampled(0.02)
    assert np.array_equal(coarse.acceleration, acc[::2])
    assert coarse.duration == pytest.approx(0.1, abs=1e-12)


@pytest.mark.parametrize('dt', [0.0, -0.01, math.nan])
def test_resample_rejects_bad_dt(dt):
    with pytest.raises(GroundMotionError, match='dt'):
        GroundMotion(0.01, [0.0, 1.0, 2.0], 'r.csv').resampled(dt)


def test_resample_rejects_dt_longer_than_record():
    with pytest.raises(GroundMotionError, match='longer than the record'):
        GroundMotion(0.01, [0.0, 1.0, 2.0], 'r.csv').resampled(0.05)


def test_padded_appends_zeros():
    motion = GroundMotion(0.5, [1.0, 2.0, 3.0], 'p.csv')
    padded = motion.padded(3.0)
    np.testing.assert_array_equal(padded.acceleration, [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 0.0])
    assert padded.duration == pytest.approx(3.0)
    assert padded.dt == 0.5 and padded.source == 'p.csv'
    assert motion.n_samples == 3
    assert motion.padded(1.0) == motion


def test_padded_rejects_shorter_duration():
    with pytest.raises(GroundMotionError, match='already'):
        GroundMotion(0.5, [1.0, 2.0, 3.0], 'p.csv').padded(0.5)


# ---------------------------------------------------------------------- good files


def elcentro_path() -> Path:
    """The shipped El Centro record, wherever the package layout puts it."""
    for candidate in ELCENTRO_CANDIDATES:
        if candidate.is_file():
            return candidate
    raise AssertionError(f'shipped record not found at any of {ELCENTRO_CANDIDATES}')


def test_shipped_elcentro_record():
    motion = read_ground_motion(elcentro_path())
    assert motion.n_samples == 1560
    assert motion.dt == 0.02
    assert motion.source == ELCENTRO_NAME
    assert motion.pga / G == pytest.approx(0.31882, abs=1e-5)
    assert motion.acceleration[1] == pytest.approx(6.3e-3 * G, rel=1e-12)


def test_two_column_comma_with_header_and_comments(tmp_path):
    path = write(
        tmp_path,
        'rec.csv',
        '# a comment\n'
        'time_s,accel_g\n'
        '0.00,0.0\n'
        '# another comment\n'
        '0.01,0.1\n'
        '\n'
        '0.02,-0.2\n',
    )
    motion = read_two_column(path)
    assert motion.dt == 0.01
    np.testing.assert_allclose(motion.acceleration, [0.0, 0.1 * G, -0.2 * G], rtol=1e-15)
    assert motion.source == 'rec.csv'


def test_two_column_whitespace_shifted_start_and_m_s2(tmp_path):
    path = write(tmp_path, 'rec.txt', '5.000\t1.5\n5.005   -2.5\n  5.010 3.0  \n')
    motion = read_two_column(path, units='m/s2')
    assert motion.dt == 0.005
    np.testing.assert_array_equal(motion.acceleration, [1.5, -2.5, 3.0])
    np.testing.assert_allclose(motion.time, [0.0, 0.005, 0.01])


def test_two_column_g_parameter(tmp_path):
    path = write(tmp_path, 'rec.txt', '0 1.0\n0.1 0.5\n')
    np.testing.assert_array_equal(read_two_column(path).acceleration, [9.81, 0.5 * 9.81])
    np.testing.assert_array_equal(
        read_two_column(path, g=G_STANDARD).acceleration, [G_STANDARD, 0.5 * G_STANDARD]
    )
    np.testing.assert_array_equal(
        read_two_column(path, units='m/s^2').acceleration, [1.0, 0.5]
    )


def test_single_column(tmp_path):
    path = write(tmp_path, 'one.txt', 'accel\n0.0\n1.0e-1\n-2.5E-01\n')
    motion = read_single_column(path, dt=0.005)
    assert motion.dt == 0.005
    np.testing.assert_allclose(motion.acceleration, [0.0, 0.1 * G, -0.25 * G], rtol=1e-15)


def test_multi_column_row_major_with_short_last_row(tmp_path):
    path = write(tmp_path, 'multi.txt', '1 2 3 4\n5 6 7 8\n9 10\n')
    motion = read_multi_column(path, dt=0.02, units='m/s2')
    np.testing.assert_array_equal(motion.acceleration, np.arange(1.0, 11.0))
    assert motion.dt == 0.02
    in_g = read_multi_column(path, dt=0.02, g=10.0)
    np.testing.assert_array_equal(in_g.acceleration, np.arange(10.0, 110.0, 10.0))


@pytest.mark.parametrize(
    'line4',
    [
        'NPTS=  5, DT=   .0050 SEC',
        'NPTS= 5 DT= 0.005 SEC',
        'npts=5, dt=0.005 sec',
        '5    0.00500    NPTS, DT',
    ],
)
def test_at2_header_forms(tmp_path, line4):
    path = write(
        tmp_path, 'rec.AT2', at2_text(line4, '  .1000000E-02  .2000000E-02 -.3000000E-02\n'
                                             '  .4000000E-02  0.0\n')
    )
    motion = read_at2(path)
    assert motion.dt == 0.005
    np.testing.assert_allclose(
        motion.acceleration, np.array([1e-3, 2e-3, -3e-3, 4e-3, 0.0]) * G, rtol=1e-15
    )
    assert motion.source == 'rec.AT2'


def test_at2_g_parameter(tmp_path):
    path = write(tmp_path, 'rec.at2', at2_text('NPTS=2, DT=0.01 SEC', '1.0 0.5\n'))
    np.testing.assert_array_equal(read_at2(path, g=G_STANDARD).acceleration, [G_STANDARD,
                                                                             0.5 * G_STANDARD])


def test_auto_dispatch(tmp_path):
    two = write(tmp_path, 'two.csv', '0.0,0.1\n0.02,0.2\n0.04,0.3\n')
    one = write(tmp_path, 'one.txt', '0.1\n0.2\n0.3\n')
    multi = write(tmp_path, 'multi.txt', '0.1 0.2 0.3\n0.4 0.5\n')
    at2 = write(tmp_path, 'rec.At2', at2_text('NPTS=3, DT=0.01 SEC', '0.1 0.2 0.3\n'))

    assert read_ground_motion(two).dt == 0.02
    assert read_ground_motion(one, dt=0.01).n_samples == 3
    multi_motion = read_ground_motion(multi, dt=0.01)
    np.testing.assert_allclose(multi_motion.acceleration, np.array([0.1, 0.2, 0.3, 0.4, 0.5]) * G)
    at2_motion = read_ground_motion(at2)
    assert at2_motion.dt == 0.01
    np.testing.assert_allclose(at2_motion.acceleration, np.array([0.1, 0.2, 0.3]) * G)


def test_explicit_format_and_units(tmp_path):
    # Two values per row read as a row-major multi-column record when asked to.
    path = write(tmp_path, 'pairs.txt', '1 2\n3 4\n5\n')
    motion = read_ground_motion(path, format='multi_column', dt=0.1, units='m/s2')
    np.testing.assert_array_equal(motion.acceleration, [1.0, 2.0, 3.0, 4.0, 5.0])
    single = write(tmp_path, 'single.dat', '1\n2\n')
    assert read_ground_motion(single, format='single_column', dt=0.1, units='m/s2').pga == 2.0


def test_dt_agreeing_with_file_is_accepted(tmp_path):
    two = write(tmp_path, 'two.csv', '0.0,0.1\n0.02,0.2\n')
    at2 = write(tmp_path, 'rec.at2', at2_text('NPTS=2, DT=0.01 SEC', '0.1 0.2\n'))
    assert read_ground_motion(two, dt=0.02).dt == 0.02
    assert read_ground_motion(at2, dt=0.01).dt == 0.01


# ---------------------------------------------------------------------- broken files


def test_truncated_two_column_names_line(tmp_path):
    path = write(tmp_path, 'cut.csv', '0.0,0.1\n0.01,0.2\n0.02,1.2e')
    with pytest.raises(GroundMotionError, match=r"'.*cut\.csv'.*line 3: non-numeric .*1\.2e"):
        read_ground_motion(path)


def test_truncated_two_column_missing_column(tmp_path):
    path = write(tmp_path, 'cut.csv', '0.0,0.1\n0.01,0.2\n0.02\n')
    with pytest.raises(GroundMotionError, match='line 3: expected 2 columns'):
        read_two_column(path)


def test_non_numeric_value_names_line(tmp_path):
    path = write(tmp_path, 'bad.txt', '# c\n0.0 0.1\n0.01 abc\n0.02 0.3\n')
    with pytest.raises(GroundMotionError, match=r"'.*bad\.txt': line 3: non-numeric value 'abc'"):
        read_ground_motion(path)


def test_second_header_line_is_an_error(tmp_path):
    path = write(tmp_path, 'hdr.txt', 'time accel\nseconds g\n0.0 0.1\n0.01 0.2\n')
    with pytest.raises(GroundMotionError, match="line 2: non-numeric value 'seconds'"):
        read_ground_motion(path)


def test_empty_field_is_an_error(tmp_path):
    path = write(tmp_path, 'gap.csv', '0.0,0.1\n0.01,,0.2\n')
    with pytest.raises(GroundMotionError, match='line 2: empty field'):
        read_ground_motion(path)


@pytest.mark.parametrize('text', ['', '   \n\n'])
def test_empty_file(tmp_path, text):
    path = write(tmp_path, 'empty.csv', text)
    with pytest.raises(GroundMotionError, match=r"'.*empty\.csv'.*empty"):
        read_ground_motion(path)


def test_only_comments(tmp_path):
    path = write(tmp_path, 'comments.csv', '# just\n# comments\n\n')
    with pytest.raises(GroundMotionError, match='no data'):
        read_ground_motion(path)


def test_only_header(tmp_path):
    path = write(tmp_path, 'header.csv', '# c\ntime,accel\n')
    with pytest.raises(GroundMotionError, match='no data after the header'):
        read_ground_motion(path)


def test_single_sample_two_column(tmp_path):
    path = write(tmp_path, 'short.csv', '0.0,0.1\n')
    with pytest.raises(GroundMotionError, match='at least 2 samples'):
        read_two_column(path)


def test_non_uniform_time(tmp_path):
    path = write(tmp_path, 'uneven.csv', 'time,acc\n0.00,0\n0.01,0\n0.02,0\n0.035,0\n0.04,0\n')
    with pytest.raises(GroundMotionError, match='non-uniform time step at line 5'):
        read_ground_motion(path)


def test_time_within_tolerance_is_uniform(tmp_path):
    path = write(tmp_path, 'ok.csv', '0.00,0\n0.01,0\n0.0200000000001,0\n0.03,0\n')
    assert read_two_column(path).n_samples == 4


def test_decreasing_time(tmp_path):
    path = write(tmp_path, 'back.csv', '0.02,0\n0.01,0\n0.0,0\n')
    with pytest.raises(GroundMotionError, match='line 2: time must increase'):
        read_two_column(path)


@pytest.mark.parametrize('token', ['NaN', 'nan', 'inf', '-Infinity', '1e400'])
def test_non_finite_values(tmp_path, token):
    path = write(tmp_path, 'nan.csv', f'0.0,0.1\n0.01,{token}\n0.02,0.3\n')
    with pytest.raises(GroundMotionError, match='line 2: non-finite value'):
        read_ground_motion(path)


def test_non_finite_single_column(tmp_path):
    path = write(tmp_path, 'nan.txt', '0.1\n0.2\nnan\n')
    with pytest.raises(GroundMotionError, match='line 3: non-finite'):
        read_single_column(path, dt=0.01)


def test_ragged_multi_column_middle_row(tmp_path):
    path = write(tmp_path, 'ragged.txt', '1 2 3\n4 5\n6 7 8\n9\n')
    with pytest.raises(GroundMotionError, match='line 2: expected 3 values, found 2'):
        read_ground_motion(path, dt=0.01)


def test_multi_column_last_row_longer(tmp_path):
    path = write(tmp_path, 'long.txt', '1 2 3\n4 5 6\n7 8 9 10\n')
    with pytest.raises(GroundMotionError, match='line 3: expected 3 values, found 4'):
        read_multi_column(path, dt=0.01)


def test_single_column_with_two_values(tmp_path):
    path = write(tmp_path, 'two.txt', '1\n2 3\n')
    with pytest.raises(GroundMotionError, match='line 2: expected 1 value'):
        read_single_column(path, dt=0.01)


def test_unknown_units(tmp_path):
    path = write(tmp_path, 'rec.csv', '0.0,0.1\n0.01,0.2\n')
    with pytest.raises(GroundMotionError, match="unknown units 'cm/s2'"):
        read_ground_motion(path, units='cm/s2')
    with pytest.raises(GroundMotionError, match="unknown units 'gal'"):
        read_two_column(path, units='gal')


def test_unknown_format(tmp_path):
    path = write(tmp_path, 'rec.csv', '0.0,0.1\n0.01,0.2\n')
    with pytest.raises(GroundMotionError, match="unknown format 'smc'"):
        read_ground_motion(path, format='smc')


@pytest.mark.parametrize('g', [0.0, -9.81, math.nan])
def test_bad_g(tmp_path, g):
    path = write(tmp_path, 'rec.csv', '0.0,0.1\n0.01,0.2\n')
    with pytest.raises(GroundMotionError, match='g must be positive'):
        read_ground_motion(path, g=g)


def test_single_column_needs_dt(tmp_path):
    path = write(tmp_path, 'one.txt', '0.1\n0.2\n0.3\n')
    with pytest.raises(GroundMotionError, match=r"'.*one\.txt'.*single-column file needs dt"):
        read_ground_motion(path)


def test_multi_column_needs_dt(tmp_path):
    path = write(tmp_path, 'multi.txt', '0.1 0.2 0.3\n0.4\n')
    with pytest.raises(GroundMotionError, match='multi-column file needs dt'):
        read_ground_motion(path)


@pytest.mark.parametrize('dt', [0.0, -0.01, math.inf])
def test_bad_user_dt(tmp_path, dt):
    path = write(tmp_path, 'one.txt', '0.1\n0.2\n')
    with pytest.raises(GroundMotionError, match='dt must be positive'):
        read_single_column(path, dt=dt)


def test_two_column_dt_disagreeing_with_file(tmp_path):
    path = write(tmp_path, 'two.csv', '0.0,0.1\n0.02,0.2\n')
    with pytest.raises(GroundMotionError, match=r'dt=0\.01 was given but the file has dt=0\.02'):
        read_ground_motion(path, dt=0.01)


def test_at2_dt_disagreeing_with_file(tmp_path):
    path = write(tmp_path, 'rec.at2', at2_text('NPTS=2, DT=0.005 SEC', '0.1 0.2\n'))
    with pytest.raises(GroundMotionError, match=r'dt=0\.01 was given but the file has dt=0\.005'):
        read_ground_motion(path, dt=0.01)


def test_at2_with_m_s2_units_is_an_error(tmp_path):
    path = write(tmp_path, 'rec.at2', at2_text('NPTS=2, DT=0.005 SEC', '0.1 0.2\n'))
    with pytest.raises(GroundMotionError, match='AT2 files are in g'):
        read_ground_motion(path, units='m/s2')


def test_at2_npts_mismatch(tmp_path):
    values = '\n'.join(' '.join(['0.001'] * 5) for _ in range(799)) + '\n0.1 0.2 0.3 0.4\n'
    path = write(tmp_path, 'rec.AT2', at2_text('NPTS=  4000, DT=   .0050 SEC', values))
    with pytest.raises(
        GroundMotionError,
        match=r"'.*rec\.AT2': line 4: NPTS=4000 but 3999 values were read",
    ):
        read_ground_motion(path)


def test_at2_too_many_values(tmp_path):
    path = write(tmp_path, 'rec.at2', at2_text('NPTS=2, DT=0.01 SEC', '0.1 0.2 0.3\n'))
    with pytest.raises(GroundMotionError, match='NPTS=2 but 3 values were read'):
        read_at2(path)


def test_at2_truncated_mid_number(tmp_path):
    path = write(tmp_path, 'cut.at2', at2_text('NPTS=4, DT=0.01 SEC', '0.1 0.2\n0.3 .4E-'))
    with pytest.raises(GroundMotionError, match=r"line 6: non-numeric value '\.4E-'"):
        read_at2(path)


def test_at2_non_numeric_value(tmp_path):
    path = write(tmp_path, 'bad.at2', at2_text('NPTS=4, DT=0.01 SEC', '0.1 0.2\nx 0.4\n'))
    with pytest.raises(GroundMotionError, match=r"'.*bad\.at2': line 6: non-numeric value 'x'"):
        read_ground_motion(path)


def test_at2_nan_value(tmp_path):
    path = write(tmp_path, 'nan.at2', at2_text('NPTS=3, DT=0.01 SEC', '0.1 NaN 0.3\n'))
    with pytest.raises(GroundMotionError, match='line 5: non-finite value'):
        read_at2(path)


def test_at2_missing_header(tmp_path):
    path = write(tmp_path, 'short.at2', 'PEER NGA\nTITLE\n')
    with pytest.raises(GroundMotionError, match='expected 4 header lines, found 2'):
        read_at2(path)


def test_at2_only_header(tmp_path):
    path = write(tmp_path, 'hdr.at2', at2_text('NPTS=3, DT=0.01 SEC', ''))
    with pytest.raises(GroundMotionError, match='NPTS=3 but 0 values were read'):
        read_at2(path)


@pytest.mark.parametrize(
    'line4', ['0.1 0.2 0.3 0.4 0.5', 'NPTS=abc, DT=0.01 SEC', 'NPTS=3, DT=-0.01 SEC']
)
def test_at2_unparseable_line4(tmp_path, line4):
    path = write(tmp_path, 'hdr.at2', at2_text(line4, '0.1 0.2 0.3\n'))
    with pytest.raises(GroundMotionError, match=re.escape('line 4: ')):
        read_at2(path)


def test_missing_file(tmp_path):
    with pytest.raises(GroundMotionError, match=r"'.*nowhere\.csv'.*cannot read"):
        read_ground_motion(tmp_path / 'nowhere.csv')


# ---------------------------------------------------------------------- strict AT2 reading


def peer_value(value):
    """``value`` as PEER writes it (Fortran E14.7 style): ``.1196327E-03``, ``-.1790158E-02``."""
    if value == 0.0:
        return '.0000000E+00'
    exponent = math.floor(math.log10(abs(value))) + 1
    mantissa = round(abs(value) / 10.0**exponent * 1e7)
    if mantissa == 10**7:  # rounded up to 1.0
        mantissa, exponent = 10**6, exponent + 1
    sign = '-' if value < 0 else ''
    return f'{sign}.{mantissa:07d}E{"-" if exponent < 0 else "+"}{abs(exponent):02d}'


PEER_VALUES = [2.339013e-3, -1.790158e-3, 1.2e-3, -3.4e-3, 5.0e-3, 1.23e-4, -9.87e-3,
               4.3e-3, 1.1e-3, 2.0e-4, 0.0, -1.790158e-3]


def peer_text(values=PEER_VALUES, line4=None):
    """A PEER-style AT2 file: values in 14-character fields, five per line, a final newline."""
    tokens = [f'{peer_value(v):>14}' for v in values]
    body = ''.join(''.join(tokens[i:i + 5]) + '\n' for i in range(0, len(tokens), 5))
    return at2_text(line4 or f'NPTS=  {len(values)}, DT=   .0050 SEC', body)


def test_peer_value_writes_what_peer_writes():
    assert peer_value(-1.790158e-3) == '-.1790158E-02'
    assert peer_value(1.196327e-4) == '.1196327E-03'
    assert peer_value(0.0) == '.0000000E+00'


def test_a_peer_file_and_one_without_its_final_newline_are_read(tmp_path):
    text = peer_text()
    assert text.endswith(' -.1790158E-02\n')
    for name, content in (('full.AT2', text), ('no-newline.AT2', text[:-1]),
                          ('crlf.AT2', text.replace('\n', '\r\n')),
                          ('crlf-cut-1.AT2', text.replace('\n', '\r\n')[:-1])):
        motion = read_at2(write(tmp_path, name, content))
        np.testing.assert_allclose(motion.acceleration, np.array(PEER_VALUES) * G, rtol=1e-6)


@pytest.mark.parametrize('cut', range(2, 16))
def test_a_file_cut_short_is_refused(tmp_path, cut):
    # The last value is ' -.1790158E-02' and a newline: cutting 2 to 13 characters leaves a
    # part of it ('-.1790158E-0', ..., '-.1790158', ..., '-'), 14 or 15 drop it.
    path = write(tmp_path, 'cut.AT2', peer_text()[:-cut])
    with pytest.raises(GroundMotionError) as info:
        read_at2(path)
    message = str(info.value)
    assert '\n' not in message
    assert str(path) in message
    if cut >= 14:
        assert 'line 4: NPTS=12 but 11 values were read' in message
    else:
        left = '-.1790158E-02'[:14 - cut]
        assert 'line 7: ' in message
        assert repr(left) in message


def test_a_file_cut_5_or_9_characters_short_names_the_file_line_and_token(tmp_path):
    text = peer_text()
    path = write(tmp_path, 'cut5.AT2', text[:-5])
    with pytest.raises(GroundMotionError, match=re.escape(
            f"ground motion '{path}': line 7: last value '-.1790158' is not written like the "
            "one before it ('.0000000E+00') and the file does not end with a line end: file "
            'truncated?')):
        read_at2(path)
    path = write(tmp_path, 'cut9.AT2', text[:-9])
    with pytest.raises(GroundMotionError, match=re.escape(
            f"ground motion '{path}': line 7: last value '-.179' is not written like")):
        read_ground_motion(path)


@pytest.mark.parametrize(('token', 'what'), [
    ('-.1790158E-0', ("malformed value '-.1790158E-0' (an AT2 file writes an exponent with "
                      'two digits or more; file truncated?)')),
    ('-.1790158E', "non-numeric value '-.1790158E'"),
    ('1.2E+', "non-numeric value '1.2E+'"),
    ('1.2E-', "non-numeric value '1.2E-'"),
    ('.1790158D-0', "malformed value '.1790158D-0'"),
    ('1.2.3', "non-numeric value '1.2.3'"),
    ('\u0661.5', "non-numeric value '\u0661.5'"),  # an Arabic-Indic digit: not a number here
])
def test_a_malformed_at2_token_is_refused_with_file_line_and_token(tmp_path, token, what):
    # In the middle of the file, and with the final newline: not only at a cut end.
    body = f'  .1000000E-02  {token}  .2000000E-02\n  .3000000E-02\n'
    path = write(tmp_path, 'bad.AT2', at2_text('NPTS=  4, DT=   .0050 SEC', body))
    with pytest.raises(GroundMotionError, match=re.escape(f"'{path}': line 5: {what}")):
        read_at2(path)


def test_at2_exponents_of_two_or_three_digits_are_read(tmp_path):
    path = write(tmp_path, 'ok.AT2', at2_text('NPTS=3, DT=.01 SEC', '.1E-02 -.2E+02 .3E-100\n'))
    np.testing.assert_allclose(read_at2(path).acceleration, np.array([1e-3, -20.0, 3e-101]) * G)


def test_npts_may_be_an_integral_float(tmp_path):
    values = [0.001 * ((i % 7) - 3) for i in range(5372)]
    path = write(tmp_path, 'rec.AT2', peer_text(values, 'NPTS= 5372.0, DT= .0050 SEC'))
    motion = read_at2(path)
    assert motion.n_samples == 5372
    path = write(tmp_path, 'half.AT2', peer_text(values, 'NPTS= 5372.5, DT= .0050 SEC'))
    with pytest.raises(GroundMotionError, match=re.escape(
            f"'{path}': line 4: NPTS must be a non-negative integer, got '5372.5'")):
        read_at2(path)


@pytest.mark.parametrize(('line4', 'dt'), [
    ('NPTS=  12, DT=   .0050 SEC', 0.005),
    ('NPTS=  12, DT=   10 MSEC', 0.01),
    ('npts= 12 dt= 10 msec', 0.01),
    ('NPTS=  12, DT=   .0050', 0.005),  # no unit: seconds, as before
    ('NPTS=  12, DT=   .0050,', 0.005),
    ('DT= .0050 NPTS= 12', 0.005),  # 'NPTS' is the next key, not a unit
    ('DT= .0050 SEC NPTS= 12', 0.005),
])
def test_at2_dt_units(tmp_path, line4, dt):
    assert read_at2(write(tmp_path, 'rec.AT2', peer_text(line4=line4))).dt == dt


@pytest.mark.parametrize(('line4', 'unit'), [
    ('NPTS=  12, DT=   10 USEC', 'USEC'),
    ('NPTS=  12, DT=   .005 MIN', 'MIN'),
    ('NPTS=  12, DT=   .005 samples', 'samples'),
])
def test_an_unknown_dt_unit_is_refused_naming_it(tmp_path, line4, unit):
    path = write(tmp_path, 'rec.AT2', peer_text(line4=line4))
    with pytest.raises(GroundMotionError, match=re.escape(
            f"ground motion '{path}': line 4: unknown DT unit '{unit}' (expected SEC or MSEC, or "
            'no unit for seconds)')):
        read_ground_motion(path)


@pytest.mark.parametrize(('name', 'text', 'line', 'token'), [
    ('one.txt', '1.2E-\n0.3\n0.4\n', 1, '1.2E-'),  # not a header line: a cut number
    ('one2.txt', '-.5E\n0.3\n', 1, '-.5E'),
    ('two.csv', '0.0,1.2E-\n0.01,0.3\n', 1, '1.2E-'),
    ('two2.csv', 'time,accel\n0.0,0.1\n0.01,1.2E+\n', 3, '1.2E+'),
    ('multi.txt', '1 2 3\n4 5E 6\n', 2, '5E'),
    ('digits.txt', '0.1\n\u0663\n', 2, '\u0663'),
])
def test_other_readers_refuse_malformed_numbers(tmp_path, name, text, line, token):
    path = write(tmp_path, name, text)
    with pytest.raises(GroundMotionError, match=re.escape(
            f"ground motion '{path}': line {line}: non-numeric value {token!r}")):
        read_ground_motion(path, dt=None if name.endswith('.csv') else 0.01)


def test_a_header_line_is_still_skipped(tmp_path):
    path = write(tmp_path, 'one.txt', 'accel_g\n0.1\n0.2\n')
    np.testing.assert_allclose(read_ground_motion(path, dt=0.01).acceleration, [0.1 * G, 0.2 * G])
