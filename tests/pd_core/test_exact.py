"""Exact reference solutions (core/exact.py) against closed forms and independent integrators."""

from __future__ import annotations

import math
import time
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg

from pd_core.dynamics.record_readers import read_ground_motion
from pd_core.dynamics.structure import damping_from_ratio
from pd_core.errors import ConfigError
from pd_core.verification import (
    EPPResponse,
    epp_exact,
    free_vibration,
    harmonic_response,
    modal_superposition,
    nigam_jennings,
    nigam_jennings_coefficients,
)
from pd_core.verification.nigam_jennings import transition_scalar

ELCENTRO = (
    Path(__file__).resolve().parents[2]
    / 'src/pd_integrator/data/ground_motions/elcentro_1940_ns_chopra.csv'
)


def relative_error(value: np.ndarray, reference: np.ndarray) -> float:
    """Largest absolute difference relative to the reference's peak."""
    return float(np.max(np.abs(value - reference)) / np.max(np.abs(reference)))


def piecewise_linear(rng: np.random.Generator, n: int, dt: float, refine: int) -> tuple:
    """Random breakpoints at ``dt`` and the same function sampled at ``dt/refine``."""
    values = rng.standard_normal(n)
    t = np.arange(n) * dt
    t_fine = np.arange((n - 1) * refine + 1) * (dt / refine)
    return values, np.interp(t_fine, t, values)


# --------------------------------------------------------------------------- Nigam-Jennings


@pytest.mark.parametrize('zeta', [0.0, 0.05, 0.3, 0.9])
@pytest.mark.parametrize('omega_dt', [0.01, 0.3, 0.7, 2.5])
def test_free_vibration_is_the_damped_closed_form(zeta: float, omega_dt: float) -> None:
    omega, x0, v0 = 7.3, 0.012, -0.2
    dt = omega_dt / omega
    n = max(200, int(6 * 2 * math.pi / omega / dt))
    x, v, a = nigam_jennings(omega, zeta, dt, np.zeros(n), x0, v0)
    t = np.arange(n) * dt
    wd = omega * math.sqrt(1 - zeta**2)
    # Chopra eq. 2.2.4, written out here independently of the module.
    big_b = (v0 + zeta * omega * x0) / wd
    decay = np.exp(-zeta * omega * t)
    x_ref = decay * (x0 * np.cos(wd * t) + big_b * np.sin(wd * t))
    v_ref = decay * (
        (wd * big_b - zeta * omega * x0) * np.cos(wd * t)
        - (wd * x0 + zeta * omega * big_b) * np.sin(wd * t)
    )
    scale = max(abs(x0), abs(v0) / omega)
    assert np.max(np.abs(x - x_ref)) < 1e-12 * scale
    assert np.max(np.abs(v - v_ref)) < 1e-12 * scale * omega
    assert np.max(np.abs(a + 2 * zeta * omega * v + omega**2 * x)) < 1e-12 * scale * omega**2
    x_fv, v_fv = free_vibration(omega, zeta, t, x0, v0)
    assert np.max(np.abs(x_fv - x_ref)) < 1e-14 * scale
    assert np.max(np.abs(v_fv - v_ref)) < 1e-14 * scale * omega


def _exact_transition(omega: float, zeta: float, dt: float, terms: int) -> list[float]:
    """e^{M dt} of the state (x, v, f, ḟ) summed in exact rational arithmetic."""
    w, z, h = Fraction(omega), Fraction(zeta), Fraction(dt)
    m = [[Fraction(0)] * 4 for _ in range(4)]
    m[0][1] = h
    m[1][0] = -w * w * h
    m[1][1] = -2 * z * w * h
    m[1][2] = h
    m[2][3] = h
    total = [[Fraction(int(i == j)) for j in range(4)] for i in range(4)]
    term = [row[:] for row in total]
    for j in range(1, terms):
        term = [
            [sum(term[i][q] * m[q][col] for q in range(4)) / j for col in range(4)]
            for i in range(4)
        ]
        total = [[total[i][col] + term[i][col] for col in range(4)] for i in range(4)]
    return [[float(value) for value in row] for row in total]


@pytest.mark.parametrize('omega_dt', [1e-3, 0.02, 0.49, 0.51, 1.3, 2.0])
@pytest.mark.parametrize('zeta', [0.0, 0.05, 0.6])
def test_coefficients_equal_the_exact_matrix_exponential(omega_dt: float, zeta: float) -> None:
    omega = 11.0
    dt = omega_dt / omega
    a, b = nigam_jennings_coefficients(omega, zeta, dt)
    e = _exact_transition(omega, zeta, dt, 45)
    # f(σ) = f_i + (f_{i+1} − f_i) σ/Δt  ⇒  B = [E[:, 2] − E[:, 3]/Δt, E[:, 3]/Δt].
    a_ref = np.array([[e[0][0], e[0][1]], [e[1][0], e[1][1]]])
    b_ref = np.array(
        [
            [e[0][2] - e[0][3] / dt, e[0][3] / dt],
            [e[1][2] - e[1][3] / dt, e[1][3] / dt],
        ]
    )
    assert np.allclose(a, a_ref, rtol=1e-14, atol=1e-15 * np.max(np.abs(a_ref)))
    for row in range(2):
        scale = np.max(np.abs(b_ref[row]))
        assert np.allclose(b[row], b_ref[row], rtol=1e-13, atol=1e-14 * scale)
    # The scalar transition used inside epp_exact: x(τ) = A y0 + p1 f0 + p2 s.
    scalar = transition_scalar(omega, zeta, dt)
    reference = [e[0][0], e[0][1], e[1][0], e[1][1], e[0][2], e[1][2], e[0][3], e[1][3]]
    for value, ref in zip(scalar, reference):
        assert value == pytest.approx(ref, rel=1e-13, abs=1e-16)


def test_coefficients_vectorise_over_modes() -> None:
    omegas = np.array([0.5, 3.0, 20.0, 150.0])
    zetas = np.array([0.0, 0.02, 0.1, 0.5])
    a, b = nigam_jennings_coefficients(omegas, zetas, 0.01)
    assert a.shape == b.shape == (4, 2, 2)
    for j in range(4):
        a1, b1 = nigam_jennings_coefficients(omegas[j], zetas[j], 0.01)
        assert np.array_equal(a[j], a1) and np.array_equal(b[j], b1)
    a2, _ = nigam_jennings_coefficients(omegas, 0.05, 0.01)  # scalar zeta broadcast
    assert a2.shape == (4, 2, 2)


@pytest.mark.parametrize('dt', [0.01, 0.1])
def test_ramp_matches_chopra_4_4_2(dt: float) -> None:
    # Undamped SDOF under f = F t / t_r from rest: x = F/ω² (t/t_r − sin ωt/(ω t_r)).
    omega, big_f, t_r = 4.0, 3.0, 2.0
    t = np.arange(801) * dt
    x, v, _ = nigam_jennings(omega, 0.0, dt, big_f * t / t_r)
    x_ref = big_f / omega**2 * (t / t_r - np.sin(omega * t) / (omega * t_r))
    v_ref = big_f / omega**2 * (1 - np.cos(omega * t)) / t_r
    assert relative_error(x, x_ref) < 1e-12
    assert relative_error(v, v_ref) < 1e-12


def test_ramp_then_hold_matches_chopra_4_5() -> None:
    # Step force with finite rise time t_r (Chopra eqs. 4.5.1-4.5.2), undamped.
    omega, big_f, dt, t_r = 5.0, 2.0, 0.01, 0.37
    t = np.arange(1500) * dt
    f = big_f * np.minimum(t / t_r, 1.0)
    x, _, _ = nigam_jennings(omega, 0.0, dt, f)
    ramp = big_f / omega**2 * (t / t_r - np.sin(omega * t) / (omega * t_r))
    hold = big_f / omega**2 * (
        1 - (np.sin(omega * t) - np.sin(omega * (t - t_r))) / (omega * t_r)
    )
    x_ref = np.where(t <= t_r, ramp, hold)
    assert relative_error(x, x_ref) < 1e-12


@pytest.mark.parametrize('zeta', [0.0, 0.05, 0.5])
def test_step_load_matches_the_damped_step_response(zeta: float) -> None:
    # Chopra §4.3, step force applied at t = 0 (a constant, hence piecewise-linear, input).
    omega, big_f, dt = 9.0, 1.7, 0.005
    t = np.arange(3000) * dt
    x, _v, a = nigam_jennings(omega, zeta, dt, np.full(t.size, big_f))
    wd = omega * math.sqrt(1 - zeta**2)
    x_ref = big_f / omega**2 * (
        1
        - np.exp(-zeta * omega * t)
        * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    )
    assert relative_error(x, x_ref) < 1e-12
    assert abs(a[0] - big_f) < 1e-12 * big_f


@pytest.mark.parametrize('omega, zeta', [(2 * math.pi, 0.05), (31.0, 0.02), (0.7, 0.3)])
def test_exact_for_piecewise_linear_input_sampled_finer(omega: float, zeta: float) -> None:
    rng = np.random.default_rng(int(omega * 100))
    dt, refine = 0.02, 10
    coarse, fine = piecewise_linear(rng, 1500, dt, refine)
    x, v, a = nigam_jennings(omega, zeta, dt, coarse, 0.01, -0.02)
    xf, vf, af = nigam_jennings(omega, zeta, dt / refine, fine, 0.01, -0.02)
    assert relative_error(xf[::refine], x) < 1e-12
    assert relative_error(vf[::refine], v) < 1e-12
    assert relative_error(af[::refine], a) < 1e-12


def test_harmonic_response_solves_the_equation() -> None:
    omega, zeta, big_f, big_w, x0, v0 = 6.0, 0.04, 2.5, 3.7, 0.01, 0.3
    t = np.linspace(0.0, 8.0, 401)
    x, v = harmonic_response(omega, zeta, t, big_f, big_w, x0, v0)
    sol = scipy.integrate.solve_ivp(
        lambda s, y: [y[1], big_f * math.sin(big_w * s) - 2 * zeta * omega * y[1]
                      - omega**2 * y[0]],
        (0.0, 8.0), [x0, v0], t_eval=t, rtol=1e-12, atol=1e-14, method='DOP853',
    )
    assert relative_error(x, sol.y[0]) < 1e-9
    assert relative_error(v, sol.y[1]) < 1e-9


def test_sine_load_converges_at_second_order() -> None:
    # A sine is not piecewise linear: the recurrence sees its linear interpolant, whose error
    # is O(Δt²), so the response converges at order 2 to the closed form.
    omega, zeta, big_f, big_w = 6.0, 0.05, 3.0, 0.6 * 6.0
    t_end = 10.0
    dts = [0.04, 0.02, 0.01, 0.005]
    errors = []
    for dt in dts:
        t = np.arange(round(t_end / dt) + 1) * dt
        x, _, _ = nigam_jennings(omega, zeta, dt, big_f * np.sin(big_w * t))
        x_ref, _ = harmonic_response(omega, zeta, t, big_f, big_w)
        errors.append(relative_error(x, x_ref))
    slope = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    assert 1.9 < slope < 2.1
    assert errors[-1] < 1e-4
    assert all(e2 < e1 for e1, e2 in zip(errors, errors[1:]))


def test_long_record_is_fast() -> None:
    f = np.random.default_rng(5).standard_normal(100_000)
    start = time.perf_counter()
    x, _, _ = nigam_jennings(10.0, 0.05, 0.005, f)
    assert time.perf_counter() - start < 2.0
    assert x.shape == (100_000,) and np.all(np.isfinite(x))


@pytest.mark.parametrize(
    'kwargs',
    [
        {'omega': 0.0},
        {'omega': -1.0},
        {'zeta': 1.0},
        {'zeta': -0.1},
        {'dt': 0.0},
        {'excitation': np.zeros((3, 2))},
        {'excitation': [0.0, math.nan]},
        {'excitation': []},
        {'x0': math.inf},
    ],
)
def test_nigam_jennings_rejects_bad_input(kwargs: dict) -> None:
    args = {'omega': 1.0, 'zeta': 0.05, 'dt': 0.01, 'excitation': np.zeros(5)}
    args.update(kwargs)
    with pytest.raises(ConfigError):
        nigam_jennings(**args)


def test_single_sample_returns_the_initial_state() -> None:
    x, v, a = nigam_jennings(2.0, 0.1, 0.01, [3.0], 0.5, 0.25)
    assert x.tolist() == [0.5] and v.tolist() == [0.25]
    assert a[0] == pytest.approx(3.0 - 2 * 0.1 * 2.0 * 0.25 - 4.0 * 0.5)


# --------------------------------------------------------------------------- modal superposition


def shear_building(masses: list[float], stiffnesses: list[float]) -> tuple:
    n = len(masses)
    m = np.diag(masses)
    k = np.zeros((n, n))
    for j, kj in enumerate(stiffnesses):
        k[j, j] += kj
        if j + 1 < n:
            k[j, j] += stiffnesses[j + 1]
            k[j, j + 1] = k[j + 1, j] = -stiffnesses[j + 1]
    return m, k


def direct_integration(
    m: np.ndarray, c: np.ndarray, k: np.ndarray, dt: float, p: np.ndarray,
    x0: np.ndarray, v0: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """solve_ivp of M ẍ + C ẋ + K x = p(t), p linear between samples, one segment at a time.

    Each segment is integrated separately so that the adaptive steps never straddle a kink
    of the load (where the error estimate of DOP853 would be poor).
    """
    n = m.shape[0]
    m_inv = np.linalg.inv(m)
    y = np.concatenate([x0, v0])
    out = [y]
    for i in range(p.shape[0] - 1):
        p0, slope = p[i], (p[i + 1] - p[i]) / dt

        def rhs(s: float, state: np.ndarray, p0: np.ndarray = p0,
                slope: np.ndarray = slope) -> np.ndarray:
            load = p0 + slope * s
            return np.concatenate(
                [state[n:], m_inv @ (load - c @ state[n:] - k @ state[:n])]
            )

        sol = scipy.integrate.solve_ivp(
            rhs, (0.0, dt), y, method='DOP853', rtol=1e-10, atol=1e-14, t_eval=[dt]
        )
        assert sol.success
        y = sol.y[:, -1]
        out.append(y)
    states = np.array(out)
    return states[:, :n], states[:, n:]


@pytest.mark.parametrize('n_dof', [2, 3])
@pytest.mark.parametrize('damping', ['ratios', 'rayleigh'])
def test_modal_superposition_matches_direct_integration(n_dof: int, damping: str) -> None:
    masses = [1200.0, 1000.0, 800.0][:n_dof]
    stiffnesses = [4.0e5, 3.0e5, 2.0e5][:n_dof]
    m, k = shear_building(masses, stiffnesses)
    rng = np.random.default_rng(n_dof)
    dt = 0.02
    p = np.cumsum(rng.standard_normal((301, n_dof)), axis=0) * 200.0
    x0 = rng.standard_normal(n_dof) * 1e-3
    v0 = rng.standard_normal(n_dof) * 1e-2
    if damping == 'rayleigh':
        c = damping_from_ratio(m, k, 0.05, modes=(1, n_dof))
        x, v, a = modal_superposition(m, k, None, dt, p, x0, v0, damping_matrix=c)
    else:
        zetas = [0.02, 0.05, 0.1][:n_dof]
        x, v, a = modal_superposition(m, k, zetas, dt, p, x0, v0)
        # The implied damping matrix C = M Φ diag(2ζω) Φᵀ M of the mass-normalised modes.
        w2, modes = scipy.linalg.eigh(k, m)
        c = m @ modes @ np.diag(2 * np.array(zetas) * np.sqrt(w2)) @ modes.T @ m
    x_ref, v_ref = direct_integration(m, c, k, dt, p, x0, v0)
    assert x.shape == v.shape == a.shape == (301, n_dof)
    assert relative_error(x, x_ref) < 1e-7
    assert relative_error(v, v_ref) < 1e-7
    a_ref = np.linalg.solve(m, (p - v_ref @ c.T - x_ref @ k.T).T).T
    assert relative_error(a, a_ref) < 1e-6


def test_free_vibration_in_one_mode_stays_in_that_mode() -> None:
    m, k = shear_building([1000.0, 1000.0, 1000.0], [3e5, 3e5, 3e5])
    w2, phi = scipy.linalg.eigh(k, m)
    omegas = np.sqrt(w2)
    zetas = np.array([0.02, 0.04, 0.06])
    dt = 0.01
    mode = 1
    x0 = 0.02 * phi[:, mode]
    x, _v, _ = modal_superposition(m, k, zetas, dt, np.zeros((2000, 3)), x0, np.zeros(3))
    q = x @ m @ phi  # modal coordinates Φᵀ M x
    others = [j for j in range(3) if j != mode]
    assert np.max(np.abs(q[:, others])) < 1e-14 * 0.02
    t = np.arange(2000) * dt
    q_ref, _ = free_vibration(omegas[mode], zetas[mode], t, 0.02, 0.0)
    assert np.max(np.abs(q[:, mode] - q_ref)) < 1e-13
    # The shape is preserved: x(t) is q(t) φ at every instant.
    assert np.max(np.abs(x - np.outer(q[:, mode], phi[:, mode]))) < 1e-14


def test_sdof_modal_superposition_equals_nigam_jennings() -> None:
    rng = np.random.default_rng(3)
    p = rng.standard_normal(500) * 1000.0
    mass, k, zeta = 2543.4, 312559.0, 0.05
    x, _v, a = modal_superposition(mass, k, zeta, 0.01, p, [0.003], [0.0])
    xn, _vn, an = nigam_jennings(math.sqrt(k / mass), zeta, 0.01, p / mass, 0.003)
    assert x.shape == (500, 1)
    assert relative_error(x[:, 0], xn) < 1e-13
    assert relative_error(a[:, 0], an) < 1e-13


def test_rayleigh_damping_matrix_gives_the_modal_ratios() -> None:
    m, k = shear_building([1.0, 2.0, 1.5], [500.0, 800.0, 300.0])
    c = damping_from_ratio(m, k, 0.05, modes=(1, 3))
    p = np.random.default_rng(8).standard_normal((400, 3))
    x1, _, _ = modal_superposition(m, k, None, 0.01, p, damping_matrix=c)
    w2, phi = scipy.linalg.eigh(k, m)
    zetas = np.diag(phi.T @ c @ phi) / (2 * np.sqrt(w2))
    assert zetas[0] == pytest.approx(0.05, rel=1e-10)
    assert zetas[2] == pytest.approx(0.05, rel=1e-10)
    x2, _, _ = modal_superposition(m, k, zetas, 0.01, p)
    assert relative_error(x1, x2) < 1e-13


def test_non_classical_damping_is_rejected() -> None:
    m, k = shear_building([1.0, 1.0], [100.0, 100.0])
    c = np.array([[3.0, 0.0], [0.0, 0.0]])  # a damper at the first floor only
    with pytest.raises(ConfigError, match='not classical'):
        modal_superposition(m, k, None, 0.01, np.zeros((10, 2)), damping_matrix=c)


@pytest.mark.parametrize(
    'kwargs',
    [
        {'damping_ratios': None},  # neither
        {'damping_matrix': np.eye(2)},  # both
        {'damping_ratios': [0.05, 0.05, 0.05]},
        {'damping_ratios': [0.05, 1.2]},
        {'load': np.zeros((10, 3))},
        {'load': np.zeros(10)},
        {'x0': np.zeros(3)},
        {'stiffness': np.array([[1.0, -1.0], [-1.0, 1.0]])},  # a rigid-body mode
        {'dt': -0.01},
    ],
)
def test_modal_superposition_rejects_bad_input(kwargs: dict) -> None:
    m, k = shear_building([1.0, 1.0], [100.0, 100.0])
    args = {
        'mass': m, 'stiffness': k, 'damping_ratios': 0.05, 'dt': 0.01,
        'load': np.zeros((10, 2)),
    }
    args.update(kwargs)
    with pytest.raises(ConfigError):
        modal_superposition(**args)


# --------------------------------------------------------------------------- EPP


def newmark_epp_reference(
    m: float, k: float, fy: float, c: float, dt: float, load: np.ndarray, substeps: int
) -> tuple[np.ndarray, np.ndarray]:
    """Independent reference: average-acceleration Newmark on ``dt/substeps`` substeps.

    The EPP spring is solved exactly within each step: the elastic trial, and if it exceeds
    ``f_y`` the step is re-solved with ``r = ±f_y`` and the plastic offset updated (return
    mapping). The step is written for the new acceleration (no large cancelling terms), so
    rounding stays far below the method's O(h²) error.
    """
    h = dt / substeps
    uy = fy / k
    ps = np.asarray(load, dtype=float).tolist()
    x = v = xp = r = 0.0
    a = (ps[0] - c * v - r) / m
    d_el = m + c * h / 2 + k * h * h / 4
    d_pl = m + c * h / 2
    xs, rs = [x], [r]
    for i in range(len(ps) - 1):
        p0, dp = ps[i], (ps[i + 1] - ps[i]) / substeps
        for j in range(1, substeps + 1):
            x_pred = x + h * v + h * h / 4 * a
            rhs = p0 + dp * j - c * (v + h * a / 2)
            a1 = (rhs - k * (x_pred - xp)) / d_el
            x1 = x_pred + h * h / 4 * a1
            r = k * (x1 - xp)
            if r > fy:
                a1 = (rhs - fy) / d_pl
                x1 = x_pred + h * h / 4 * a1
                r, xp = fy, x1 - uy
            elif r < -fy:
                a1 = (rhs + fy) / d_pl
                x1 = x_pred + h * h / 4 * a1
                r, xp = -fy, x1 + uy
            v += h / 2 * (a + a1)
            x, a = x1, a1
        xs.append(x)
        rs.append(r)
    return np.array(xs), np.array(rs)


# The thesis's NPTEL example: m = 1 kg, k = 39.478 N/m (T = 1 s), c = 0.251 N·s/m (ζ = 2 %).
NPTEL_M, NPTEL_K, NPTEL_C = 1.0, 39.478, 0.251


@pytest.fixture(scope='module')
def elcentro():
    return read_ground_motion(ELCENTRO)


def test_epp_that_never_yields_equals_nigam_jennings(elcentro) -> None:
    load = -NPTEL_M * elcentro.acceleration
    res = epp_exact(NPTEL_M, NPTEL_K, 1e6, NPTEL_C, elcentro.dt, load, 0.01, -0.05)
    omega = math.sqrt(NPTEL_K / NPTEL_M)
    x, v, a = nigam_jennings(
        omega, NPTEL_C / (2 * NPTEL_M * omega), elcentro.dt, load / NPTEL_M, 0.01, -0.05
    )
    assert isinstance(res, EPPResponse)
    assert res.events == ()
    assert relative_error(res.x, x) < 1e-12
    assert relative_error(res.v, v) < 1e-12
    assert relative_error(res.a, a) < 1e-12
    assert np.array_equal(res.r, NPTEL_K * res.x)
    assert not np.any(res.plastic_displacement) and not np.any(res.hysteretic_energy)


def test_slow_ramp_saturates_at_the_yield_force() -> None:
    # Quasi-static (T = 1 s, ramps over 100 s, ζ = 20 %): load up to 1.5 f_y and back to 0.
    m, k, fy = 1.0, (2 * math.pi) ** 2, 2.0
    c = 2 * 0.2 * math.sqrt(k * m)
    dt = 0.05
    t = np.arange(4001) * dt
    p = 1.5 * fy * np.minimum(t, t[-1] - t) / 100.0
    res = epp_exact(m, k, fy, c, dt, p)
    assert np.max(res.r) == pytest.approx(fy, rel=1e-14)
    assert np.all(np.abs(res.r) <= fy * (1 + 1e-14))
    kinds = [kind for _, kind in res.events]
    assert kinds == ['yield+', 'unload']
    t_yield, t_unload = res.events[0][0], res.events[1][0]
    # Quasi-static: yielding starts when p reaches f_y (t = 66.7 s) and ends when p drops
    # back to f_y (t = 133.3 s), up to the lag of the slow ramp.
    assert t_yield == pytest.approx(200 / 3, abs=0.1)
    assert t_unload == pytest.approx(400 / 3, abs=0.5)
    plastic = (t > t_yield + 1e-9) & (t < t_unload - 1e-9)
    assert np.all(res.r[plastic] == fy)
    elastic = ~plastic
    assert np.max(np.abs(res.r[elastic] - np.minimum(p[elastic], fy))) < 0.01 * fy
    assert np.all(np.diff(res.plastic_displacement) >= 0.0)
    assert res.plastic_displacement[-1] > 0.0
    assert res.x[-1] == pytest.approx(res.plastic_displacement[-1], abs=0.01 * fy / k)
    assert res.hysteretic_energy[-1] == pytest.approx(fy * res.plastic_displacement[-1])


@pytest.mark.parametrize('c', [0.0, 0.3])
def test_plastic_branch_matches_its_closed_form(c: float) -> None:
    # Start on the yield surface at rest under a constant load 2 f_y: m ẍ + c ẋ = f_y.
    m, k, fy = 2.0, 50.0, 3.0
    uy = fy / k
    dt = 0.01
    t = np.arange(301) * dt
    res = epp_exact(m, k, fy, c, dt, np.full(t.size, 2 * fy), uy, 0.0)
    if c == 0.0:
        x_ref = uy + fy * t**2 / (2 * m)
    else:
        lam = c / m
        x_ref = uy + fy / c * (t - (1 - np.exp(-lam * t)) / lam)
    assert relative_error(res.x, x_ref) < 1e-13
    assert np.all(res.r == fy)
    assert res.events[0][0] == 0.0 and res.events[0][1] == 'yield+'
    assert np.allclose(res.plastic_displacement, res.x - uy, rtol=0, atol=1e-15)


@pytest.mark.parametrize('uy', [0.05, 0.025])
def test_nptel_el_centro_matches_a_fine_newmark_reference(elcentro, uy: float) -> None:
    fy = NPTEL_K * uy
    load = -NPTEL_M * elcentro.acceleration
    res = epp_exact(NPTEL_M, NPTEL_K, fy, NPTEL_C, elcentro.dt, load)
    # 0.02 s / 2000 = 1e-5 s substeps.
    x_ref, r_ref = newmark_epp_reference(NPTEL_M, NPTEL_K, fy, NPTEL_C, elcentro.dt, load, 2000)
    peak, peak_ref = np.max(np.abs(res.x)), np.max(np.abs(x_ref))
    assert peak == pytest.approx(peak_ref, rel=1e-4)
    assert res.x[-1] == pytest.approx(x_ref[-1], rel=1e-4)
    assert relative_error(res.x, x_ref) < 1e-6
    assert np.max(np.abs(res.r - r_ref)) < 1e-6 * fy
    assert len(res.events) > 5
    assert peak > 1.5 * uy  # it really is inelastic


@pytest.mark.parametrize('c', [0.0, 0.251])
def test_undamped_and_damped_epp_match_the_reference_over_10_s(elcentro, c: float) -> None:
    n = 501
    load = -NPTEL_M * elcentro.acceleration[:n]
    fy = NPTEL_K * 0.03
    res = epp_exact(NPTEL_M, NPTEL_K, fy, c, elcentro.dt, load)
    x_ref, _ = newmark_epp_reference(NPTEL_M, NPTEL_K, fy, c, elcentro.dt, load, 400)
    assert relative_error(res.x, x_ref) < 1e-6


def test_epp_is_exact_for_piecewise_linear_load_sampled_finer(elcentro) -> None:
    fy = NPTEL_K * 0.025
    load = -NPTEL_M * elcentro.acceleration
    fine = elcentro.resampled(elcentro.dt / 4)
    res = epp_exact(NPTEL_M, NPTEL_K, fy, NPTEL_C, elcentro.dt, load)
    res_f = epp_exact(NPTEL_M, NPTEL_K, fy, NPTEL_C, fine.dt, -NPTEL_M * fine.acceleration)
    assert relative_error(res_f.x[::4], res.x) < 1e-12
    assert relative_error(res_f.v[::4], res.v) < 1e-12
    assert np.max(np.abs(res_f.r[::4] - res.r)) < 1e-12 * fy
    assert res_f.hysteretic_energy[-1] == pytest.approx(res.hysteretic_energy[-1], rel=1e-12)
    assert [kind for _, kind in res_f.events] == [kind for _, kind in res.events]
    times = np.array([t for t, _ in res.events])
    times_f = np.array([t for t, _ in res_f.events])
    assert np.max(np.abs(times - times_f)) < 1e-12


@pytest.mark.parametrize('dt', [0.3, 0.05])
def test_brief_yield_between_samples_matches_the_analytic_solution(dt: float) -> None:
    # Undamped, unloaded, from x = 0 with an elastic amplitude A = 1.001 u_y: the spring
    # yields briefly around t = T/4 = 0.25 s, where no sample (dt = 0.3 s) and no scan point
    # of the segment is. Elastic until A sin ωt1 = u_y; plastic m ẍ = −f_y until v = 0 at
    # t2 (offset v1² m/(2 f_y)); then elastic about x_p with amplitude u_y.
    m, k = 1.0, (2 * math.pi) ** 2
    omega = math.sqrt(k / m)
    uy = 0.01
    fy = k * uy
    amplitude = 1.001 * uy
    n = round(3.0 / dt) + 1
    res = epp_exact(m, k, fy, 0.0, dt, np.zeros(n), 0.0, amplitude * omega)
    t1 = math.asin(uy / amplitude) / omega
    v1 = amplitude * omega * math.cos(omega * t1)
    t2 = t1 + v1 * m / fy
    xp = v1**2 * m / (2 * fy)
    kinds = [kind for _, kind in res.events]
    assert kinds[:2] == ['yield+', 'unload']
    assert res.events[0][0] == pytest.approx(t1, abs=1e-12)
    assert res.events[1][0] == pytest.approx(t2, abs=1e-12)
    # Undamped, the elastic amplitude after unloading is exactly u_y: the troughs graze the
    # yield surface, which may register as a yield/unload pair with no plastic flow.
    assert set(kinds[2:]) <= {'yield-', 'unload'}
    t = np.arange(n) * dt
    x_ref = np.where(
        t <= t1,
        amplitude * np.sin(omega * t),
        np.where(
            t <= t2,
            uy + v1 * (t - t1) - fy / (2 * m) * (t - t1) ** 2,
            xp + uy * np.cos(omega * (t - t2)),
        ),
    )
    assert np.max(np.abs(res.x - x_ref)) < 1e-13
    assert res.plastic_displacement[-1] == pytest.approx(xp, rel=1e-10)
    assert res.hysteretic_energy[-1] == pytest.approx(fy * xp, rel=1e-10)


@pytest.mark.parametrize('dt', [0.25, 0.6])
def test_epp_with_long_load_segments(dt: float) -> None:
    # Segments of 0.25 s and 0.6 s with T = 1 s: each holds velocity and acceleration zeros,
    # so yield and unload events fall between samples (and between the scan points of a
    # segment). The Newmark reference and the same load sampled 20x finer must agree.
    m, k, c = 1.0, (2 * math.pi) ** 2, 0.3
    fy = 0.05 * k
    n = round(12.0 / dt) + 1
    load = 0.15 * k * np.random.default_rng(int(dt * 100)).standard_normal(n)
    res = epp_exact(m, k, fy, c, dt, load)
    assert len(res.events) >= 4
    x_ref, r_ref = newmark_epp_reference(m, k, fy, c, dt, load, round(dt / 1e-4))
    assert relative_error(res.x, x_ref) < 1e-6
    assert np.max(np.abs(res.r - r_ref)) < 1e-5 * fy
    refine = 20
    t = np.arange(n) * dt
    t_fine = np.arange((n - 1) * refine + 1) * (dt / refine)
    fine = epp_exact(m, k, fy, c, dt / refine, np.interp(t_fine, t, load))
    assert relative_error(fine.x[::refine], res.x) < 1e-12
    assert [kind for _, kind in fine.events] == [kind for _, kind in res.events]


@pytest.mark.parametrize('uy', [0.05, 0.025])
def test_epp_energy_balance(elcentro, uy: float) -> None:
    fy = NPTEL_K * uy
    motion = elcentro.resampled(0.001)
    load = -NPTEL_M * motion.acceleration
    res = epp_exact(NPTEL_M, NPTEL_K, fy, NPTEL_C, motion.dt, load)
    e_h = res.hysteretic_energy
    assert np.all(e_h >= 0.0)
    assert np.all(np.diff(e_h) >= 0.0)
    assert e_h[-1] > 0.0
    # The dissipated energy is f_y |Δx_p| (no two opposite excursions within 1 ms here).
    assert np.allclose(
        np.diff(e_h), fy * np.abs(np.diff(res.plastic_displacement)), rtol=1e-9, atol=1e-15
    )
    # Input = kinetic + viscous + strain + hysteretic (trapezoidal rule, O(dt²)).
    dt = motion.dt
    e_in = scipy.integrate.cumulative_trapezoid(load * res.v, dx=dt, initial=0.0)
    e_d = scipy.integrate.cumulative_trapezoid(NPTEL_C * res.v**2, dx=dt, initial=0.0)
    e_k = 0.5 * NPTEL_M * res.v**2
    e_s = res.r**2 / (2 * NPTEL_K)
    balance = e_in - (e_k + e_d + e_s + e_h)
    assert np.max(np.abs(balance)) < 1e-4 * np.max(np.abs(e_in))
    assert e_h[-1] > 0.05 * e_in[-1]


@pytest.mark.parametrize(
    'kwargs',
    [
        {'mass': 0.0},
        {'stiffness': -1.0},
        {'yield_force': 0.0},
        {'damping': -0.1},
        {'damping': 2.0 * math.sqrt(NPTEL_K * NPTEL_M)},  # critically damped
        {'dt': 0.0},
        {'load': np.zeros((4, 2))},
        {'load': [0.0, math.nan]},
        {'v0': math.nan},
    ],
)
def test_epp_rejects_bad_input(kwargs: dict) -> None:
    args = {
        'mass': NPTEL_M, 'stiffness': NPTEL_K, 'yield_force': 1.0, 'damping': NPTEL_C,
        'dt': 0.02, 'load': np.zeros(5),
    }
    args.update(kwargs)
    with pytest.raises(ConfigError):
        epp_exact(**args)


def test_epp_starting_beyond_yield_starts_with_an_offset() -> None:
    res = epp_exact(1.0, 100.0, 1.0, 0.5, 0.01, np.zeros(300), x0=0.05, v0=0.0)
    assert res.plastic_displacement[0] == pytest.approx(0.04)
    assert res.r[0] == pytest.approx(1.0)
    # At rest on the yield surface with no load it unloads elastically about x_p = 0.04.
    assert res.events == ()
    assert np.all(res.plastic_displacement == res.plastic_displacement[0])
    assert np.all(np.abs(res.r) <= 1.0 + 1e-12)
