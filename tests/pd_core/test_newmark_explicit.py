"""Newmark explicit scheme (thesis eqs. 3.20-3.22) against closed-form solutions."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
import scipy.linalg

from pd_core.errors import ConfigError, IntegratorError
from pd_core.schemes import SCHEMES, Integrator, NewmarkExplicit, make_integrator

# Thesis SDOF (Appendix A): m = 2543.4 kg, k_ini = 312559 N/m, ζ = 5 %.
M_SDOF = 2543.4
K_SDOF = 312559.0
OMEGA_SDOF = math.sqrt(K_SDOF / M_SDOF)


def run_sdof(
    m: float,
    c: float,
    k: float,
    dt: float,
    n_steps: int,
    x0: float = 0.0,
    v0: float = 0.0,
    load: Callable[[float], float] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Drive a linear elastic SDOF (r = k x) through predict/correct/commit."""
    integrator = NewmarkExplicit(m, c, dt)
    p = load if load is not None else (lambda t: 0.0)
    integrator.initialize(x0, v0, p(0.0), k * x0)
    xs = np.empty(n_steps + 1)
    vs = np.empty(n_steps + 1)
    acs = np.empty(n_steps + 1)
    xs[0], vs[0], acs[0] = integrator.x[0], integrator.v[0], integrator.a[0]
    for i in range(1, n_steps + 1):
        target = integrator.predict()
        integrator.correct(k * float(target[0]), p(i * dt))
        integrator.commit()
        xs[i], vs[i], acs[i] = integrator.x[0], integrator.v[0], integrator.a[0]
    return xs, vs, acs


def run_mdof(
    mass: np.ndarray,
    damping: np.ndarray,
    stiffness: np.ndarray,
    dt: float,
    n_steps: int,
    x0: np.ndarray,
    v0: np.ndarray,
) -> np.ndarray:
    """Drive a linear elastic MDOF (r = K x) in free vibration; returns x history."""
    integrator = NewmarkExplicit(mass, damping, dt)
    n = mass.shape[0]
    integrator.initialize(x0, v0, np.zeros(n), stiffness @ x0)
    xs = np.empty((n_steps + 1, n))
    xs[0] = integrator.x
    for i in range(1, n_steps + 1):
        target = integrator.predict()
        integrator.correct(stiffness @ target, np.zeros(n))
        integrator.commit()
        xs[i] = integrator.x
    return xs


def convergence_slope(dts: list[float], errors: list[float]) -> float:
    """Least-squares slope of log(error) against log(dt)."""
    return float(np.polyfit(np.log(dts), np.log(errors), 1)[0])


# --------------------------------------------------------------------------- MATLAB port


def matlab_style_loop(
    m: float, kini: float, z: float, dt: float, p: list[float], x_1: float, x1_1: float
) -> tuple[list[float], list[float], list[float]]:
    """Scalar transcription of Appendix A lines 18-24, 64-65 and 70-77 (linear branch)."""
    w = math.sqrt(kini / m)
    c = 2 * m * w * z
    x = [x_1]
    x1 = [x1_1]
    x2 = [(p[0] - c * x1[0] - kini * x[0]) / m]
    fs = [kini * x[0]]
    for i in range(len(p) - 1):
        x.append(x[i] + dt * x1[i] + x2[i] * dt * dt * 0.5)
        fs.append(kini * x[i + 1])
        x2.append((p[i + 1] - fs[i + 1] - c * x1[i] - dt * 0.5 * c * x2[i]) / (m + dt * 0.5 * c))
        x1.append(x1[i] + dt * 0.5 * (x2[i] + x2[i + 1]))
    return x, x1, x2


@pytest.mark.parametrize('x_1, x1_1', [(0.0, 0.0), (0.012, -0.03)])
def test_sdof_agrees_float_for_float_with_the_thesis_matlab_loop(x_1: float, x1_1: float) -> None:
    m, kini, z, dt = M_SDOF, K_SDOF, 0.05, 0.01
    rng = np.random.default_rng(1940)
    n = 3000
    t = np.arange(n) * dt
    a_g = 0.3 * np.sin(2 * np.pi * 1.7 * t) * np.exp(-0.2 * t) + 0.05 * rng.standard_normal(n)
    p = [float(-m * 9.81 * value) for value in a_g]
    x_ref, x1_ref, x2_ref = matlab_style_loop(m, kini, z, dt, p, x_1, x1_1)

    c = 2 * m * math.sqrt(kini / m) * z
    integrator = NewmarkExplicit(m, c, dt)
    integrator.initialize(x_1, x1_1, p[0], kini * x_1)
    x, v, a = [float(integrator.x[0])], [float(integrator.v[0])], [float(integrator.a[0])]
    for i in range(1, n):
        target = integrator.predict()
        integrator.correct(kini * float(target[0]), p[i])
        integrator.commit()
        x.append(float(integrator.x[0]))
        v.append(float(integrator.v[0]))
        a.append(float(integrator.a[0]))

    assert x == x_ref
    assert v == x1_ref
    assert a == x2_ref
    assert max(abs(value) for value in x) > 1e-3  # the history is not trivial


def test_sdof_accepts_ints_and_one_element_arrays_with_identical_results() -> None:
    def run(convert: Callable[[float], object]) -> list[float]:
        integrator = NewmarkExplicit(np.array([[M_SDOF]]), [[2819.0]], 0.01)
        integrator.initialize(convert(0.01), convert(0.0), convert(0.0), K_SDOF * 0.01)
        history = []
        for i in range(200):
            target = integrator.predict()
            assert target.shape == (1,)
            integrator.correct(convert(K_SDOF * float(target[0])), convert(100.0 * (i % 7)))
            integrator.commit()
            history.append(float(integrator.x[0]))
        return history

    reference = run(float)
    assert run(lambda value: np.array([value])) == reference
    assert run(np.float64) == reference
    assert run(lambda value: [value]) == reference


# --------------------------------------------------------------------------- free vibration


@pytest.mark.parametrize('dt', [0.001, 0.01, 0.05, 0.15])
@pytest.mark.parametrize('x0, v0', [(0.02, 0.0), (-0.01, 0.3)])
def test_undamped_free_vibration_is_the_exact_discrete_solution(
    dt: float, x0: float, v0: float
) -> None:
    # Eq. 3.10-3.19: lambda = exp(+-i Omega_bar) with cos(Omega_bar) = 1 - Omega^2/2, so the
    # consistent discrete solution is x_n = x0 cos(n Omega_bar) + dt v0 / sin(Omega_bar)
    # * sin(n Omega_bar) (x_1 = x0 (1 - Omega^2/2) + dt v0 fixes the second constant).
    # Omega_bar = 2 asin(Omega/2) is the same angle, without acos's ill-conditioning near 1.
    omega_dt = OMEGA_SDOF * dt
    omega_bar = 2.0 * math.asin(omega_dt / 2.0)
    assert math.cos(omega_bar) == pytest.approx(1.0 - omega_dt**2 / 2.0, abs=1e-15)
    n_steps = 3000
    xs, _, _ = run_sdof(M_SDOF, 0.0, K_SDOF, dt, n_steps, x0=x0, v0=v0)
    n = np.arange(n_steps + 1)
    exact = x0 * np.cos(n * omega_bar) + dt * v0 / math.sin(omega_bar) * np.sin(n * omega_bar)
    amplitude = math.hypot(x0, dt * v0 / math.sin(omega_bar))
    assert np.max(np.abs(xs - exact)) <= 1e-11 * amplitude
    if omega_dt > math.sqrt(2.0):
        assert omega_bar > math.pi / 2  # the atan2 branch of eq. 3.19 is exercised


def test_undamped_free_vibration_converges_at_second_order() -> None:
    x0, v0 = 0.02, 0.1
    t_end = 2.0
    dts = [0.01 / 2**j for j in range(5)]
    errors = []
    for dt in dts:
        n_steps = round(t_end / dt)
        xs, _, _ = run_sdof(M_SDOF, 0.0, K_SDOF, dt, n_steps, x0=x0, v0=v0)
        t = np.arange(n_steps + 1) * dt
        exact = x0 * np.cos(OMEGA_SDOF * t) + v0 / OMEGA_SDOF * np.sin(OMEGA_SDOF * t)
        errors.append(float(np.max(np.abs(xs - exact))))
    slope = convergence_slope(dts, errors)
    assert 1.9 <= slope <= 2.1, (slope, errors)
    # Leading error term: the phase lag of the numerical frequency, (omega^3 dt^2 / 24) t_end.
    amplitude = math.hypot(x0, v0 / OMEGA_SDOF)
    predicted = amplitude * OMEGA_SDOF**3 * dts[-1] ** 2 * t_end / 24.0
    assert 0.7 * predicted <= errors[-1] <= 1.05 * predicted


def damped_sine_exact(
    m: float, c: float, k: float, x0: float, v0: float, p0: float, w_f: float, t: np.ndarray
) -> np.ndarray:
    """Exact x(t) of m x'' + c x' + k x = p0 sin(w_f t), x(0) = x0, x'(0) = v0 (zeta < 1)."""
    w = math.sqrt(k / m)
    zeta = c / (2.0 * math.sqrt(k * m))
    w_d = w * math.sqrt(1.0 - zeta**2)
    r = w_f / w
    denominator = (1.0 - r**2) ** 2 + (2.0 * zeta * r) ** 2
    c_s = p0 / k * (1.0 - r**2) / denominator
    d_s = p0 / k * (-2.0 * zeta * r) / denominator
    a_t = x0 - d_s
    b_t = (v0 + zeta * w * a_t - c_s * w_f) / w_d
    transient = np.exp(-zeta * w * t) * (a_t * np.cos(w_d * t) + b_t * np.sin(w_d * t))
    return transient + c_s * np.sin(w_f * t) + d_s * np.cos(w_f * t)


def test_damped_sine_exact_solution_satisfies_the_equation_of_motion() -> None:
    # Guards the reference itself: residual of the ODE by central differences.
    m, k = M_SDOF, K_SDOF
    c = 2.0 * 0.05 * math.sqrt(k * m)
    p0, w_f = 2.0e4, 0.6 * OMEGA_SDOF
    h = 1e-4
    t = np.linspace(0.1, 3.0, 50)
    x = damped_sine_exact(m, c, k, 0.01, 0.2, p0, w_f, t)
    xp = damped_sine_exact(m, c, k, 0.01, 0.2, p0, w_f, t + h)
    xm = damped_sine_exact(m, c, k, 0.01, 0.2, p0, w_f, t - h)
    residual = m * (xp - 2 * x + xm) / h**2 + c * (xp - xm) / (2 * h) + k * x
    assert np.max(np.abs(residual - p0 * np.sin(w_f * t))) < 1e-4 * p0
    start = damped_sine_exact(m, c, k, 0.01, 0.2, p0, w_f, np.array([0.0, h]))
    assert start[0] == pytest.approx(0.01, abs=1e-15)
    assert (start[1] - start[0]) / h == pytest.approx(0.2, rel=1e-2)


@pytest.mark.parametrize(
    'x0, v0, p0, ratio_f',
    [
        (0.02, -0.1, 0.0, 0.0),  # damped free vibration
        (0.0, 0.0, 2.0e4, 0.6),  # sine load from rest: transient + steady state
        (0.0, 0.0, 2.0e4, 1.7),
    ],
)
def test_damped_response_converges_at_second_order(
    x0: float, v0: float, p0: float, ratio_f: float
) -> None:
    m, k = M_SDOF, K_SDOF
    c = 2.0 * 0.05 * math.sqrt(k * m)
    w_f = ratio_f * OMEGA_SDOF
    t_end = 3.0
    dts = [0.01 / 2**j for j in range(5)]
    errors = []
    for dt in dts:
        n_steps = round(t_end / dt)
        xs, _, _ = run_sdof(
            m, c, k, dt, n_steps, x0=x0, v0=v0, load=lambda t: p0 * math.sin(w_f * t)
        )
        exact = damped_sine_exact(m, c, k, x0, v0, p0, w_f, np.arange(n_steps + 1) * dt)
        errors.append(float(np.max(np.abs(xs - exact))))
    slope = convergence_slope(dts, errors)
    assert 1.9 <= slope <= 2.1, (slope, errors)
    scale = max(abs(x0), p0 / k)
    assert errors[-1] < 1e-4 * scale


# --------------------------------------------------------------------------- MDOF


def shear_building() -> tuple[np.ndarray, np.ndarray]:
    """3-storey shear building, lumped masses (kg) and storey stiffnesses (N/m)."""
    masses = np.array([3.0e4, 2.5e4, 2.0e4])
    k1, k2, k3 = 6.0e7, 4.5e7, 3.0e7
    stiffness = np.array([[k1 + k2, -k2, 0.0], [-k2, k2 + k3, -k3], [0.0, -k3, k3]])
    return np.diag(masses), stiffness


def modal_exact(
    mass: np.ndarray,
    stiffness: np.ndarray,
    a0: float,
    a1: float,
    x0: np.ndarray,
    v0: np.ndarray,
    t: np.ndarray,
) -> np.ndarray:
    """Exact free vibration by modal superposition for C = a0 M + a1 K."""
    eigenvalues, phi = scipy.linalg.eigh(stiffness, mass)
    omegas = np.sqrt(eigenvalues)
    q0 = phi.T @ mass @ x0
    qd0 = phi.T @ mass @ v0
    x = np.zeros((t.size, mass.shape[0]))
    for j, w in enumerate(omegas):
        zeta = a0 / (2 * w) + a1 * w / 2
        w_d = w * math.sqrt(1 - zeta**2)
        b = (qd0[j] + zeta * w * q0[j]) / w_d
        q = np.exp(-zeta * w * t) * (q0[j] * np.cos(w_d * t) + b * np.sin(w_d * t))
        x += np.outer(q, phi[:, j])
    return x


@pytest.mark.parametrize('damped', [False, True])
def test_mdof_free_vibration_converges_at_second_order(damped: bool) -> None:
    mass, stiffness = shear_building()
    omegas = np.sqrt(scipy.linalg.eigh(stiffness, mass, eigvals_only=True))
    if damped:  # Rayleigh damping, 5 % in modes 1 and 2
        w1, w2 = omegas[0], omegas[1]
        a0, a1 = 2 * 0.05 * w1 * w2 / (w1 + w2), 2 * 0.05 / (w1 + w2)
    else:
        a0 = a1 = 0.0
    damping = a0 * mass + a1 * stiffness
    x0 = np.array([0.005, 0.012, 0.02])
    v0 = np.array([0.0, -0.05, 0.1])
    t_end = 1.0
    dt0 = 0.2 / omegas[-1]  # Omega_max = 0.2
    dts = [dt0 / 2**j for j in range(5)]
    errors = []
    for dt in dts:
        n_steps = round(t_end / dt)
        xs = run_mdof(mass, damping, stiffness, dt, n_steps, x0, v0)
        exact = modal_exact(mass, stiffness, a0, a1, x0, v0, np.arange(n_steps + 1) * dt)
        errors.append(float(np.max(np.abs(xs - exact))))
    slope = convergence_slope(dts, errors)
    assert 1.9 <= slope <= 2.1, (slope, errors)
    assert errors[-1] < 1e-4 * float(np.max(np.abs(x0)))


def test_mdof_undamped_free_vibration_is_the_exact_discrete_modal_solution() -> None:
    mass, stiffness = shear_building()
    eigenvalues, phi = scipy.linalg.eigh(stiffness, mass)
    omegas = np.sqrt(eigenvalues)
    dt = 1.5 / omegas[-1]  # highest mode beyond sqrt(2), still stable
    x0 = np.array([0.005, 0.012, 0.02])
    v0 = np.array([0.0, -0.05, 0.1])
    n_steps = 2000
    xs = run_mdof(mass, np.zeros((3, 3)), stiffness, dt, n_steps, x0, v0)
    n = np.arange(n_steps + 1)
    exact = np.zeros_like(xs)
    for j, w in enumerate(omegas):
        omega_bar = 2.0 * math.asin(w * dt / 2.0)  # cos(Omega_bar) = 1 - Omega^2/2
        q0 = phi[:, j] @ mass @ x0
        qd0 = phi[:, j] @ mass @ v0
        q = q0 * np.cos(n * omega_bar) + dt * qd0 / math.sin(omega_bar) * np.sin(n * omega_bar)
        exact += np.outer(q, phi[:, j])
    assert np.max(np.abs(xs - exact)) <= 1e-11 * float(np.max(np.abs(exact)))


def test_uncoupled_mdof_matches_independent_sdof_runs() -> None:
    m = np.diag([M_SDOF, 2.0 * M_SDOF])
    k = np.diag([K_SDOF, 3.0 * K_SDOF])
    c = np.diag([1000.0, 2500.0])
    dt = 0.01
    xs = run_mdof(m, c, k, dt, 500, np.array([0.01, -0.02]), np.array([0.1, 0.0]))
    first, _, _ = run_sdof(M_SDOF, 1000.0, K_SDOF, dt, 500, x0=0.01, v0=0.1)
    second, _, _ = run_sdof(2.0 * M_SDOF, 2500.0, 3.0 * K_SDOF, dt, 500, x0=-0.02)
    np.testing.assert_allclose(xs[:, 0], first, rtol=0, atol=1e-13)
    np.testing.assert_allclose(xs[:, 1], second, rtol=0, atol=1e-13)


def test_mdof_non_symmetric_damping_uses_a_general_solve() -> None:
    mass, stiffness = shear_building()
    damping = np.array([[2.0e5, -1.0e5, 0.0], [-0.5e5, 1.5e5, -0.5e5], [0.0, -0.5e5, 0.5e5]])
    dt = 0.002
    integrator = NewmarkExplicit(mass, damping, dt)
    x0 = np.array([0.0, 0.01, 0.02])
    v0 = np.array([0.1, 0.0, -0.1])
    integrator.initialize(x0, v0, np.zeros(3), stiffness @ x0)
    a0 = np.linalg.solve(mass, -damping @ v0 - stiffness @ x0)
    np.testing.assert_allclose(integrator.a, a0, rtol=1e-12)
    target = integrator.predict()
    load = np.array([1.0e3, 0.0, -2.0e3])
    integrator.correct(stiffness @ target, load)
    integrator.commit()
    # Equation of motion at t_1 with v_1 = v_0 + dt/2 (a_0 + a_1) (eqs. 3.1, 3.20).
    residual = (
        mass @ integrator.a + damping @ integrator.v + stiffness @ integrator.x - load
    )
    assert np.max(np.abs(residual)) < 1e-8 * float(np.max(np.abs(stiffness @ x0)))
    np.testing.assert_allclose(integrator.x, x0 + dt * v0 + a0 * dt * dt * 0.5, rtol=1e-14)


# --------------------------------------------------------------------------- API


def started(x0: float = 0.01) -> NewmarkExplicit:
    integrator = NewmarkExplicit(M_SDOF, 2819.0, 0.01)
    integrator.initialize(x0, 0.0, 0.0, K_SDOF * x0)
    for _ in range(3):
        target = integrator.predict()
        integrator.correct(K_SDOF * float(target[0]), 0.0)
        integrator.commit()
    return integrator


def snapshot(integrator: Integrator) -> tuple:
    return (
        integrator.x.tolist(),
        integrator.v.tolist(),
        integrator.a.tolist(),
        integrator.step,
        integrator.t,
        integrator.status,
    )


def test_class_attributes_and_registry() -> None:
    assert NewmarkExplicit.name == 'newmark_explicit'
    assert NewmarkExplicit.stability_limit == 2.0
    assert NewmarkExplicit.needs_initial_stiffness is False
    assert SCHEMES['newmark_explicit'] is NewmarkExplicit
    integrator = make_integrator('newmark_explicit', mass=1.0, damping=0.0, dt=0.1)
    assert isinstance(integrator, NewmarkExplicit)
    assert integrator.dt == 0.1


def test_make_integrator_rejects_unknown_names_listing_valid_ones() -> None:
    with pytest.raises(ConfigError, match='newmark_explicit') as info:
        make_integrator('central_difference', mass=1.0, damping=0.0, dt=0.1)
    assert 'central_difference' in str(info.value)
    assert '\n' not in str(info.value)


@pytest.mark.parametrize('dt', [0.0, -0.01, math.nan, math.inf, 'fast'])
def test_invalid_dt_is_a_config_error_naming_dt(dt: object) -> None:
    with pytest.raises(ConfigError, match='dt'):
        NewmarkExplicit(M_SDOF, 0.0, dt)


@pytest.mark.parametrize(
    'mass, damping, name',
    [
        (np.eye(2), np.eye(3), 'damping'),
        (np.ones((2, 3)), np.eye(2), 'mass'),
        (np.array([[1.0, 2.0], [2.0, 1.0]]), np.eye(2), 'mass'),  # indefinite
        (np.array([[1.0, 0.1], [0.0, 1.0]]), np.eye(2), 'mass'),  # not symmetric
        (-1.0, 0.0, 'mass'),
        (np.eye(2), np.array([[np.nan, 0.0], [0.0, 1.0]]), 'damping'),
    ],
)
def test_invalid_matrices_are_config_errors(mass: object, damping: object, name: str) -> None:
    with pytest.raises(ConfigError, match=name):
        NewmarkExplicit(mass, damping, 0.01)


def test_initial_state_and_time_bookkeeping() -> None:
    integrator = NewmarkExplicit(M_SDOF, 100.0, 0.01)
    assert integrator.status == 'idle'
    integrator.initialize(0.01, 0.2, 500.0, K_SDOF * 0.01)
    assert integrator.status == 'running'
    assert integrator.step == 0 and integrator.t == 0.0
    assert integrator.a[0] == pytest.approx((500.0 - 100.0 * 0.2 - K_SDOF * 0.01) / M_SDOF)
    for _ in range(7):
        integrator.predict()
        integrator.correct(0.0, 0.0)
        integrator.commit()
    assert integrator.step == 7
    assert integrator.t == 7 * 0.01


def test_state_properties_cannot_modify_the_integrator() -> None:
    integrator = started()
    x = integrator.x
    with pytest.raises(ValueError):
        x[0] = 1.0
    target = integrator.predict()
    target[0] = 123.0  # the caller's copy
    integrator.correct(0.0, 0.0)
    integrator.commit()
    assert integrator.x[0] != 123.0


def test_predict_before_initialize_is_an_error() -> None:
    with pytest.raises(IntegratorError, match='initialize'):
        NewmarkExplicit(M_SDOF, 0.0, 0.01).predict()


def test_predict_twice_is_an_error_and_changes_nothing() -> None:
    integrator = started()
    before = snapshot(integrator)
    first = integrator.predict()
    with pytest.raises(IntegratorError, match='predict'):
        integrator.predict()
    assert snapshot(integrator) == before
    assert integrator.phase == 'predicted'
    integrator.correct(K_SDOF * float(first[0]), 0.0)
    integrator.commit()
    assert integrator.x[0] == first[0]


def test_correct_without_predict_is_an_error_and_changes_nothing() -> None:
    integrator = started()
    before = snapshot(integrator)
    with pytest.raises(IntegratorError, match='predict'):
        integrator.correct(1.0, 0.0)
    assert snapshot(integrator) == before
    with pytest.raises(IntegratorError):
        integrator.commit()
    assert snapshot(integrator) == before


@pytest.mark.parametrize(
    'force, load',
    [
        (math.nan, 0.0),
        (math.inf, 0.0),
        (0.0, -math.inf),
        (np.float64('nan'), 0.0),
        (np.array([math.nan]), 0.0),
        (0.0, np.array([math.inf])),
    ],
)
def test_non_finite_input_is_rejected_and_the_step_can_be_retried(
    force: object, load: object
) -> None:
    integrator = started()
    before = snapshot(integrator)
    target = integrator.predict()
    with pytest.raises(IntegratorError, match='finite'):
        integrator.correct(force, load)
    assert snapshot(integrator) == before
    assert integrator.status == 'running'
    with pytest.raises(IntegratorError):
        integrator.commit()  # nothing was corrected
    reference = started()
    reference_target = reference.predict()
    reference.correct(K_SDOF * float(reference_target[0]), 0.0)
    reference.commit()
    integrator.correct(K_SDOF * float(target[0]), 0.0)  # retry with a good measurement
    integrator.commit()
    assert snapshot(integrator) == snapshot(reference)


def test_mdof_rejects_wrong_shapes_and_nan_without_changing_state() -> None:
    mass, stiffness = shear_building()
    integrator = NewmarkExplicit(mass, np.zeros((3, 3)), 0.002)
    x0 = np.array([0.0, 0.0, 0.01])
    integrator.initialize(x0, np.zeros(3), np.zeros(3), stiffness @ x0)
    before = snapshot(integrator)
    target = integrator.predict()
    with pytest.raises(IntegratorError, match='restoring_force'):
        integrator.correct(np.zeros(2), np.zeros(3))
    with pytest.raises(IntegratorError, match='finite'):
        integrator.correct(np.array([0.0, np.nan, 0.0]), np.zeros(3))
    assert snapshot(integrator) == before
    integrator.correct(stiffness @ target, np.zeros(3))
    integrator.commit()
    assert integrator.step == 1


def test_revert_discards_the_trial() -> None:
    integrator = started()
    before = snapshot(integrator)
    integrator.predict()
    integrator.correct(5.0e3, 1.0e3)
    integrator.revert_to_last_step()
    assert snapshot(integrator) == before
    assert integrator.phase == 'committed'
    integrator.revert_to_last_step()  # nothing to revert: no-op
    target = integrator.predict()
    x, v, a = float(integrator.x[0]), float(integrator.v[0]), float(integrator.a[0])
    assert target[0] == x + 0.01 * v + a * 0.01 * 0.01 * 0.5


def test_divergence_sets_failed_status() -> None:
    # Omega = 3 is far beyond the limit; the target displacement overflows (with k = 9e-3 N/m the
    # forces stay finite until then) and the integrator fails.
    dt, m, k = 1.0, 1e-3, 9e-3
    integrator = NewmarkExplicit(m, 0.0, dt)
    integrator.initialize(1.0, 0.0, 0.0, k)
    with pytest.raises(IntegratorError, match='not finite'):
        for _ in range(10_000):
            target = integrator.predict()
            integrator.correct(k * float(target[0]), 0.0)
            integrator.commit()
    assert 300 < integrator.step < 400  # |lambda| = 6.85 per step
    assert integrator.status == 'failed'
    with pytest.raises(IntegratorError, match='failed'):
        integrator.predict()
    integrator.initialize(0.0, 0.0, 0.0, 0.0)
    assert integrator.status == 'running'
