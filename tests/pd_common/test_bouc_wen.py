"""Tests of the Bouc–Wen model: closed forms, degradation, semantics, and OpenSees itself.

OpenSees's ``uniaxialMaterial BoucWen`` (``BoucWenMaterial.cpp``) is the reference of the
discretisation: it runs in a child process (openseespy needs its bundled library path), driven
by ``testUniaxialMaterial``/``setStrain`` (which commits) over the same displacement history.
The OpenSees tests are skipped only if openseespy cannot be imported.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from functools import cache
from typing import Any

import numpy as np
import pytest
from tests.support.opensees_material import opensees_available, opensees_responses

from pd_common.specimen import HysteresisError, HysteresisModel
from pd_common.specimen.bouc_wen import BoucWen

K = 1.0e5   # N/m
ALPHA = 0.05
DY = 0.02   # m: z_u = DY with A0 = 1 and β + γ = 1/DY^n


def shape(n: float) -> dict[str, float]:
    """β = γ with ``(A0/(β+γ))^(1/n) = DY``."""
    s = 1.0 / DY ** n
    return {'beta': s / 2.0, 'gamma': s / 2.0}


def model(n: float = 1.0, **kwargs: Any) -> BoucWen:
    params: dict[str, Any] = {'stiffness': K, 'post_yield_ratio': ALPHA, 'exponent': n,
                              **shape(n)}
    params.update(kwargs)
    return BoucWen(**params)


def drive(m: HysteresisModel, path: Sequence[float] | np.ndarray) -> np.ndarray:
    """Apply each displacement as one committed step and return the forces."""
    forces = np.empty(len(path))
    for i, x in enumerate(path):
        forces[i] = m.set_trial_displacement(float(x))
        m.commit()
    return forces


def cycles(amplitude: float, count: int, points_per_cycle: int) -> np.ndarray:
    """``count`` sine cycles of constant amplitude (starting at 0, first going positive)."""
    t = np.arange(1, count * points_per_cycle + 1) / points_per_cycle
    return amplitude * np.sin(2.0 * math.pi * t)


def growing_sine(amplitude: float = 0.08, count: int = 5, points: int = 2000) -> np.ndarray:
    t = np.linspace(0.0, 1.0, points)
    return amplitude * t * np.sin(2.0 * math.pi * count * t)


def opensees_path() -> np.ndarray:
    """The growing sine with every 97th point repeated (zero steps, also at reversals)."""
    path = growing_sine()
    return np.insert(path, np.arange(50, len(path), 97), path[50::97])


# --- closed forms -----------------------------------------------------------------------------

def z_exact(x: np.ndarray, a: float = 1.0, s: float = 1.0 / DY) -> np.ndarray:
    """n = 1, no degradation, monotonic from virgin: dz/dx = A − (β+γ) z."""
    return a / s * (1.0 - np.exp(-s * x))


def monotonic_error(h: float, x_end: float = 0.06, a0: float = 1.0) -> float:
    m = model(1.0, a0=a0)
    x = np.arange(1, round(x_end / h) + 1) * h
    f = drive(m, x)
    z = (f - ALPHA * K * x) / ((1.0 - ALPHA) * K)
    return float(np.max(np.abs(z - z_exact(x, a0)))) / DY


def test_monotonic_closed_form_first_order() -> None:
    errors = [monotonic_error(h) for h in (4e-4, 2e-4, 1e-4)]
    assert errors[0] / errors[1] == pytest.approx(2.0, rel=0.05)
    assert errors[1] / errors[2] == pytest.approx(2.0, rel=0.03)
    assert errors[2] < 2e-3  # relative to z_u


def test_monotonic_closed_form_tiny_increments() -> None:
    assert monotonic_error(2e-6, x_end=0.04, a0=1.3) < 3e-5


def test_ultimate_strength_and_initial_stiffness() -> None:
    m = model(2.0, a0=1.2)
    z_u = (1.2 / (1.0 / DY ** 2)) ** 0.5
    assert m.ultimate_hysteretic_displacement == pytest.approx(z_u, rel=1e-15)
    assert m.initial_stiffness == pytest.approx(ALPHA * K + (1.0 - ALPHA) * K * 1.2)
    assert m.tangent == m.initial_stiffness
    x = np.arange(1, 601) * 1e-3  # to 30 z_u
    f = drive(m, x)
    expected = ALPHA * K * x + (1.0 - ALPHA) * K * z_u
    assert f[-1] == pytest.approx(expected[-1], rel=1e-9)
    assert m.hysteretic_displacement == pytest.approx(z_u, rel=1e-9)
    assert m.tangent == pytest.approx(ALPHA * K, rel=1e-6)
    # The hysteretic force never overshoots its bound on the way.
    assert np.all(f <= expected * (1.0 + 1e-12))
    # Negative side is the mirror image.
    mirror = drive(model(2.0, a0=1.2), -x)
    np.testing.assert_allclose(mirror, -f, rtol=1e-12)


def test_tangent_is_the_consistent_one() -> None:
    m = model(1.5, delta_a=1e-4, delta_nu=2e-4, delta_eta=2e-4)
    drive(m, growing_sine(points=300)[:220])
    x_c = m.committed_displacement
    for dx in (2e-3, -2e-3, 5e-4, -5e-4):
        x = x_c + dx
        m.set_trial_displacement(x)
        tangent = m.tangent
        h = 1e-8
        slope = (m.set_trial_displacement(x + h) - m.set_trial_displacement(x - h)) / (2.0 * h)
        assert tangent == pytest.approx(slope, rel=1e-5)


# --- degradation and energy -------------------------------------------------------------------

def peaks_and_energy(m: BoucWen, amplitude: float, count: int,
                     per: int = 200) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Peak force and committed energy at the end of each cycle, and all the forces."""
    path = cycles(amplitude, count, per)
    peaks, energy = [], []
    forces = np.empty(len(path))
    for i, x in enumerate(path):
        forces[i] = m.set_trial_displacement(float(x))
        m.commit()
        if i % per == per // 4 - 1:
            peaks.append(forces[i])
        if i % per == per - 1:
            energy.append(m.hysteretic_energy)
    return np.array(peaks), np.array(energy), forces


@pytest.mark.parametrize('degradation', [
    {'delta_nu': 2e-4}, {'delta_eta': 2e-4}, {'delta_a': 1e-4},
    {'delta_a': 5e-5, 'delta_nu': 1e-4, 'delta_eta': 1e-4},
])
def test_loops_shrink_with_degradation(degradation: dict[str, float]) -> None:
    peaks, energy, _ = peaks_and_energy(model(1.0, **degradation), 3 * DY, 6)
    # The first peak is reached from the virgin z = 0, the others from z ≈ −z_u.
    steady = peaks[1:]
    assert np.all(np.diff(steady) < 0.0), peaks
    assert np.all(np.diff(energy) > 0.0), energy
    assert steady[-1] < 0.99 * steady[0]
    plain, _, _ = peaks_and_energy(model(1.0), 3 * DY, 6)
    assert np.all(peaks < plain)


def test_steady_loop_without_degradation() -> None:
    per = 200
    for n in (1.0, 2.0):
        m = model(n)
        peaks, energy, forces = peaks_and_energy(m, 3 * DY, 3, per)
        loop2, loop3 = forces[per:2 * per], forces[2 * per:]
        peak = float(np.max(np.abs(forces)))
        assert np.max(np.abs(loop3 - loop2)) < 1e-4 * peak
        assert peaks[2] == pytest.approx(peaks[1], rel=1e-5)
        # Each steady cycle adds the loop's area (the α k x part encloses none).
        path = cycles(3 * DY, 3, per)
        x3 = np.concatenate([[path[2 * per - 1]], path[2 * per:]])
        f3 = np.concatenate([[forces[2 * per - 1]], loop3])
        area = float(np.sum(0.5 * (f3[1:] + f3[:-1]) * np.diff(x3)))
        assert area > 0.0
        assert energy[2] - energy[1] == pytest.approx(area, rel=2e-2)
        assert energy[2] - energy[1] == pytest.approx(energy[1] - energy[0], rel=1e-3)
    # Contrast: the same check fails with degradation.
    _, _, forces = peaks_and_energy(model(1.0, delta_nu=2e-4), 3 * DY, 3, per)
    assert np.max(np.abs(forces[2 * per:] - forces[per:2 * per])) > 1e-2 * np.max(forces)


def test_energy_decreases_while_unloading() -> None:
    """``e`` is Baber–Wen's running work integral: it falls while ``ẋ z < 0``."""
    m = model(1.0)
    drive(m, np.linspace(1e-3, 0.06, 60))
    loaded = m.hysteretic_energy
    drive(m, [0.059, 0.058])
    assert m.hysteretic_displacement > 0.0
    assert m.hysteretic_energy < loaded


# --- trial / commit / revert ------------------------------------------------------------------

def test_trial_commit_revert_copy() -> None:
    m = model(1.5, delta_a=1e-4, delta_nu=1e-4, delta_eta=1e-4)
    drive(m, [0.01, 0.03, 0.02])
    committed = (m.committed_displacement, m.committed_force, m.hysteretic_energy,
                 m.hysteretic_displacement)
    first = m.set_trial_displacement(-0.01)
    tangent = m.tangent
    m.set_trial_displacement(0.05)
    m.set_trial_displacement(0.0123)
    assert m.set_trial_displacement(-0.01) == first
    assert m.tangent == tangent
    assert (m.committed_displacement, m.committed_force, m.hysteretic_energy,
            m.hysteretic_displacement) == committed
    m.revert_to_last_commit()
    assert m.trial_displacement == committed[0]
    assert m.trial_force == committed[1]
    other = m.copy()
    twin = copy.deepcopy(m)
    drive(m, [-0.04, 0.05])
    assert other.committed_force == committed[1]
    assert other.set_trial_displacement(-0.01) == first
    assert twin.set_trial_displacement(-0.01) == first
    # The copy reproduces the original's future exactly.
    assert drive(other, [-0.04, 0.05]).tolist() == [twin.set_trial_displacement(-0.04),
                                                    m.committed_force]
    m.reset()
    assert (m.committed_force, m.hysteretic_energy, m.tangent) == (0.0, 0.0,
                                                                    m.initial_stiffness)
    fresh = model(1.5, delta_a=1e-4, delta_nu=1e-4, delta_eta=1e-4)
    assert m.set_trial_displacement(0.01) == fresh.set_trial_displacement(0.01)


def test_zero_step_keeps_the_state() -> None:
    beta, gamma = 0.8 / DY ** 2, 0.2 / DY ** 2
    m = model(2.0, beta=beta, gamma=gamma, delta_nu=1e-4, delta_eta=2e-4)
    drive(m, [0.01, 0.02])
    before = (m.committed_force, m.hysteretic_energy, m.hysteretic_displacement)
    assert m.set_trial_displacement(0.02) == pytest.approx(before[0], rel=1e-15)
    m.commit()
    e, z = m.hysteretic_energy, m.hysteretic_displacement
    assert e == before[1]
    assert z == pytest.approx(before[2], rel=1e-15)
    # OpenSees's signum(0) = -1: the tangent of a zero step is the unloading one (γ − β).
    dz_dx = (1.0 - z ** 2 * (gamma - beta) * (1.0 + 1e-4 * e)) / (1.0 + 2e-4 * e)
    assert m.tangent == pytest.approx(ALPHA * K + (1.0 - ALPHA) * K * dz_dx, rel=1e-12)


def test_newton_failure_raises_and_keeps_the_trial() -> None:
    m = model(1.0, max_iterations=1)
    with pytest.raises(HysteresisError, match='did not converge in 1 iterations'):
        m.set_trial_displacement(0.01)
    assert m.trial_force == 0.0
    assert m.trial_displacement == 0.0
    assert model(1.0, max_iterations=2).set_trial_displacement(0.01) > 0.0


def test_properties() -> None:
    m = BoucWen(stiffness=2e5, post_yield_ratio=-0.1, exponent=3.0, beta=7.0, gamma=-2.0,
                a0=0.9, delta_a=1e-3, delta_nu=2e-3, delta_eta=3e-3, tolerance=1e-10,
                max_iterations=30)
    assert (m.stiffness, m.post_yield_ratio, m.exponent, m.beta, m.gamma, m.a0, m.delta_a,
            m.delta_nu, m.delta_eta, m.tolerance, m.max_iterations) == (
        2e5, -0.1, 3.0, 7.0, -2.0, 0.9, 1e-3, 2e-3, 3e-3, 1e-10, 30)
    defaults = BoucWen(1e5, 0.1, 1.0, 1.0, 0.0)
    assert (defaults.a0, defaults.delta_a, defaults.delta_nu, defaults.delta_eta,
            defaults.tolerance, defaults.max_iterations) == (1.0, 0.0, 0.0, 0.0, 1e-8, 20)


@pytest.mark.parametrize(('kwargs', 'name'), [
    ({'stiffness': 0.0}, 'stiffness'),
    ({'stiffness': math.inf}, 'stiffness'),
    ({'post_yield_ratio': 1.0}, 'post_yield_ratio'),
    ({'post_yield_ratio': math.nan}, 'post_yield_ratio'),
    ({'exponent': 0.0}, 'exponent'),
    ({'exponent': 'two'}, 'exponent'),
    ({'beta': -1.0}, 'beta'),
    ({'beta': 1.0, 'gamma': -1.0}, 'beta \\+ gamma'),
    ({'gamma': math.inf}, 'gamma'),
    ({'a0': 0.0}, 'a0'),
    ({'delta_a': -1e-6}, 'delta_a'),
    ({'delta_nu': math.nan}, 'delta_nu'),
    ({'delta_eta': -1.0}, 'delta_eta'),
    ({'tolerance': 0.0}, 'tolerance'),
    ({'tolerance': 1.0}, 'tolerance'),
    ({'max_iterations': 0}, 'max_iterations'),
    ({'max_iterations': 2.5}, 'max_iterations'),
    ({'max_iterations': True}, 'max_iterations'),
])
def test_bad_parameters(kwargs: dict[str, Any], name: str) -> None:
    with pytest.raises(HysteresisError, match=f'^BoucWen: {name} '):
        model(1.0, **kwargs)


def test_bad_displacement() -> None:
    with pytest.raises(HysteresisError, match='finite'):
        model().set_trial_displacement(math.nan)


# --- OpenSees ---------------------------------------------------------------------------------

CASES = {
    'degrading n=1.5': {'exponent': 1.5, 'a0': 1.0, 'delta_a': 1e-4, 'delta_nu': 2e-4,
                        'delta_eta': 2e-4},
    'degrading n=1': {'exponent': 1.0, 'a0': 1.1, 'delta_a': 5e-5, 'delta_nu': 1e-4,
                      'delta_eta': 3e-4},
    'plain n=1': {'exponent': 1.0, 'a0': 1.0, 'delta_a': 0.0, 'delta_nu': 0.0,
                  'delta_eta': 0.0},
    'plain n=2': {'exponent': 2.0, 'a0': 1.0, 'delta_a': 0.0, 'delta_nu': 0.0,
                  'delta_eta': 0.0},
}


def case_params(name: str) -> dict[str, float]:
    case = CASES[name]
    n = case['exponent']
    params = {'stiffness': K, 'post_yield_ratio': ALPHA, **case, **shape(n)}
    if name == 'plain n=2':  # unequal β, γ (γ < β): a fuller loop
        params.update(beta=0.7 / DY ** n, gamma=0.3 / DY ** n)
    return params


def boucwen_arguments(params: dict[str, float]) -> list[object]:
    """``uniaxialMaterial BoucWen tag alpha ko n gamma beta Ao deltaA deltaNu deltaEta``."""
    return ['BoucWen', 1, params['post_yield_ratio'], params['stiffness'], params['exponent'],
            params['gamma'], params['beta'], params['a0'], params['delta_a'],
            params['delta_nu'], params['delta_eta']]


@cache
def opensees_results() -> dict[str, dict[str, np.ndarray]]:
    """Stress and tangent histories from OpenSees for every case (one child process)."""
    if not opensees_available():
        pytest.skip('openseespy cannot be imported')
    responses = opensees_responses([boucwen_arguments(case_params(name)) for name in CASES],
                                   opensees_path())
    return {name: {'stress': stress, 'tangent': tangent}
            for name, (stress, tangent) in zip(CASES, responses, strict=True)}


@pytest.mark.parametrize('name', list(CASES))
def test_matches_opensees(name: str) -> None:
    reference = opensees_results()[name]
    ours = model(**case_params(name))
    path = opensees_path()
    forces, tangents = [], []
    for x in path:
        forces.append(ours.set_trial_displacement(float(x)))
        tangents.append(ours.tangent)
        ours.commit()
    stress = np.array(reference['stress'])
    peak = float(np.max(np.abs(stress)))
    assert peak > 0.8 * (1.0 - ALPHA) * K * DY  # well into the nonlinear range
    force_error = float(np.max(np.abs(np.array(forces) - stress))) / peak
    tangent_error = float(np.max(np.abs(np.array(tangents) - np.array(reference['tangent'])))
                          ) / K
    print(f'{name}: max |f - f_OpenSees| / max |f| = {force_error:.3g}, '
          f'max |kt - kt_OpenSees| / k = {tangent_error:.3g}')
    assert force_error <= 1e-10
    assert tangent_error <= 1e-10
    if name.startswith('degrading'):
        assert ours.hysteretic_energy > 0.0
