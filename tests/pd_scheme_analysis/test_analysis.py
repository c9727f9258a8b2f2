"""Spectral stability and accuracy analysis (thesis §3.3.1, eqs. 3.4-3.19, Figure 3.2)."""

from __future__ import annotations

import csv
import math
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.linalg

from pd_core.dynamics import analysis
from pd_core.dynamics.analysis import (
    SWEEP_COLUMNS,
    SpectralProperties,
    expected_period_error,
    has_amplification_matrix,
    spectral_properties,
    sweep,
)
from pd_core.dynamics.stability import (
    check_stability,
    period_distortion,
    period_shrinkage,
)
from pd_core.errors import ConfigError
from pd_core.schemes import (
    SCHEMES,
    Integrator,
    NewmarkExplicit,
    SchemeParameter,
    amplification_matrix_newmark_explicit,
    make_integrator,
    newmark_explicit_numerical_frequency,
    numerical_schemes,
)
from pd_scheme_analysis import analyze
from pd_scheme_analysis.figures import write_sweep_csv
from support.spectra import assert_same_spectrum

OMEGA = 3.0  # rad/s of the free-vibration SDOF (m = 1, k = OMEGA**2)
NE_GRID = [1e-3, 0.01, 0.1, 0.3, 0.7, 1.0, 1.2, math.sqrt(2.0), 1.5, 1.8, 1.95, 1.999]


# --------------------------------------------------------------------------- test schemes


class _Synthetic(Integrator):
    """A scheme known only by its amplification matrix: the exact one-step transition of the
    damped SDOF scaled by ``scale`` (``scale < 1`` adds a known dissipation), plus an optional
    real spurious root."""

    name = 'synthetic'

    def _setup(self) -> None:
        pass

    def _initial_acceleration(self, x0: Any, v0: Any, p0: Any, r0: Any) -> Any:
        return 0.0

    def _predict(self) -> Any:
        return self._x

    def _correct(self, restoring_force: Any, load: Any) -> tuple[Any, Any]:
        return self._a, self._v

    PARAMETERS = (SchemeParameter('scale', 1.0, 'a scale', low=0.0, high=2.0),
                  SchemeParameter('spurious', None, 'a spurious root', low=-2.0, high=2.0))

    @classmethod
    def _amplification(cls, omega_dt: float, xi: float, parameters: Mapping[str, Any]
                       ) -> np.ndarray:
        exact = scipy.linalg.expm(np.array([[0.0, 1.0],
                                            [-omega_dt**2, -2.0 * xi * omega_dt]]))
        matrix = parameters['scale'] * exact
        if parameters['spurious'] is not None:
            matrix = scipy.linalg.block_diag(matrix, [[parameters['spurious']]])
        return matrix


class _Lossy(_Synthetic):
    """An instance whose parameters add dissipation (``scale = 0.99``)."""

    @property
    def parameters(self) -> dict[str, Any]:
        return {'scale': 0.99}


class _Growing(_Synthetic):
    """An instance whose parameters make the spectrum unstable (``scale = 1.01``)."""

    @property
    def parameters(self) -> dict[str, Any]:
        return {'scale': 1.01}


class _Diagonal(_Synthetic):
    """Real roots only: a non-oscillatory recursion."""

    name = 'diagonal'

    PARAMETERS = (SchemeParameter('first', 0.5, 'first root', low=-2.0, high=2.0),
                  SchemeParameter('second', 0.3, 'second root', low=-2.0, high=2.0))

    @classmethod
    def _amplification(cls, omega_dt: float, xi: float, parameters: Mapping[str, Any]
                       ) -> np.ndarray:
        return np.diag([parameters['first'], parameters['second'], 0.0])


class _Opaque(_Synthetic):
    """A scheme without an amplification matrix."""

    name = 'opaque'

    PARAMETERS = ()

    @classmethod
    def _amplification(cls, omega_dt: float, xi: float, parameters: Mapping[str, Any]
                       ) -> np.ndarray:
        raise NotImplementedError('opaque')


@pytest.fixture
def synthetic() -> Iterator[None]:
    with (SCHEMES.added(_Synthetic.name, _Synthetic), SCHEMES.added(_Diagonal.name, _Diagonal),
          SCHEMES.added(_Opaque.name, _Opaque)):
        yield


# --------------------------------------------------------------------------- Newmark explicit


@pytest.mark.parametrize('omega_dt', NE_GRID)
def test_newmark_explicit_frequency_equals_eq_3_19(omega_dt: float) -> None:
    p = spectral_properties('newmark_explicit', omega_dt)
    # Eq. 3.19 / 3.11: cos(Omega_bar) = 1 - Omega^2/2 on [0, pi], i.e. 2 asin(Omega/2).
    closed = 2.0 * math.asin(omega_dt / 2.0)
    assert abs(p.numerical_frequency - closed) <= 1e-12 * closed
    assert abs(math.cos(p.numerical_frequency) - (1.0 - omega_dt**2 / 2.0)) <= 1e-12
    assert p.numerical_frequency == pytest.approx(
        newmark_explicit_numerical_frequency(omega_dt), rel=1e-12)
    assert abs(p.spectral_radius - 1.0) <= 1e-12
    assert abs(p.principal_radius - 1.0) <= 1e-12
    assert abs(p.numerical_damping) <= 1e-12  # eq. 3.15: no numerical damping
    assert p.stable
    assert p.period_error == pytest.approx(omega_dt / closed - 1.0, abs=1e-12)
    assert p.period_shrinkage == -p.period_error


def test_newmark_explicit_dense_grid_equals_eq_3_19() -> None:
    omegas = np.concatenate([np.geomspace(1e-3, 1e-2, 20, endpoint=False),
                             np.linspace(0.01, 1.999, 2000)])
    result = sweep('newmark_explicit', omegas)
    closed = 2.0 * np.arcsin(omegas / 2.0)
    assert np.max(np.abs(result['numerical_frequency'] / closed - 1.0)) <= 1e-12
    assert np.max(np.abs(np.cos(result['numerical_frequency']) - (1.0 - omegas**2 / 2.0))) \
        <= 1e-12
    assert np.max(np.abs(result['spectral_radius'] - 1.0)) <= 1e-12
    assert np.max(np.abs(result['numerical_damping'])) <= 1e-12
    assert np.all(result['stable'])


@pytest.mark.parametrize('omega_dt', [2.0001, 2.05, 2.5, 3.0, 4.0])
def test_newmark_explicit_beyond_the_limit(omega_dt: float) -> None:
    p = spectral_properties('newmark_explicit', omega_dt)
    a = 1.0 - omega_dt**2 / 2.0
    assert p.spectral_radius == pytest.approx(abs(a) + math.sqrt(a * a - 1.0), rel=1e-10)
    assert p.spectral_radius > 1.0
    assert not p.stable
    # Beyond the bifurcation the principal roots are real: no period.
    assert not p.oscillatory
    assert math.isnan(p.period_error) and math.isnan(p.numerical_damping)
    assert math.isnan(expected_period_error('newmark_explicit', omega_dt))


def test_newmark_explicit_at_the_limit_is_stable_with_a_two_step_period() -> None:
    p = spectral_properties('newmark_explicit', 2.0)  # eq. 3.14 counts Omega = 2 as stable
    assert p.stable
    assert p.numerical_frequency == pytest.approx(math.pi, abs=1e-6)
    assert p.period_shrinkage == pytest.approx(1.0 - 2.0 / math.pi, abs=1e-6)


def test_figure_3_2_period_shrinkage() -> None:
    ratios = np.linspace(1e-3, 0.3, 300)  # dt/T, the thesis's abscissa
    result = sweep('newmark_explicit', 2.0 * math.pi * ratios)
    np.testing.assert_allclose(result['dt_over_T'], ratios, rtol=1e-15)
    shrinkage = result['period_shrinkage']
    closed = [period_shrinkage(2.0 * math.pi * r) for r in ratios]
    np.testing.assert_allclose(shrinkage, closed, rtol=1e-10, atol=1e-13)
    assert np.all(shrinkage > 0.0) and np.all(np.diff(shrinkage) > 0.0)
    # Leading term Omega^2/24; about 0.4 % at the thesis's dt/T = 0.05 threshold.
    at_005 = float(np.interp(0.05, ratios, shrinkage))
    assert at_005 == pytest.approx((2.0 * math.pi * 0.05) ** 2 / 24.0, rel=0.02)
    assert shrinkage[-1] == pytest.approx(1.0 - 0.6 * math.pi / (2.0 * math.asin(0.3 * math.pi)),
                                          rel=1e-10)


def test_damped_newmark_explicit_matrix_reproduces_one_integrator_step() -> None:
    xi, omega_dt, dt = 0.07, 0.9, 0.02
    w = omega_dt / dt
    integrator = NewmarkExplicit(1.0, 2.0 * xi * w, dt)
    integrator.initialize(0.01, -0.4, 0.0, w * w * 0.01)
    before = np.array([integrator.x[0], integrator.v[0], integrator.a[0]])
    target = integrator.predict()
    integrator.correct(w * w * float(target[0]), 0.0)
    integrator.commit()
    after = np.array([integrator.x[0], integrator.v[0], integrator.a[0]])
    matrix = amplification_matrix_newmark_explicit(omega_dt, dt=dt, xi=xi)
    np.testing.assert_allclose(after, matrix @ before, rtol=1e-12)
    # Same spectrum through the analysis (the dt-normalised form is similar).
    assert_same_spectrum(
        np.linalg.eigvals(analysis.amplification_matrix('newmark_explicit', omega_dt, xi)),
        np.linalg.eigvals(matrix), atol=1e-12)


# --------------------------------------------------------------------------- conventions


@pytest.mark.parametrize('xi', [0.0, 0.05, 0.3])
@pytest.mark.parametrize('omega_dt', [0.01, 0.5, 1.5, 2.5])
def test_exact_integrator_has_no_period_error_and_only_viscous_damping(
        synthetic: None, xi: float, omega_dt: float) -> None:
    p = spectral_properties('synthetic', omega_dt, xi, spurious=0.2)
    assert p.period_error == pytest.approx(0.0, abs=1e-12)
    assert p.algorithmic_damping == pytest.approx(0.0, abs=1e-12)
    # Total damping under eq. 3.15 of the exact root exp((-xi +- i sqrt(1-xi^2)) Omega).
    assert p.numerical_damping == pytest.approx(xi / math.sqrt(1.0 - xi * xi), rel=1e-10,
                                                abs=1e-13)
    assert p.decay_per_cycle == pytest.approx(
        math.exp(-2.0 * math.pi * xi / math.sqrt(1.0 - xi * xi)), rel=1e-10)
    assert p.principal_radius == pytest.approx(math.exp(-xi * omega_dt), rel=1e-12)
    assert p.spectral_radius == pytest.approx(max(math.exp(-xi * omega_dt), 0.2), rel=1e-12)


def test_algorithmic_dissipation_is_separated_from_the_viscous_part(synthetic: None) -> None:
    omega_dt, xi, scale = 0.8, 0.05, 0.97
    p = spectral_properties('synthetic', omega_dt, xi, scale=scale)
    omega_d = omega_dt * math.sqrt(1.0 - xi * xi)
    assert p.numerical_frequency == pytest.approx(omega_d, rel=1e-12)
    assert p.numerical_damping == pytest.approx((xi * omega_dt - math.log(scale)) / omega_d,
                                                rel=1e-12)
    assert p.algorithmic_damping == pytest.approx(-math.log(scale) / omega_d, rel=1e-10)


def test_the_spurious_root_is_excluded_but_counts_for_stability(synthetic: None) -> None:
    p = spectral_properties('synthetic', 0.5, 0.0, spurious=-1.3)
    assert p.principal_radius == pytest.approx(1.0, abs=1e-12)
    assert p.numerical_damping == pytest.approx(0.0, abs=1e-12)
    assert p.spectral_radius == pytest.approx(1.3)
    assert not p.stable


def test_real_principal_roots_have_no_period(synthetic: None) -> None:
    p = spectral_properties('diagonal', 1.0)
    assert p.stable and not p.oscillatory
    assert p.spectral_radius == pytest.approx(0.5)
    for value in (p.numerical_frequency, p.numerical_damping, p.period_error,
                  p.period_shrinkage, p.principal_radius):
        assert math.isnan(value)
    assert not spectral_properties('diagonal', 1.0, first=-1.2).stable
    # Coincident negative roots: the two-step oscillation at the bifurcation.
    at_bifurcation = spectral_properties('diagonal', 1.0, first=-0.8, second=-0.8)
    assert at_bifurcation.numerical_frequency == pytest.approx(math.pi)
    assert at_bifurcation.numerical_damping == pytest.approx(-math.log(0.8) / math.pi)


def test_omega_zero_gives_the_limit_values() -> None:
    p = spectral_properties('newmark_explicit', 0.0, 0.05)
    assert p.period_error == 0.0 and p.algorithmic_damping == 0.0
    assert p.numerical_damping == pytest.approx(0.05 / math.sqrt(1 - 0.05**2))
    assert period_distortion(0.0) == 0.0


def test_errors_name_the_scheme_and_the_parameter(synthetic: None) -> None:
    with pytest.raises(ConfigError, match="'leapfrog'"):
        spectral_properties('leapfrog', 0.5)
    with pytest.raises(ConfigError, match="'rho_inf'"):
        spectral_properties('synthetic', 0.5, rho_inf=0.5)
    with pytest.raises(ConfigError, match="'rho_inf'"):
        spectral_properties('newmark_explicit', 0.5, rho_inf=0.5)
    with pytest.raises(ConfigError, match='opaque'):
        spectral_properties('opaque', 0.5)
    with pytest.raises(ConfigError, match='xi'):
        spectral_properties('newmark_explicit', 0.5, 1.0)
    with pytest.raises(ConfigError, match='omega_dt'):
        spectral_properties('newmark_explicit', -0.5)
    assert not has_amplification_matrix('opaque')
    assert has_amplification_matrix('synthetic')
    assert math.isnan(expected_period_error('opaque', 0.5))


# --------------------------------------------------------------------------- stability report


def test_report_period_distortion_comes_from_the_analysis(synthetic: None) -> None:
    report = check_stability('newmark_explicit', 2543.4, 312559.0, 0.01)
    assert report.period_distortion == pytest.approx(period_distortion(report.omega_dt),
                                                     rel=1e-10)
    assert report.period_distortion == pytest.approx(
        expected_period_error('newmark_explicit', report.omega_dt), rel=1e-12)
    assert abs(report.numerical_damping) < 1e-12
    assert 'numerical damping' not in report.message
    # Another scheme: the period and the damping come from its amplification matrix.
    lossless = check_stability('synthetic', 1.0, 4.0, 0.25)  # omega = 2, Omega = 0.5
    assert lossless.omega_dt == 0.5
    assert lossless.period_distortion == pytest.approx(0.0, abs=1e-12)
    assert period_distortion(0.5, 'synthetic') == pytest.approx(0.0, abs=1e-12)
    # The parameters of an instance are used: a dissipative one reports its damping.
    damped = check_stability(_Lossy(1.0, 0.0, 0.25), 1.0, 4.0, 0.25)
    assert damped.period_distortion == pytest.approx(0.0, abs=1e-12)
    assert damped.numerical_damping == pytest.approx(-math.log(0.99) / 0.5, rel=1e-10)
    assert 'numerical damping 2 %' in damped.message
    # A declared limit that the spectrum contradicts is flagged; no period is promised.
    growing = check_stability(_Growing(1.0, 0.0, 0.25), 1.0, 4.0, 0.25)
    assert growing.stable  # the declared limit decides (infinite here)
    assert math.isnan(growing.period_distortion) and math.isnan(growing.numerical_damping)
    assert 'spectral radius is 1.01 > 1' in growing.message
    # No amplification matrix: NaN, and the message has no distortion.
    opaque = check_stability('opaque', 1.0, 4.0, 0.25)
    assert math.isnan(opaque.period_distortion) and math.isnan(opaque.numerical_damping)
    assert 'period distortion' not in opaque.message


@pytest.mark.parametrize('name', sorted(numerical_schemes()))
def test_report_matches_the_analysis_for_every_registered_scheme(name: str) -> None:
    if not has_amplification_matrix(name):
        pytest.skip(f'{name} has no amplification_matrix')
    omega_dt = 0.3
    report = check_stability(name, 1.0, 1.0, omega_dt)
    assert report.stable
    properties = spectral_properties(name, omega_dt)
    assert properties.stable
    assert report.period_distortion == pytest.approx(properties.period_error, rel=1e-12)
    assert report.numerical_damping == pytest.approx(properties.numerical_damping, rel=1e-12,
                                                     abs=1e-15)
    assert report.period_distortion < 0.02  # a scheme in use is accurate at Omega = 0.3


# --------------------------------------------------------------------------- free vibration


def free_vibration(name: str, omega_dt: float, xi: float, n_steps: int | None = None
                   ) -> np.ndarray:
    """``x_n`` of the linear SDOF ``r = ω² x`` from ``x0 = 1``, by the integrator itself.

    Many cycles by default; stops early before the amplitude underflows or overflows.
    """
    integrator = make_integrator(name, mass=1.0, damping=2.0 * xi * OMEGA, dt=omega_dt / OMEGA,
                                 initial_stiffness=OMEGA**2)
    k = OMEGA**2
    integrator.initialize(1.0, 0.0, 0.0, k * 1.0)
    if n_steps is None:
        n_steps = max(1000, int(40 * 2.0 * math.pi / omega_dt))
    xs = [1.0]
    for _ in range(n_steps):
        while True:  # an implicit scheme iterates within the step
            target = integrator.predict()
            integrator.correct(k * float(target[0]), 0.0)
            if integrator.phase == 'corrected':
                break
        integrator.commit()
        x = float(integrator.x[0])
        xs.append(x)
        amplitude = math.hypot(x, float(integrator.v[0]) / OMEGA)
        if not 1e-200 < amplitude < 1e200:
            break
    return np.array(xs)


def measure(xs: np.ndarray) -> tuple[float, float]:
    """Period in steps (zero crossings) and decay per cycle (log decrement of the peaks)."""
    skip = len(xs) // 10  # let the spurious roots die out
    tail = xs[skip:]
    i = np.nonzero(np.sign(tail[:-1]) * np.sign(tail[1:]) < 0)[0]
    crossings = i + tail[i] / (tail[i] - tail[i + 1])
    assert crossings.size > 40, 'too few zero crossings'
    period = 2.0 * np.polyfit(np.arange(crossings.size), crossings, 1)[0]
    j = np.nonzero((tail[1:-1] > tail[:-2]) & (tail[1:-1] >= tail[2:]) & (tail[1:-1] > 0))[0] + 1
    assert j.size > 20, 'too few peaks'
    # Each peak from the parabola through its three samples, then ln(peak) against time: the
    # slope is the log decrement per step.
    before, at, after = tail[j - 1], tail[j], tail[j + 1]
    offset = 0.5 * (before - after) / (before - 2.0 * at + after)
    peaks = at - 0.25 * (before - after) * offset
    slope = np.polyfit(j + offset, np.log(peaks), 1)[0]
    return float(period), float(math.exp(slope * period))


def _free_vibration_cases() -> list[Any]:
    cases = []
    for name in sorted(numerical_schemes()):
        for xi in (0.0, 0.05):
            for omega_dt in (0.1, 0.5, 1.0, 1.8):
                cases.append(pytest.param(name, xi, omega_dt, id=f'{name}-xi{xi}-{omega_dt}'))
    return cases


def _limit(name: str, xi: float) -> float:
    """The stability limit the integrator declares for its default parameters and ``ξ``.

    Skips the test if the scheme refuses that damping, after checking that the analysis
    agrees that it is unstable there.
    """
    try:
        integrator = make_integrator(name, mass=1.0, damping=2.0 * xi, dt=1.0,
                                     initial_stiffness=1.0)
    except ConfigError as err:
        radius = sweep(name, np.linspace(0.01, 1.0, 100), xi)['spectral_radius']
        assert np.any(radius > 1.0 + analysis.STABILITY_TOLERANCE), (
            f'{name} refuses xi = {xi} although it is stable there: {err}')
        pytest.skip(f'{name} refuses xi = {xi} (unstable, as the analysis finds): {err}')
    return float(integrator.stability_limit)


@pytest.mark.parametrize(('name', 'xi', 'omega_dt'), _free_vibration_cases())
def test_free_vibration_matches_the_analysis(name: str, xi: float, omega_dt: float) -> None:
    if not has_amplification_matrix(name):
        pytest.skip(f'{name} has no amplification_matrix')
    limit = _limit(name, xi)
    if omega_dt == 1.8 and not omega_dt < limit:
        pytest.skip(f'{name}: Omega = 1.8 is not below its stability limit {limit:g}')
    predicted = spectral_properties(name, omega_dt, xi)
    if not predicted.stable:
        # The tool predicts growth: the integrator must grow at the spectral radius per step.
        n_steps = int(min(2000, 200 / math.log(predicted.spectral_radius)))
        xs = free_vibration(name, omega_dt, xi, n_steps)
        window = max(20, int(4 * math.pi / omega_dt))
        late = np.max(np.abs(xs[-window:]))
        early = np.max(np.abs(xs[-2 * window:-window]))
        assert (late / early) ** (1.0 / window) == pytest.approx(predicted.spectral_radius,
                                                                 rel=1e-3)
        return
    if not predicted.oscillatory:
        pytest.skip(f'{name}: the principal roots are real at Omega = {omega_dt}, xi = {xi}')
    period_steps, decay = measure(free_vibration(name, omega_dt, xi))
    exact_period_steps = 2.0 * math.pi / (omega_dt * math.sqrt(1.0 - xi * xi))
    measured_error = period_steps / exact_period_steps - 1.0
    assert 1.0 + measured_error == pytest.approx(1.0 + predicted.period_error, rel=1e-3)
    assert decay == pytest.approx(predicted.decay_per_cycle, rel=1e-3)
    assert predicted.decay_per_cycle == pytest.approx(
        math.exp(-2.0 * math.pi * predicted.numerical_damping), rel=1e-15)


@pytest.mark.parametrize('xi', [0.0, 0.05])
@pytest.mark.parametrize('name', sorted(numerical_schemes()))
def test_declared_stability_limit_agrees_with_the_spectrum(name: str, xi: float) -> None:
    """Below its declared limit a scheme is stable, with and without viscous damping (the
    thesis's test uses 5 %); check_stability relies on the declared limit."""
    if not has_amplification_matrix(name):
        pytest.skip(f'{name} has no amplification_matrix')
    limit = _limit(name, xi)
    omegas = np.linspace(0.01, min(limit, 10.0), 200)
    if math.isfinite(limit):
        omegas = omegas[:-1]  # the limit itself may be a double root on the unit circle
    radius = sweep(name, omegas, xi)['spectral_radius']
    unstable = omegas[radius > 1.0 + analysis.STABILITY_TOLERANCE]
    assert unstable.size == 0, (
        f'{name}, xi = {xi}: declared limit {limit:g} but rho = '
        f'{radius[radius > 1.0 + analysis.STABILITY_TOLERANCE][0]:.6g} > 1 at Omega = '
        f'{unstable[0]:.4g}')


def test_free_vibration_measurement_detects_a_wrong_prediction() -> None:
    # The measurement can fail: Newmark explicit is not the exact integrator.
    xs = free_vibration('newmark_explicit', 1.0, 0.05)
    period_steps, decay = measure(xs)
    exact_period_steps = 2.0 * math.pi / math.sqrt(1.0 - 0.05**2)
    assert abs(period_steps / exact_period_steps - 1.0) > 0.04  # about -4.6 %
    assert decay != pytest.approx(math.exp(-2.0 * math.pi * 0.05 / math.sqrt(1 - 0.05**2)),
                                  rel=1e-2)


# --------------------------------------------------------------------------- sweeps and files


def test_sweep_columns_and_csv_round_trip(tmp_path: Path, synthetic: None) -> None:
    omegas = analysis.omega_grid(4.0, 40)
    assert omegas[0] == pytest.approx(0.1) and omegas[-1] == 4.0
    first = sweep('newmark_explicit', omegas)
    second = sweep('newmark_explicit', omegas, 0.05)
    for key in (*SWEEP_COLUMNS, 'algorithmic_damping', 'numerical_frequency', 'stable', 'xi'):
        assert first[key].shape == omegas.shape
    assert np.all(first['stable'] == (omegas <= 2.0))
    path = write_sweep_csv([first, second], tmp_path / 'ne.csv')
    with path.open(encoding='utf-8') as stream:
        rows = list(csv.DictReader(stream))
    assert list(rows[0])[:len(SWEEP_COLUMNS)] == list(SWEEP_COLUMNS)
    assert len(rows) == 80
    assert float(rows[45]['xi']) == 0.05
    for key in SWEEP_COLUMNS:
        values = np.array([float(row[key]) for row in rows[:40]])
        np.testing.assert_array_equal(values, first[key])
    tagged = write_sweep_csv(
        [sweep('synthetic', omegas[:3], scale=s) for s in (0.9, 1.0)], tmp_path / 's.csv',
        parameters=[{'scale': 0.9}, {'scale': 1.0}])
    with tagged.open(encoding='utf-8') as stream:
        rows = list(csv.DictReader(stream))
    assert [row['scale'] for row in rows] == ['0.9'] * 3 + ['1.0'] * 3


def test_spectral_properties_is_a_frozen_record() -> None:
    p = spectral_properties('newmark_explicit', 0.5)
    assert isinstance(p, SpectralProperties)
    assert p.dt_over_T == pytest.approx(0.5 / (2.0 * math.pi))
    with pytest.raises(AttributeError):
        p.omega_dt = 1.0  # type: ignore[misc]


def _is_png(path: Path) -> bool:
    return path.is_file() and path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_cli_writes_the_tables_and_figures(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'spectra'
    assert analyze.main(['--points', '50', '--out', str(out)]) == 0  # defaults otherwise
    for name in ('spectral_radius.png', 'numerical_damping.png', 'period_error.png',
                 'figure_3_2_newmark_explicit.png'):
        assert _is_png(out / name), name
    stdout = capsys.readouterr().out
    for scheme in SCHEMES:
        if has_amplification_matrix(scheme):
            assert f'spectral_{scheme}.csv' in stdout
            with (out / f'spectral_{scheme}.csv').open(encoding='utf-8') as stream:
                rows = list(csv.DictReader(stream))
            assert list(rows[0])[:len(SWEEP_COLUMNS)] == list(SWEEP_COLUMNS)
            assert sorted({row['xi'] for row in rows}) == ['0.0', '0.05']  # default xi
            assert float(rows[49]['omega_dt']) == 4.0  # default omega-max
            assert len(rows) == 100
    ne = np.loadtxt(out / 'spectral_newmark_explicit.csv', delimiter=',', skiprows=1,
                    usecols=range(len(SWEEP_COLUMNS)), max_rows=50)
    np.testing.assert_array_equal(ne[:, 0], analysis.omega_grid(4.0, 50))


def test_cli_parameter_values_give_one_line_each(tmp_path: Path, synthetic: None) -> None:
    assert analyze.main(['--schemes', 'synthetic', '--param', 'synthetic:scale=0.9,1',
                         '--points', '10', '--xi', '0.0', '--no-figures',
                         '--out', str(tmp_path)]) == 0
    with (tmp_path / 'spectral_synthetic.csv').open(encoding='utf-8') as stream:
        rows = list(csv.DictReader(stream))
    assert [row['scale'] for row in rows] == ['0.9'] * 10 + ['1'] * 10
    assert not list(tmp_path.glob('*.png'))


@pytest.mark.parametrize(('argv', 'needle'), [
    (['--schemes', 'leapfrog'], "'leapfrog'"),
    (['--param', 'leapfrog:rho_inf=0.5'], "'leapfrog'"),
    (['--schemes', 'newmark_explicit', '--param', 'newmark_explicit:rho_inf=0.5'],
     "'rho_inf'"),
    (['--param', 'newmark_explicit-rho'], 'newmark_explicit-rho'),
    (['--xi', '1.5'], 'xi'),
])
def test_cli_errors_exit_2_with_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                         argv: list[str], needle: str) -> None:
    assert analyze.main([*argv, '--out', str(tmp_path / 'x')]) == 2
    err = capsys.readouterr().err
    assert needle in err
    assert err.count('\n') == 1
    assert not (tmp_path / 'x').exists()
