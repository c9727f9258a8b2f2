"""Energy balance: input = kinetic + viscous + strain/hysteretic, checked independently."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from pd_integrator.core.run.energy import energy_balance
from pd_integrator.core.run.history import ResponseHistory
from pd_integrator.core.run.runner import run_offline
from pd_integrator.core.run.test_file import load_test_file

REPO = Path(__file__).resolve().parents[2]
RECORD = REPO / 'src/pd_integrator/data/ground_motions/elcentro_1940_ns_chopra.csv'


def _history(x: np.ndarray, v: np.ndarray, force: np.ndarray, ag: np.ndarray,
             dt: float) -> ResponseHistory:
    history = ResponseHistory.allocate(('u',), dt, ag)
    for i in range(len(ag)):
        history.record(i, x[i:i + 1], v[i:i + 1], np.zeros(1), (force[i],), (x[i],))
    return history


def test_energy_terms_against_hand_computed_values() -> None:
    dt = 0.5
    x = np.array([0.0, 1.0, 3.0])
    v = np.array([0.0, 2.0, 4.0])
    force = np.array([0.0, 10.0, 30.0])
    ag = np.array([0.0, -1.0, -2.0])
    mass, damping = np.array([[2.0]]), np.array([[0.5]])
    energy = energy_balance(_history(x, v, force, ag, dt), mass, damping, np.ones(1))
    # p = -m ag = [0, 2, 4]; input = ½(0+2)·1 + ½(2+4)·2 = 1 + 6
    assert energy.input.tolist() == [0.0, 1.0, 7.0]
    assert energy.kinetic.tolist() == [0.0, 4.0, 16.0]
    # C v = [0, 1, 2]; viscous = ½(0+1)·1 + ½(1+2)·2 = 0.5 + 3
    assert energy.viscous.tolist() == [0.0, 0.5, 3.5]
    # strain = ½(0+10)·1 + ½(10+30)·2 = 5 + 40
    assert energy.strain.tolist() == [0.0, 5.0, 45.0]
    assert energy.error.tolist() == [0.0, 1.0 - 4.0 - 0.5 - 5.0, 7.0 - 16.0 - 3.5 - 45.0]
    assert energy.scale == 45.0


def _test_file(tmp_path: Path, dt: float, specimen: dict[str, object]) -> Path:
    raw = {
        'test': {'id': 'energy', 'dt': dt, 'duration': 12.0},
        'structure': {'dof_names': ['top'], 'mass': 2543.4, 'damping': {'ratio': 0.05},
                      'initial_stiffness': 312559.0},
        'ground_motion': {'file': str(RECORD), 'units': 'g'},
        'specimen': {'elements': [specimen]},
    }
    path = tmp_path / f'energy-{dt}.yaml'
    path.write_text(yaml.safe_dump(raw), encoding='utf-8')
    return path


def test_energy_error_is_small_and_shrinks_with_dt(tmp_path: Path) -> None:
    specimen = {'model': 'epp', 'stiffness': 312559.0, 'yield_force': 10000.0}
    ratios = []
    for dt in (0.01, 0.005):
        run = run_offline(load_test_file(_test_file(tmp_path, dt, specimen)),
                          tmp_path / f'run-{dt}', figures=False)
        energy = run.summary['energy']
        assert energy['input'] > 1000.0
        ratios.append(energy['max_error_ratio'])
        assert (tmp_path / f'run-{dt}' / 'energy.csv').is_file()
    assert ratios[0] < 2e-3
    assert 3.0 < ratios[0] / ratios[1] < 5.0  # second order


def test_hysteretic_energy_equals_plastic_work(tmp_path: Path) -> None:
    """For EPP, ∫ r dx = r_end²/2k + f_y·Σ|Δx_plastic| (recoverable + dissipated)."""
    k, fy = 312559.0, 8000.0
    run = run_offline(load_test_file(_test_file(
        tmp_path, 0.005, {'model': 'epp', 'stiffness': k, 'yield_force': fy})),
        tmp_path / 'run', figures=False)
    history = run.session.history
    n = history.n_committed
    x = history.measured_displacement[:n, 0]
    r = history.restoring_force[:n, 0]
    plastic = x - r / k
    dissipated = fy * np.sum(np.abs(np.diff(plastic)))
    expected = r[-1] ** 2 / (2.0 * k) + dissipated
    assert dissipated > 300.0  # the column yields repeatedly
    assert run.summary['energy']['strain'] == pytest.approx(expected, rel=2e-3)
