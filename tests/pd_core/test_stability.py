"""Stability and accuracy of the Newmark explicit scheme (thesis §3.3.1, eqs. 3.7-3.19)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from pd_core.dynamics.stability import (
    StabilityReport,
    check_stability,
    period_distortion,
    period_error,
    period_shrinkage,
    require_stable,
    spectral_radius,
)
from pd_core.errors import ConfigError, StabilityError
from pd_core.schemes import (
    NewmarkExplicit,
    amplification_matrix_newmark_explicit,
    newmark_explicit_numerical_frequency,
)

M_THESIS = 2543.4
K_THESIS = 312559.0


def free_vibration(omega_dt: float, n_steps: int, dt: float = 0.01) -> np.ndarray:
    """Undamped linear SDOF free vibration from x0 = 1, v0 = 0 at the given Omega."""
    m = 10.0
    k = m * (omega_dt / dt) ** 2
    integrator = NewmarkExplicit(m, 0.0, dt)
    integrator.initialize(1.0, 0.0, 0.0, k * 1.0)
    xs = np.empty(n_steps + 1)
    xs[0] = 1.0
    for i in range(1, n_steps + 1):
        target = integrator.predict()
        integrator.correct(k * float(target[0]), 0.0)
        integrator.commit()
        xs[i] = integrator.x[0]
    return xs


# --------------------------------------------------------------------------- growth / bounds


@pytest.mark.parametrize('omega_dt', [2.05, 2.2, 3.0])
def test_response_grows_without_bound_above_the_limit(omega_dt: float) -> None:
    xs = free_vibration(omega_dt, 100)
    assert np.max(np.abs(xs)) > 1e3
    # Growth rate per step is the real root of eq. 3.10 with |lambda| > 1.
    a = 1.0 - omega_dt**2 / 2.0
    rate = abs(a) + math.sqrt(a * a - 1.0)
    measured = (abs(xs[100]) / abs(xs[80])) ** (1 / 20)
    assert measured == pytest.approx(rate, rel=1e-6)


@pytest.mark.parametrize('omega_dt', [0.5, 1.0, 1.9, 1.99])
def test_response_stays_bounded_below_the_limit(omega_dt: float) -> None:
    xs = free_vibration(omega_dt, 10_000)
    # No numerical damping either (eq. 3.15 gives zeta_bar = 0): the amplitude is kept.
    assert np.max(np.abs(xs)) <= 1.0 + 1e-9
    assert np.max(np.abs(xs[-200:])) > 0.9


# --------------------------------------------------------------------------- eq. 3.7


def test_amplification_matrix_matches_eq_3_7_entries() -> None:
    w, dt = 7.0, 0.03
    a = amplification_matrix_newmark_explicit(w * dt, dt=dt)
    expected = np.array(
        [
            [1, dt, dt**2 / 2],
            [-(w**2) * dt / 2, 1 - w**2 * dt**2 / 2, dt / 2 - w**2 * dt**3 / 4],
            [-(w**2), -(w**2) * dt, -(w**2) * dt**2 / 2],
        ]
    )
    np.testing.assert_allclose(a, expected, rtol=1e-14, atol=0)


def test_amplification_matrix_reproduces_one_integrator_step() -> None:
    m, dt, omega_dt = 3.0, 0.02, 0.7
    k = m * (omega_dt / dt) ** 2
    integrator = NewmarkExplicit(m, 0.0, dt)
    integrator.initialize(0.01, -0.4, 0.0, k * 0.01)
    state = np.array([integrator.x[0], integrator.v[0], integrator.a[0]])
    target = integrator.predict()
    integrator.correct(k * float(target[0]), 0.0)
    integrator.commit()
    after = np.array([integrator.x[0], integrator.v[0], integrator.a[0]])
    expected = amplification_matrix_newmark_explicit(omega_dt, dt=dt) @ state
    np.testing.assert_allclose(after, expected, rtol=1e-12)


@pytest.mark.parametrize('omega_dt', [1e-3, 0.1, 0.5, 1.0, 1.5, 1.9, 1.99])
def test_spectral_radius_is_one_below_the_limit(omega_dt: float) -> None:
    for dt in (1.0, 0.01, 0.37):
        rho = spectral_radius(amplification_matrix_newmark_explicit(omega_dt, dt=dt))
        assert abs(rho - 1.0) <= 1e-12


@pytest.mark.parametrize('omega_dt', [2.01, 2.05, 2.2, 3.0, 10.0])
def test_spectral_radius_exceeds_one_above_the_limit(omega_dt: float) -> None:
    a = 1.0 - omega_dt**2 / 2.0
    expected = abs(a) + math.sqrt(a * a - 1.0)
    for dt in (1.0, 0.01):
        rho = spectral_radius(amplification_matrix_newmark_explicit(omega_dt, dt=dt))
        assert rho > 1.0
        assert rho == pytest.approx(expected, rel=1e-10)


def test_spectral_radius_of_a_known_matrix() -> None:
    assert spectral_radius(np.array([[0.0, -2.0], [2.0, 0.0]])) == pytest.approx(2.0)
    assert spectral_radius(np.diag([0.5, -3.0, 1.0])) == pytest.approx(3.0)


# --------------------------------------------------------------------------- eq. 3.19


@pytest.mark.parametrize('omega_dt', [1e-4, 0.05, 0.5, 1.0, 1.4, 1.5, 1.9, 1.999, 2.0])
def test_numerical_frequency_matches_independent_forms(omega_dt: float) -> None:
    omega_bar = newmark_explicit_numerical_frequency(omega_dt)
    # cos(Omega_bar) = A = 1 - Omega^2/2 (eq. 3.11, |lambda| = 1) on the branch [0, pi].
    assert omega_bar == pytest.approx(2.0 * math.asin(omega_dt / 2.0), rel=1e-12)
    assert math.cos(omega_bar) == pytest.approx(1.0 - omega_dt**2 / 2.0, abs=1e-12)
    # ... and the angle of the principal eigenvalue of eq. 3.7.
    if omega_dt < 2.0:
        eigenvalues = np.linalg.eigvals(amplification_matrix_newmark_explicit(omega_dt))
        principal = eigenvalues[np.abs(eigenvalues) > 0.5]  # drop the spurious root 0
        assert principal.size == 2
        assert omega_bar == pytest.approx(float(np.max(np.angle(principal))), rel=1e-9)


def test_numerical_frequency_uses_the_obtuse_branch_above_sqrt2() -> None:
    # The bare arctan(B/A) of eq. 3.19 would give a negative angle here.
    assert newmark_explicit_numerical_frequency(1.8) > math.pi / 2
    assert newmark_explicit_numerical_frequency(2.0) == pytest.approx(math.pi)
    assert newmark_explicit_numerical_frequency(0.0) == 0.0


@pytest.mark.parametrize('omega_dt', [2.0000001, 2.5, math.inf, -0.1, math.nan])
def test_numerical_frequency_is_nan_outside_the_stable_range(omega_dt: float) -> None:
    assert math.isnan(newmark_explicit_numerical_frequency(omega_dt))
    assert math.isnan(period_distortion(omega_dt))
    assert math.isnan(period_shrinkage(omega_dt))


@pytest.mark.parametrize('omega_dt', [0.1, 0.3, 0.7, 1.2, 1.6])
def test_measured_period_from_zero_crossings_matches_eq_3_19(omega_dt: float) -> None:
    n_steps = 20_000
    xs = free_vibration(omega_dt, n_steps)
    # Zero crossings by linear interpolation between samples, in units of steps.
    i = np.nonzero(np.sign(xs[:-1]) != np.sign(xs[1:]))[0]
    crossings = i + xs[i] / (xs[i] - xs[i + 1])
    assert crossings.size > 20
    half_period = np.polyfit(np.arange(crossings.size), crossings, 1)[0]
    measured_omega_bar = math.pi / half_period
    expected = newmark_explicit_numerical_frequency(omega_dt)
    assert measured_omega_bar == pytest.approx(expected, rel=1e-3)
    assert measured_omega_bar > omega_dt * (1 + 1e-4)  # visibly faster than exact


def test_period_shrinks_and_matches_figure_3_2_order_of_magnitude() -> None:
    omega_dt = 2.0 * math.pi * 0.05  # dt/T = 0.05, the thesis's accuracy threshold
    distortion = period_distortion(omega_dt)
    shrinkage = period_shrinkage(omega_dt)
    assert distortion < 0.0 < shrinkage  # T_bar < T
    assert shrinkage == -distortion
    assert period_error(omega_dt) == shrinkage  # thesis (T - T_bar)/T
    # Independent: cos(Omega_bar) = 1 - Omega^2/2, T_bar/T = Omega/Omega_bar.
    omega_bar = math.acos(1.0 - omega_dt**2 / 2.0)
    assert distortion == pytest.approx(omega_dt / omega_bar - 1.0, rel=1e-9)
    assert -1e-2 < distortion < -1e-3  # about -0.4 %: a fraction of a percent
    assert distortion == pytest.approx(-(omega_dt**2) / 24.0, rel=0.02)  # leading term


def test_period_distortion_vanishes_as_dt_goes_to_zero_and_grows_monotonically() -> None:
    ratios = np.linspace(1e-4, 0.3, 60)  # dt/T
    shrinkage = np.array([period_shrinkage(2 * math.pi * r) for r in ratios])
    assert np.all(np.diff(shrinkage) > 0)
    assert shrinkage[0] < 1e-6
    assert period_distortion(0.0) == 0.0
    # At the limit Omega = 2, Omega_bar = pi: T_bar/T = 2/pi.
    assert period_shrinkage(2.0) == pytest.approx(1.0 - 2.0 / math.pi)


# --------------------------------------------------------------------------- check_stability


def test_check_stability_accepts_the_thesis_defaults() -> None:
    report = check_stability('newmark_explicit', M_THESIS, K_THESIS, 0.01)
    assert isinstance(report, StabilityReport)
    omega = math.sqrt(K_THESIS / M_THESIS)
    assert report.omega_max == pytest.approx(omega, rel=1e-14)
    assert report.omega_dt == pytest.approx(omega * 0.01, rel=1e-14)
    assert round(report.omega_dt, 4) == 0.1109
    assert report.stable is True
    assert report.limit == 2.0
    assert report.scheme == 'newmark_explicit'
    assert report.period_distortion == pytest.approx(-(report.omega_dt**2) / 24.0, rel=1e-2)
    assert '0.110856' in report.message and 'stable' in report.message
    assert '\n' not in report.message
    assert require_stable(report) is report


def test_check_stability_accepts_a_class_or_an_instance() -> None:
    by_class = check_stability(NewmarkExplicit, M_THESIS, K_THESIS, 0.01)
    by_instance = check_stability(NewmarkExplicit(M_THESIS, 0.0, 0.01), M_THESIS, K_THESIS, 0.01)
    assert by_class == by_instance == check_stability('newmark_explicit', M_THESIS, K_THESIS, 0.01)


def test_check_stability_refuses_omega_dt_above_two() -> None:
    omega = math.sqrt(K_THESIS / M_THESIS)
    dt = 2.2 / omega
    report = check_stability('newmark_explicit', M_THESIS, K_THESIS, dt)
    assert report.stable is False
    assert math.isnan(report.period_distortion)
    assert report.max_stable_dt == pytest.approx(2.0 / omega)
    assert 'UNSTABLE' in report.message
    with pytest.raises(StabilityError) as info:
        require_stable(report)
    message = str(info.value)
    assert isinstance(info.value, ValueError)
    assert message.startswith('dt')
    assert f'{2.0 / omega:.6g}' in message
    assert '\n' not in message


def test_omega_dt_exactly_at_the_limit_counts_as_stable() -> None:
    # Eq. 3.14: 0 <= omega dt <= 2 (the thesis calls Omega = 2 stable but inaccurate).
    report = check_stability('newmark_explicit', 1.0, 4.0, 1.0)  # omega = 2, dt = 1
    assert report.omega_dt == 2.0
    assert report.stable is True


def test_check_stability_uses_the_highest_mode_of_an_mdof() -> None:
    mass = np.diag([3.0e4, 2.5e4, 2.0e4])
    k1, k2, k3 = 6.0e7, 4.5e7, 3.0e7
    stiffness = np.array([[k1 + k2, -k2, 0.0], [-k2, k2 + k3, -k3], [0.0, -k3, k3]])
    w_max = math.sqrt(scipy.linalg.eigh(stiffness, mass, eigvals_only=True)[-1])
    stable = check_stability('newmark_explicit', mass, stiffness, 1.9 / w_max)
    assert stable.omega_max == pytest.approx(w_max, rel=1e-12)
    assert stable.stable
    unstable = check_stability('newmark_explicit', mass, stiffness, 2.1 / w_max)
    assert not unstable.stable
    with pytest.raises(StabilityError, match='dt'):
        require_stable(unstable)


@pytest.mark.parametrize('dt', [0.0, -0.01, math.nan, math.inf])
def test_check_stability_rejects_bad_dt(dt: float) -> None:
    with pytest.raises(ConfigError, match='dt'):
        check_stability('newmark_explicit', M_THESIS, K_THESIS, dt)


def test_check_stability_rejects_unknown_schemes() -> None:
    with pytest.raises(ConfigError, match='newmark_explicit'):
        check_stability('leapfrog', M_THESIS, K_THESIS, 0.01)
