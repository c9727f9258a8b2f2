"""MATLAB ``.mat`` ground-motion records (the vRTHS benchmark's layout: rows [time; accel])."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import io as scipy_io

from pd_core.dynamics.record_readers import FORMATS, read_ground_motion, read_mat
from pd_core.errors import GroundMotionError

TIME = np.arange(50) * 0.02
ACC = np.sin(2 * np.pi * 1.5 * TIME)


def _save(path: Path, **arrays: object) -> Path:
    scipy_io.savemat(path, arrays)
    return path


def test_rows_and_columns(tmp_path: Path) -> None:
    rows = _save(tmp_path / 'rows.mat', ElCentroAccel=np.vstack([TIME + 3.0, ACC]))
    motion = read_mat(rows)
    assert motion.dt == 0.02
    np.testing.assert_array_equal(motion.acceleration, ACC)
    assert motion.source == 'rows.mat'
    columns = _save(tmp_path / 'columns.mat', record=np.column_stack([TIME, ACC]))
    np.testing.assert_array_equal(read_mat(columns).acceleration, ACC)


def test_dispatch_by_suffix_and_units(tmp_path: Path) -> None:
    path = _save(tmp_path / 'Kobe.MAT', KobeAccel=np.vstack([TIME, ACC]))
    assert 'mat' in FORMATS
    motion = read_ground_motion(path, units='m/s2')
    np.testing.assert_array_equal(motion.acceleration, ACC)
    in_g = read_ground_motion(path, units='g', g=9.81)
    np.testing.assert_allclose(in_g.acceleration, ACC * 9.81, rtol=1e-15)
    assert read_ground_motion(path, format='mat', units='m/s2', dt=0.02).dt == 0.02
    with pytest.raises(GroundMotionError, match=r'dt=0\.01 was given'):
        read_ground_motion(path, units='m/s2', dt=0.01)


def test_choosing_the_array(tmp_path: Path) -> None:
    path = _save(tmp_path / 'two.mat', a=np.vstack([TIME, ACC]), b=np.vstack([TIME, -ACC]),
                 label='text')
    with pytest.raises(GroundMotionError, match=r"found: a, b; name it with variable"):
        read_mat(path)
    np.testing.assert_array_equal(read_mat(path, variable='b').acceleration, -ACC)
    with pytest.raises(GroundMotionError, match="no 2-row or 2-column numeric array 'c'"):
        read_mat(path, variable='c')


@pytest.mark.parametrize(('array', 'match'), [
    (np.vstack([[0.0, 0.02, 0.05, 0.07], [1.0, 2.0, 3.0, 4.0]]),
     'non-uniform time step at sample 2'),
    (np.vstack([[0.0, -0.02], [1.0, 2.0]]), 'time must increase'),
    (np.vstack([[0.0, 0.02], [1.0, np.nan]]), 'non-finite'),
    (np.ones((3, 3)), 'expected one 2-row or 2-column'),
])
def test_bad_records(tmp_path: Path, array: np.ndarray, match: str) -> None:
    path = _save(tmp_path / 'bad.mat', record=array)
    with pytest.raises(GroundMotionError, match=match) as error:
        read_mat(path)
    assert "'" + str(path) + "'" in str(error.value)


def test_not_a_mat_file(tmp_path: Path) -> None:
    path = tmp_path / 'text.mat'
    path.write_text('0 1\n0.02 2\n')
    with pytest.raises(GroundMotionError, match='cannot read MATLAB file'):
        read_mat(path)
