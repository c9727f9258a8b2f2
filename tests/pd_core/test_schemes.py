"""The family of time-integration schemes against closed-form solutions and their analysis.

Schemes and their theoretical order of accuracy (global displacement error ~ Δt^order):

=============================  ==========================================================
newmark_explicit               2 (thesis eqs. 3.20-3.22)
explicit_generalized_alpha     2 (Hulbert & Chung 1996), with or without viscous damping
modified_newmark               1 for alpha > 0 (numerical damping ~ alpha*Omega/2), 2 for 0
alpha_os                       2 (HHT-alpha; exact for a linear specimen with K = K_I)
generalized_alpha_os           2 (generalized-alpha with gamma = 1/2 - alpha_m + alpha_f)
cr                             2 (poles of the average-acceleration method)
kr_alpha                       2 (spectrally the generalized-alpha method)
newmark_implicit & aliases     2 (gamma = 1/2), converged iterations
=============================  ==========================================================

Each integrator is driven as the session does: ``predict()`` -> command -> ``correct(r, p)``
-> ``commit()`` once the phase is ``'corrected'``, else ``predict()`` again.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
import scipy.linalg

from pd_core.errors import ConfigError, IntegratorError
from pd_core.schemes import (
    SCHEMES,
    Integrator,
    NewmarkExplicit,
    amplification_matrix_newmark_explicit,
    make_integrator,
    numerical_schemes,
)
from support.spectra import assert_same_spectrum

# Thesis SDOF (Appendix A): m = 2543.4 kg, k_ini = 312559 N/m.
M_SDOF = 2543.4
K_SDOF = 312559.0
OMEGA_SDOF = math.sqrt(K_SDOF / M_SDOF)

# (registry name, parameters, theoretical order). Damped cases must be stable with 5 %.
CASES: list[tuple[str, dict[str, Any], int]] = [
    ('newmark_explicit', {}, 2),
    ('explicit_generalized_alpha', {'rho_b': 0.8}, 2),
    ('explicit_generalized_alpha', {'rho_b': 0.0}, 2),
    ('modified_newmark', {'alpha': 0.1}, 1),
    ('modified_newmark', {'alpha': 0.0}, 2),
    ('alpha_os', {'alpha': -0.1}, 2),
    ('alpha_os', {'alpha': -1.0 / 3.0}, 2),
    ('generalized_alpha_os', {'rho_inf': 0.5}, 2),
    ('generalized_alpha_os', {'rho_inf': 1.0}, 2),
    ('cr', {}, 2),
    ('kr_alpha', {'rho_inf': 0.5}, 2),
    ('kr_alpha', {'rho_inf': 0.0}, 2),
    ('newmark_implicit', {'beta': 0.25, 'iterations': 2}, 2),
    ('newmark_implicit', {'beta': 1.0 / 6.0}, 2),
    ('average_acceleration', {}, 2),
    ('linear_acceleration', {'iterations': 1}, 2),
]


# Undamped only: explicit generalized-alpha with rho_b = 1 is unstable with viscous damping.
UNDAMPED_CASES = [*CASES, ('explicit_generalized_alpha', {'rho_b': 1.0}, 2)]


def start_order(name: str, order: int) -> int:
    """Observed order from a start with a_0 != 0.

    The model-based schemes' recurrences are second order (CR: central differences with
    ``Ω²/(1 + Ω²/4)``), but their first step ``x_1 = x_0 + Δt v_0 + Δt² α₂ a_0`` has
    ``α₂ → (1/2 + γ)`` (1 for CR), not 1/2: an ``O(Δt²)`` start error, i.e. an ``O(Δt)``
    global one, whenever ``a_0 ≠ 0``. From rest (a_0 = 0) they are second order.
    """
    return 1 if name in ('cr', 'kr_alpha') else order


def case_id(case: tuple[str, dict[str, Any], int]) -> str:
    name, parameters, _ = case
    text = ','.join(f'{key}={value:.3g}' for key, value in parameters.items())
    return f'{name}[{text}]' if text else name


# --------------------------------------------------------------------------- drivers


def step(integrator: Integrator, force: Callable[[np.ndarray], Any], load: Any) -> list:
    """One time step in the session's manner; returns the targets commanded."""
    targets = []
    while True:
        target = integrator.predict()
        assert integrator.phase == 'predicted'
        targets.append(target.copy())
        integrator.correct(force(target), load)
        if integrator.phase == 'corrected':
            break
        assert integrator.phase == 'iterating'
    integrator.commit()
    return targets


def run_sdof(
    name: str,
    parameters: dict[str, Any],
    m: float,
    c: float,
    k: float,
    dt: float,
    n_steps: int,
    x0: float = 0.0,
    v0: float = 0.0,
    load: Callable[[float], float] | None = None,
    k_initial: float | None = None,
) -> np.ndarray:
    """Linear specimen r = k x (K_I = k_initial, default k); returns the x history."""
    integrator = make_integrator(
        name, mass=m, damping=c, dt=dt,
        initial_stiffness=k if k_initial is None else k_initial, **parameters,
    )
    p = load if load is not None else (lambda t: 0.0)
    integrator.initialize(x0, v0, p(0.0), k * x0)
    xs = np.empty(n_steps + 1)
    xs[0] = integrator.x[0]
    for i in range(1, n_steps + 1):
        step(integrator, lambda target: k * float(target[0]), p(i * dt))
        xs[i] = integrator.x[0]
    return xs


def run_mdof(
    name: str,
    parameters: dict[str, Any],
    mass: np.ndarray,
    damping: np.ndarray,
    stiffness: np.ndarray,
    dt: float,
    n_steps: int,
    x0: np.ndarray,
    v0: np.ndarray,
) -> np.ndarray:
    """Linear MDOF (r = K x, K_I = K) in free vibration; returns the x history."""
    integrator = make_integrator(
        name, mass=mass, damping=damping, dt=dt, initial_stiffness=stiffness, **parameters
    )
    n = mass.shape[0]
    integrator.initialize(x0, v0, np.zeros(n), stiffness @ x0)
    xs = np.empty((n_steps + 1, n))
    xs[0] = integrator.x
    for i in range(1, n_steps + 1):
        step(integrator, lambda target: stiffness @ target, np.zeros(n))
        xs[i] = integrator.x
    return xs


def convergence_slope(dts: list[float], errors: list[float]) -> float:
    """Least-squares slope of log(error) against log(dt)."""
    return float(np.polyfit(np.log(dts), np.log(errors), 1)[0])


def spectral_radius(matrix: np.ndarray) -> float:
    return float(np.max(np.abs(scipy.linalg.eigvals(matrix))))


# --------------------------------------------------------------------------- exact solutions


def damped_sine_exact(
    m: float, c: float, k: float, x0: float, v0: float, p0: float, w_f: float, t: np.ndarray
) -> np.ndarray:
    """x(t) of m x'' + c x' + k x = p0 sin(w_f t), x(0) = x0, x'(0) = v0 (0 <= zeta < 1)."""
    w = math.sqrt(k / m)
    zeta = c / (2.0 * math.sqrt(k * m))
    w_d = w * math.sqrt(1.0 - zeta**2)
    r = w_f / w
    denominator = (1.0 - r**2) ** 2 + (2.0 * zeta * r) ** 2
    c_s = p0 / k * (1.0 - r**2) / denominator  # coefficient of sin(w_f t)
    d_s = p0 / k * (-2.0 * zeta * r) / denominator  # coefficient of cos(w_f t)
    a_t = x0 - d_s
    b_t = (v0 + zeta * w * a_t - c_s * w_f) / w_d
    transient = np.exp(-zeta * w * t) * (a_t * np.cos(w_d * t) + b_t * np.sin(w_d * t))
    return transient + c_s * np.sin(w_f * t) + d_s * np.cos(w_f * t)


def test_damped_sine_exact_solution_satisfies_the_equation_of_motion() -> None:
    m, k = M_SDOF, K_SDOF
    c = 2.0 * 0.05 * math.sqrt(k * m)
    p0, w_f = 2.0e4, 1.3 * OMEGA_SDOF
    h = 1e-4
    t = np.linspace(0.1, 3.0, 40)
    x = damped_sine_exact(m, c, k, 0.01, 0.2, p0, w_f, t)
    xp = damped_sine_exact(m, c, k, 0.01, 0.2, p0, w_f, t + h)
    xm = damped_sine_exact(m, c, k, 0.01, 0.2, p0, w_f, t - h)
    residual = m * (xp - 2 * x + xm) / h**2 + c * (xp - xm) / (2 * h) + k * x
    assert np.max(np.abs(residual - p0 * np.sin(w_f * t))) < 1e-4 * p0
    start = damped_sine_exact(m, c, k, 0.01, 0.2, p0, w_f, np.array([0.0, h]))
    assert start[0] == pytest.approx(0.01, abs=1e-15)
    assert (start[1] - start[0]) / h == pytest.approx(0.2, rel=1e-2)


def shear_building() -> tuple[np.ndarray, np.ndarray]:
    """3-storey shear building: lumped masses (kg) and stiffness matrix (N/m)."""
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


def test_modal_exact_solution_satisfies_the_equations_of_motion() -> None:
    mass, stiffness = shear_building()
    a0, a1 = 0.5, 1e-3
    damping = a0 * mass + a1 * stiffness
    x0 = np.array([0.005, 0.012, 0.02])
    v0 = np.array([0.0, -0.05, 0.1])
    h = 1e-5
    t = np.linspace(0.05, 0.5, 7)
    x = modal_exact(mass, stiffness, a0, a1, x0, v0, t)
    xp = modal_exact(mass, stiffness, a0, a1, x0, v0, t + h)
    xm = modal_exact(mass, stiffness, a0, a1, x0, v0, t - h)
    residual = (
        (xp - 2 * x + xm) @ mass.T / h**2 + (xp - xm) @ damping.T / (2 * h) + x @ stiffness.T
    )
    assert np.max(np.abs(residual)) < 1e-4 * float(np.max(np.abs(stiffness @ x0)))
    np.testing.assert_allclose(modal_exact(mass, stiffness, a0, a1, x0, v0, np.zeros(1))[0], x0)


# --------------------------------------------------------------------------- registry and API


def test_registry_names_and_classes() -> None:
    assert set(SCHEMES) == {
        'newmark_explicit', 'explicit_generalized_alpha', 'modified_newmark', 'alpha_os',
        'generalized_alpha_os', 'cr', 'kr_alpha', 'newmark_implicit', 'average_acceleration',
        'linear_acceleration', 'opensees_element',
    }
    assert SCHEMES['newmark_explicit'] is NewmarkExplicit
    for name, cls in SCHEMES.items():
        assert cls.name == name
        assert issubclass(cls, Integrator)
    needs_k = {name for name, cls in SCHEMES.items() if cls.needs_initial_stiffness}
    assert needs_k == {'alpha_os', 'generalized_alpha_os', 'cr', 'kr_alpha', 'newmark_implicit',
                       'average_acceleration', 'linear_acceleration', 'opensees_element'}
    assert SCHEMES['kr_alpha'].numerical_damping_parameter == 'rho_inf'
    assert SCHEMES['generalized_alpha_os'].numerical_damping_parameter == 'rho_inf'
    assert SCHEMES['alpha_os'].numerical_damping_parameter == 'alpha'
    assert SCHEMES['modified_newmark'].numerical_damping_parameter == 'alpha'
    assert SCHEMES['explicit_generalized_alpha'].numerical_damping_parameter == 'rho_b'
    assert SCHEMES['newmark_explicit'].numerical_damping_parameter is None


@pytest.mark.parametrize('case', CASES, ids=case_id)
def test_parameters_round_trip_through_make_integrator(case: tuple) -> None:
    name, parameters, _ = case
    integrator = make_integrator(name, mass=2.0, damping=0.1, dt=0.01, initial_stiffness=50.0,
                                 **parameters)
    assert integrator.name == name
    for key, value in parameters.items():
        assert integrator.parameters[key] == pytest.approx(value)
    again = make_integrator(name, mass=2.0, damping=0.1, dt=0.01, initial_stiffness=50.0,
                            **integrator.parameters)
    assert again.parameters == integrator.parameters
    assert again.stability_limit == integrator.stability_limit


NEEDS_K = sorted(name for name, cls in SCHEMES.items()
                 if cls.needs_initial_stiffness and not cls.external)


@pytest.mark.parametrize('name', NEEDS_K)
def test_schemes_needing_k_initial_refuse_to_start_without_it(name: str) -> None:
    with pytest.raises(ConfigError, match='initial_stiffness'):
        make_integrator(name, mass=1.0, damping=0.0, dt=0.01)


@pytest.mark.parametrize(
    'name, parameters, word',
    [
        ('explicit_generalized_alpha', {'rho_b': 1.2}, 'rho_b'),
        ('explicit_generalized_alpha', {'rho_b': -0.1}, 'rho_b'),
        ('modified_newmark', {'alpha': -0.05}, 'alpha'),
        ('modified_newmark', {'alpha': math.nan}, 'alpha'),
        ('alpha_os', {'alpha': 0.1}, 'alpha'),
        ('alpha_os', {'alpha': -0.5}, 'alpha'),
        ('generalized_alpha_os', {'rho_inf': 1.5}, 'rho_inf'),
        ('kr_alpha', {'rho_inf': 'low'}, 'rho_inf'),
        ('kr_alpha', {'rho_inf': True}, 'rho_inf'),
        ('newmark_implicit', {'beta': 0.0}, 'beta'),
        ('newmark_implicit', {'gamma': 0.4}, 'gamma'),
        ('newmark_implicit', {'iterations': 0}, 'iterations'),
        ('newmark_implicit', {'iterations': 2.5}, 'iterations'),
        ('newmark_implicit', {'increment_reduction': 0.0}, 'increment_reduction'),
        ('average_acceleration', {'iterations': -1}, 'iterations'),
    ],
)
def test_invalid_parameters_are_config_errors_naming_them(
    name: str, parameters: dict, word: str
) -> None:
    with pytest.raises(ConfigError, match=word) as info:
        make_integrator(name, mass=1.0, damping=0.0, dt=0.01, initial_stiffness=1.0,
                        **parameters)
    assert '\n' not in str(info.value)


def test_unknown_parameter_is_a_config_error_naming_it() -> None:
    with pytest.raises(ConfigError, match='rho_inf'):
        make_integrator('cr', mass=1.0, damping=0.0, dt=0.01, initial_stiffness=1.0,
                        rho_inf=0.5)


def test_parameter_dependent_stability_limits() -> None:
    cls = SCHEMES['explicit_generalized_alpha']
    assert cls.stability_limit == 2.0  # the class attribute: default rho_b = 1
    assert make_integrator('explicit_generalized_alpha', mass=1.0, damping=0.0, dt=0.1,
                           rho_b=0.0).stability_limit == pytest.approx(math.sqrt(2.4))
    assert cls.stability_limit == 2.0
    modified = make_integrator('modified_newmark', mass=1.0, damping=0.0, dt=0.1, alpha=0.3)
    assert modified.stability_limit == pytest.approx(2.0 / math.sqrt(1.6))
    linear = make_integrator('newmark_implicit', mass=1.0, damping=0.0, dt=0.1,
                             initial_stiffness=1.0, beta=1.0 / 6.0)
    assert linear.stability_limit == pytest.approx(math.sqrt(12.0))
    assert SCHEMES['linear_acceleration'].stability_limit == pytest.approx(math.sqrt(12.0))
    for name in ('alpha_os', 'generalized_alpha_os', 'cr', 'kr_alpha', 'average_acceleration'):
        assert math.isinf(SCHEMES[name].stability_limit)


def test_explicit_generalized_alpha_limit_accounts_for_viscous_damping() -> None:
    cls = SCHEMES['explicit_generalized_alpha']
    with pytest.raises(ConfigError, match='rho_b'):
        make_integrator('explicit_generalized_alpha', mass=1.0, damping=0.1, dt=0.01,
                        initial_stiffness=100.0)
    m, k = 1.0, 100.0
    c = 2 * 0.05 * math.sqrt(k * m)
    integrator = make_integrator('explicit_generalized_alpha', mass=m, damping=c, dt=0.01,
                                 initial_stiffness=k, rho_b=0.5)
    limit = integrator.stability_limit
    assert limit == pytest.approx(cls.stability_limit_for(rho_b=0.5, xi=0.05), rel=1e-9)
    assert 1.6 < limit < cls.stability_limit_for(rho_b=0.5)
    assert spectral_radius(cls.amplification_matrix(0.999 * limit, 0.05, rho_b=0.5)) <= 1 + 1e-9
    assert spectral_radius(cls.amplification_matrix(1.01 * limit, 0.05, rho_b=0.5)) > 1.0
    # Limits fall with damping, so the most damped mode's limit bounds all the modes.
    values = [cls.stability_limit_for(rho_b=0.8, xi=xi) for xi in (0.0, 0.02, 0.05, 0.1)]
    assert values == sorted(values, reverse=True)


# --------------------------------------------------------------------------- amplification


@pytest.mark.parametrize('case', CASES, ids=case_id)
@pytest.mark.parametrize('xi', [0.0, 0.05])
def test_amplification_matrix_reproduces_the_integrator(case: tuple, xi: float) -> None:
    # The linear SDOF with specimen stiffness K_I, stepped by the integrator, against
    # A^n (x0, dt v0, dt^2 a0): checks the closed-form matrix and the implementation.
    name, parameters, _ = case
    m, k = 3.0, 1200.0
    omega = math.sqrt(k / m)
    c = 2.0 * xi * math.sqrt(k * m)
    omega_dt = 0.9 * min(1.0, make_integrator(name, mass=m, damping=c, dt=1.0,
                                              initial_stiffness=k,
                                              **parameters).stability_limit)
    dt = omega_dt / omega
    matrix = SCHEMES[name].amplification_matrix(omega_dt, xi, **parameters)
    x0, v0 = 0.01, -0.3
    xs = run_sdof(name, parameters, m, c, k, dt, 40, x0=x0, v0=v0)
    state = np.array([x0, dt * v0, dt * dt * (-(c * v0 + k * x0) / m)])
    expected = [state[0]]
    for _ in range(40):
        state = matrix @ state
        expected.append(state[0])
    np.testing.assert_allclose(xs, expected, rtol=0, atol=1e-11)


@pytest.mark.parametrize('case', CASES, ids=case_id)
def test_spectral_radius_below_and_above_the_stability_limit(case: tuple) -> None:
    name, parameters, _ = case
    cls = SCHEMES[name]
    limit = cls.stability_limit_for(**parameters)
    assert limit == make_integrator(name, mass=1.0, damping=0.0, dt=0.1, initial_stiffness=1.0,
                                    **parameters).stability_limit
    # The limit an instance declares for a 5 %-damped SDOF (lower for explicit gen.-alpha).
    damped_limit = make_integrator(name, mass=1.0, damping=0.1, dt=0.1, initial_stiffness=1.0,
                                   **parameters).stability_limit
    assert damped_limit <= limit
    for xi, top in ((0.0, limit), (0.05, damped_limit)):
        top = top if math.isfinite(top) else 1e4
        grid = np.concatenate([np.geomspace(1e-3, 0.999 * top, 300), [0.99999 * top]])
        for omega_dt in grid:
            radius = spectral_radius(cls.amplification_matrix(omega_dt, xi, **parameters))
            assert radius <= 1 + 1e-7, (xi, omega_dt, radius)
    if math.isfinite(limit):
        for factor in (1.01, 1.1, 1.5):
            assert spectral_radius(cls.amplification_matrix(factor * limit, **parameters)) > 1.0


def test_newmark_explicit_amplification_is_the_thesis_matrix() -> None:
    for omega_dt in (0.1, 1.0, 1.9):
        np.testing.assert_array_equal(
            NewmarkExplicit.amplification_matrix(omega_dt),
            amplification_matrix_newmark_explicit(omega_dt),
        )
        # With a vanishing damping the damped form tends to eq. 3.7.
        np.testing.assert_allclose(
            NewmarkExplicit.amplification_matrix(omega_dt, 1e-12),
            amplification_matrix_newmark_explicit(omega_dt), atol=1e-10,
        )


@pytest.mark.parametrize(
    'name, parameters, rho_inf',
    [
        ('kr_alpha', {'rho_inf': 0.0}, 0.0),
        ('kr_alpha', {'rho_inf': 0.5}, 0.5),
        ('kr_alpha', {'rho_inf': 0.8}, 0.8),
        ('generalized_alpha_os', {'rho_inf': 0.0}, 0.0),
        ('generalized_alpha_os', {'rho_inf': 0.5}, 0.5),
        ('generalized_alpha_os', {'rho_inf': 0.9}, 0.9),
        ('alpha_os', {'alpha': -1.0 / 3.0}, 0.5),
        ('alpha_os', {'alpha': -0.1}, 0.9 / 1.1),
        ('cr', {}, 1.0),
        ('average_acceleration', {}, 1.0),
    ],
)
def test_spectral_radius_tends_to_rho_inf(name: str, parameters: dict, rho_inf: float) -> None:
    cls = SCHEMES[name]
    radii = [spectral_radius(cls.amplification_matrix(w, **parameters))
             for w in (10.0, 1e2, 1e3, 1e5)]
    assert radii[-1] == pytest.approx(rho_inf, abs=1e-3)
    assert abs(radii[-1] - rho_inf) <= abs(radii[0] - rho_inf) + 1e-12
    # Dissipative: the low-frequency radius stays close to 1 (second order).
    assert spectral_radius(cls.amplification_matrix(0.01, **parameters)) > 1 - 1e-5


@pytest.mark.parametrize('omega_dt', [0.05, 0.3, 1.0, 2.0, 10.0, 1e3])
@pytest.mark.parametrize('xi', [0.0, 0.05])
def test_model_based_schemes_have_the_poles_of_their_implicit_parents(
    omega_dt: float, xi: float
) -> None:
    # CR: the poles of the average-acceleration method (plus 0); KR-alpha: those of the
    # generalized-alpha method with the same rho_inf (Chen & Ricles 2008; Kolay & Ricles
    # 2014). The parents' matrices are built from their own (implicit) equations.
    def poles(name: str, **parameters: Any) -> np.ndarray:
        matrix = SCHEMES[name].amplification_matrix(omega_dt, xi, **parameters)
        return scipy.linalg.eigvals(matrix)

    cr = poles('cr')
    parent = poles('average_acceleration')
    assert_same_spectrum(cr, parent, atol=1e-9)
    for rho_inf in (0.0, 0.3, 0.5, 0.9):
        assert_same_spectrum(poles('kr_alpha', rho_inf=rho_inf),
                             poles('generalized_alpha_os', rho_inf=rho_inf), atol=1e-9)


@pytest.mark.parametrize('rho_b', [0.0, 0.25, 0.5, 0.8])
def test_explicit_generalized_alpha_bifurcation_and_limits(rho_b: float) -> None:
    cls = SCHEMES['explicit_generalized_alpha']
    omega_b = cls.bifurcation_limit(rho_b)
    assert omega_b == pytest.approx((1 + rho_b) * math.sqrt(2 - rho_b))
    eigenvalues = scipy.linalg.eigvals(cls.amplification_matrix(omega_b, rho_b=rho_b))
    # A triple root at -rho_b (rounding spreads it by ~eps^(1/3)).
    np.testing.assert_allclose(eigenvalues, -rho_b, atol=5e-5)
    limit = cls.stability_limit_for(rho_b=rho_b)
    assert limit >= omega_b
    eigenvalues = scipy.linalg.eigvals(cls.amplification_matrix(limit, rho_b=rho_b))
    assert np.min(np.abs(eigenvalues + 1.0)) < 1e-9  # the root leaves through -1


def test_modified_newmark_numerical_damping_is_alpha_omega_over_two() -> None:
    cls = SCHEMES['modified_newmark']
    for alpha in (0.02, 0.1):
        for omega_dt in (0.05, 0.1):
            eigenvalues = scipy.linalg.eigvals(cls.amplification_matrix(omega_dt, alpha=alpha))
            principal = eigenvalues[np.argmax(np.abs(eigenvalues.imag))]
            assert abs(principal) ** 2 == pytest.approx(1 - alpha * omega_dt**2, rel=1e-9)
            assert np.min(np.abs(eigenvalues)) < 1e-12  # the third root is zero
            xi_bar = -math.log(abs(principal)) / abs(np.angle(principal))
            assert xi_bar == pytest.approx(alpha * omega_dt / 2, rel=0.02)


def test_modified_newmark_with_alpha_zero_is_newmark_explicit_float_for_float() -> None:
    m, c, k, dt = M_SDOF, 2819.0, K_SDOF, 0.01

    def load(t: float) -> float:
        return 3.0e4 * math.sin(9.0 * t)

    reference = run_sdof('newmark_explicit', {}, m, c, k, dt, 500, x0=0.01, load=load)
    modified = run_sdof('modified_newmark', {'alpha': 0.0}, m, c, k, dt, 500, x0=0.01,
                        load=load)
    np.testing.assert_allclose(modified, reference, rtol=1e-12, atol=1e-15)


# --------------------------------------------------------------------------- SDOF accuracy


@pytest.mark.parametrize('case', UNDAMPED_CASES, ids=case_id)
def test_undamped_free_vibration_converges_at_the_theoretical_order(case: tuple) -> None:
    name, parameters, order = case
    order = start_order(name, order)
    x0, v0 = 0.02, 0.1
    t_end = 2.0
    dts = [0.01 / 2**j for j in range(5)]
    errors = []
    for dt in dts:
        n_steps = round(t_end / dt)
        xs = run_sdof(name, parameters, M_SDOF, 0.0, K_SDOF, dt, n_steps, x0=x0, v0=v0)
        t = np.arange(n_steps + 1) * dt
        exact = x0 * np.cos(OMEGA_SDOF * t) + v0 / OMEGA_SDOF * np.sin(OMEGA_SDOF * t)
        errors.append(float(np.max(np.abs(xs - exact))))
    slope = convergence_slope(dts, errors)
    assert order - 0.12 <= slope <= order + 0.15, (slope, errors)
    assert errors[-1] < (2e-3 if order == 2 else 2e-2) * math.hypot(x0, v0 / OMEGA_SDOF)


@pytest.mark.parametrize('case', CASES, ids=case_id)
@pytest.mark.parametrize('x0, v0, p0, ratio_f', [(0.02, -0.1, 0.0, 0.0), (0.0, 0.0, 2.0e4, 0.6),
                                                 (0.0, 0.0, 2.0e4, 1.7)])
def test_damped_response_converges_at_the_theoretical_order(
    case: tuple, x0: float, v0: float, p0: float, ratio_f: float
) -> None:
    name, parameters, order = case
    if x0 != 0.0:
        order = start_order(name, order)
    m, k = M_SDOF, K_SDOF
    c = 2.0 * 0.05 * math.sqrt(k * m)
    w_f = ratio_f * OMEGA_SDOF
    t_end = 3.0
    dts = [0.01 / 2**j for j in range(5)]
    errors = []
    for dt in dts:
        n_steps = round(t_end / dt)
        xs = run_sdof(name, parameters, m, c, k, dt, n_steps, x0=x0, v0=v0,
                      load=lambda t: p0 * math.sin(w_f * t))
        exact = damped_sine_exact(m, c, k, x0, v0, p0, w_f, np.arange(n_steps + 1) * dt)
        errors.append(float(np.max(np.abs(xs - exact))))
    slope = convergence_slope(dts, errors)
    assert order - 0.12 <= slope <= order + 0.15, (slope, errors)
    scale = max(abs(x0), p0 / k)
    assert errors[-1] < (1e-3 if order == 2 else 2e-2) * scale


# --------------------------------------------------------------------------- MDOF


@pytest.mark.parametrize('case', CASES, ids=case_id)
def test_mdof_free_vibration_converges_at_the_theoretical_order(case: tuple) -> None:
    name, parameters, order = case
    order = start_order(name, order)
    mass, stiffness = shear_building()
    omegas = np.sqrt(scipy.linalg.eigh(stiffness, mass, eigvals_only=True))
    w1, w2 = omegas[0], omegas[1]  # Rayleigh damping, 5 % in modes 1 and 2
    a0, a1 = 2 * 0.05 * w1 * w2 / (w1 + w2), 2 * 0.05 / (w1 + w2)
    damping = a0 * mass + a1 * stiffness
    x0 = np.array([0.005, 0.012, 0.02])
    v0 = np.array([0.0, -0.05, 0.1])
    t_end = 0.5
    dt0 = 0.2 / omegas[-1]  # Omega_max = 0.2
    dts = [dt0 / 2**j for j in range(4)]
    errors = []
    for dt in dts:
        n_steps = round(t_end / dt)
        xs = run_mdof(name, parameters, mass, damping, stiffness, dt, n_steps, x0, v0)
        exact = modal_exact(mass, stiffness, a0, a1, x0, v0, np.arange(n_steps + 1) * dt)
        errors.append(float(np.max(np.abs(xs - exact))))
    slope = convergence_slope(dts, errors)
    assert order - 0.15 <= slope <= order + 0.2, (slope, errors)
    assert errors[-1] < (1e-3 if order == 2 else 1e-2) * float(np.max(np.abs(x0)))


@pytest.mark.parametrize('case', CASES, ids=case_id)
def test_uncoupled_mdof_matches_independent_sdof_runs(case: tuple) -> None:
    name, parameters, _ = case
    m = np.diag([M_SDOF, 2.0 * M_SDOF])
    k = np.diag([K_SDOF, 3.0 * K_SDOF])
    c = np.diag([1000.0, 2500.0])
    dt = 0.01
    xs = run_mdof(name, parameters, m, c, k, dt, 300, np.array([0.01, -0.02]),
                  np.array([0.1, 0.0]))
    first = run_sdof(name, parameters, M_SDOF, 1000.0, K_SDOF, dt, 300, x0=0.01, v0=0.1)
    second = run_sdof(name, parameters, 2.0 * M_SDOF, 2500.0, 3.0 * K_SDOF, dt, 300, x0=-0.02)
    np.testing.assert_allclose(xs[:, 0], first, rtol=0, atol=1e-12)
    np.testing.assert_allclose(xs[:, 1], second, rtol=0, atol=1e-12)


# --------------------------------------------------------------------------- alpha-OS


def opensees_alpha_os(
    alpha_os: float, m: float, c: float, k_initial: float, specimen: Callable[[float], float],
    dt: float, x0: float, loads: list[float],
) -> list[float]:
    """The alpha-OS step in OpenSees's AlphaOS convention (weights alpha_os, 1 - alpha_os)."""
    beta = (2.0 - alpha_os) ** 2 / 4.0
    gamma = 1.5 - alpha_os
    x, v = x0, 0.0
    r = specimen(x0)
    a = (loads[0] - c * v - r) / m
    history = [x]
    for p_new, p_old in zip(loads[1:], loads[:-1]):
        x_pred = x + dt * v + dt * dt * (0.5 - beta) * a
        v_pred = v + dt * (1.0 - gamma) * a
        r_pred = specimen(x_pred)
        # m a + alpha_os (c v_new + r_new - p_new) + (1 - alpha_os)(c v + r - p_old) = 0,
        # v_new = v_pred + gamma dt a, r_new = r_pred + k_initial beta dt^2 a
        lhs = m + alpha_os * (gamma * dt * c + beta * dt * dt * k_initial)
        rhs = alpha_os * (p_new - r_pred - c * v_pred) + (1.0 - alpha_os) * (p_old - r - c * v)
        a = rhs / lhs
        x = x_pred + beta * dt * dt * a
        v = v_pred + gamma * dt * a
        r = r_pred + k_initial * beta * dt * dt * a
        history.append(x)
    return history


@pytest.mark.parametrize('alpha_os', [1.0, 0.9, 2.0 / 3.0])
def test_alpha_os_matches_the_opensees_convention(alpha_os: float) -> None:
    cls = SCHEMES['alpha_os']
    alpha = cls.alpha_from_opensees(alpha_os)
    assert cls.alpha_to_opensees(alpha) == pytest.approx(alpha_os)
    beta, gamma = cls.newmark_parameters(alpha)
    assert beta == pytest.approx((2.0 - alpha_os) ** 2 / 4.0)
    assert gamma == pytest.approx(1.5 - alpha_os)
    m, c, k_i, dt = M_SDOF, 2819.0, K_SDOF, 0.02

    def specimen(x: float) -> float:  # softening, nonlinear: the OS correction matters
        return k_i * 0.01 * math.tanh(x / 0.01)

    loads = [4.0e4 * math.sin(7.0 * i * dt) for i in range(400)]
    reference = opensees_alpha_os(alpha_os, m, c, k_i, specimen, dt, 0.005, loads)
    integrator = make_integrator('alpha_os', mass=m, damping=c, dt=dt, initial_stiffness=k_i,
                                 alpha=alpha)
    integrator.initialize(0.005, 0.0, loads[0], specimen(0.005))
    xs = [float(integrator.x[0])]
    for load in loads[1:]:
        step(integrator, lambda target: specimen(float(target[0])), load)
        xs.append(float(integrator.x[0]))
    np.testing.assert_allclose(xs, reference, rtol=1e-10, atol=1e-14)
    assert max(abs(x) for x in xs) > 0.01  # the specimen went nonlinear


def test_alpha_os_parameter_range_is_the_opensees_range() -> None:
    cls = SCHEMES['alpha_os']
    assert cls.alpha_from_opensees(2.0 / 3.0) == pytest.approx(-1.0 / 3.0)
    assert cls.alpha_from_opensees(1.0) == 0.0
    for alpha_os in (0.6, 1.05):
        with pytest.raises(ConfigError, match='alpha'):
            make_integrator('alpha_os', mass=1.0, damping=0.0, dt=0.01, initial_stiffness=1.0,
                            alpha=cls.alpha_from_opensees(alpha_os))


@pytest.mark.parametrize('name', ['alpha_os', 'generalized_alpha_os', 'newmark_implicit'])
def test_committed_restoring_force_is_corrected_with_k_initial(name: str) -> None:
    mass, stiffness = shear_building()
    k_initial = stiffness
    specimen = 0.7 * stiffness  # softening: the measured force differs from K_I x
    parameters = {'iterations': 1} if name == 'newmark_implicit' else {}
    integrator = make_integrator(name, mass=mass, damping=np.zeros((3, 3)), dt=0.02,
                                 initial_stiffness=k_initial, **parameters)
    x0 = np.array([0.004, 0.008, 0.012])
    integrator.initialize(x0, np.zeros(3), np.zeros(3), specimen @ x0)
    np.testing.assert_array_equal(integrator.r, specimen @ x0)
    for _ in range(5):
        targets = step(integrator, lambda target: specimen @ target, np.zeros(3))
        last = targets[-1]
        assert np.max(np.abs(integrator.x - last)) > 1e-9  # x is the corrected one
        np.testing.assert_allclose(
            integrator.r, specimen @ last + k_initial @ (integrator.x - last),
            rtol=1e-12, atol=1e-6,
        )
        # The equation of motion holds with the committed (corrected) force for newmark.
        if name == 'newmark_implicit':
            residual = mass @ integrator.a + integrator.r
            assert np.max(np.abs(residual)) < 1e-6 * float(np.max(np.abs(integrator.r)))


@pytest.mark.parametrize('name', ['newmark_explicit', 'explicit_generalized_alpha',
                                  'modified_newmark', 'cr', 'kr_alpha'])
def test_committed_restoring_force_is_the_measured_one(name: str) -> None:
    integrator = make_integrator(name, mass=2.0, damping=0.0, dt=0.01, initial_stiffness=80.0)
    integrator.initialize(0.01, 0.0, 0.0, 0.8)
    for i in range(4):
        targets = step(integrator, lambda target, i=i: 60.0 * float(target[0]) + i, 0.0)
        assert float(integrator.x[0]) == float(targets[-1][0])
        assert float(integrator.r[0]) == 60.0 * float(targets[-1][0]) + i


# --------------------------------------------------------------------------- stiffening


@pytest.mark.parametrize('name', ['alpha_os', 'generalized_alpha_os', 'cr', 'kr_alpha'])
@pytest.mark.parametrize('ratio', [2.0, 4.0])
def test_stiffening_specimen_destabilises_model_based_and_os_schemes(
    name: str, ratio: float
) -> None:
    # Omega = 5 from K_I: far inside the unconditional range for a linear specimen.
    m, k_initial, dt = 1.0, 1.0, 5.0
    stiffening = run_bounded(name, m, k_initial, ratio * k_initial, dt)
    softening = run_bounded(name, m, k_initial, 0.5 * k_initial, dt)
    assert stiffening > 1e6  # diverged (or failed with a non-finite state)
    assert softening < 10.0  # bounded by a small multiple of x0 = 1


def run_bounded(name: str, m: float, k_initial: float, k: float, dt: float) -> float:
    """Largest |x| of a free vibration from x0 = 1 over 2000 steps (inf on divergence)."""
    integrator = make_integrator(name, mass=m, damping=0.0, dt=dt, initial_stiffness=k_initial)
    integrator.initialize(1.0, 0.0, 0.0, k)
    largest = 1.0
    try:
        for _ in range(2000):
            step(integrator, lambda target: k * float(target[0]), 0.0)
            largest = max(largest, abs(float(integrator.x[0])))
            if largest > 1e12:
                return math.inf
    except IntegratorError:
        return math.inf
    return largest


def test_softening_specimen_response_decays_for_dissipative_schemes() -> None:
    for name in ('alpha_os', 'generalized_alpha_os', 'kr_alpha'):
        integrator = make_integrator(name, mass=1.0, damping=0.0, dt=5.0, initial_stiffness=1.0)
        integrator.initialize(1.0, 0.0, 0.0, 0.5)
        for _ in range(2000):
            step(integrator, lambda target: 0.5 * float(target[0]), 0.0)
        assert abs(float(integrator.x[0])) < 1e-3, name


# --------------------------------------------------------------------------- implicit Newmark


def newmark_reference(
    m: float, c: float, k: float, dt: float, beta: float, x0: float, loads: list[float]
) -> list[float]:
    """Exact (converged) Newmark, gamma = 1/2, linear stiffness k, solved in closed form."""
    gamma = 0.5
    x, v = x0, 0.0
    a = (loads[0] - c * v - k * x) / m
    history = [x]
    k_hat = m / (beta * dt * dt) + gamma * c / (beta * dt) + k
    for load in loads[1:]:
        x_pred = x + dt * v + (0.5 - beta) * dt * dt * a
        v_pred = v + (1.0 - gamma) * dt * a
        x_new = (load + m * x_pred / (beta * dt * dt)
                 - c * (v_pred - gamma * x_pred / (beta * dt))) / k_hat
        a = (x_new - x_pred) / (beta * dt * dt)
        v = v_pred + gamma * dt * a
        x = x_new
        history.append(x)
    return history


def run_implicit(
    parameters: dict[str, Any], m: float, c: float, k_initial: float, k: float, dt: float,
    x0: float, loads: list[float], name: str = 'newmark_implicit',
) -> tuple[list[float], list[list[float]]]:
    """Returns the committed x and, per step, the actuator path (previous + targets)."""
    integrator = make_integrator(name, mass=m, damping=c, dt=dt, initial_stiffness=k_initial,
                                 **parameters)
    integrator.initialize(x0, 0.0, loads[0], k * x0)
    xs = [float(integrator.x[0])]
    paths = []
    position = x0  # where the actuator is
    for load in loads[1:]:
        path = [position]
        iterations = []
        while True:
            target = float(integrator.predict()[0])
            iterations.append(integrator.iteration)
            path.append(target)
            position = target
            integrator.correct(k * target, load)
            if integrator.phase == 'corrected':
                break
        assert iterations == list(range(integrator.iterations_per_step))
        integrator.commit()
        assert integrator.iteration == 0
        paths.append(path)
        xs.append(float(integrator.x[0]))
    return xs, paths


def plain_modified_newton_paths(
    m: float, c: float, k_initial: float, k: float, dt: float, x0: float, loads: list[float],
    iterations: int, reduction: float = 1.0,
) -> list[list[float]]:
    """The iteration of NewmarkImplicit (beta = 1/4) without the forward-only safeguard.

    Returns, per step, the actuator path: the previous position, then the N targets.
    """
    beta, gamma = 0.25, 0.5
    k_hat = m / (beta * dt * dt) + gamma * c / (beta * dt) + k_initial
    x, v = x0, 0.0
    a = (loads[0] - k * x0) / m
    position, force = x0, k * x0
    paths = []
    for i, (p_old, p_new) in enumerate(zip(loads[:-1], loads[1:])):
        p_guess = 2.0 * p_old - (loads[i - 1] if i else p_old)  # the predictor's load
        x_pred = x + dt * v + (0.5 - beta) * dt * dt * a
        v_pred = v + (1.0 - gamma) * dt * a

        def increment(trial: float, r: float, p: float, x_pred: float = x_pred,
                      v_pred: float = v_pred) -> float:
            offset = trial - x_pred
            return (p - m * offset / (beta * dt * dt)
                    - c * (v_pred + gamma * offset / (beta * dt)) - r) / k_hat

        path = [position]
        target = position + reduction * increment(position, force, p_guess)
        for i in range(iterations):
            path.append(target)
            force = k * target
            if i + 1 < iterations:
                target = target + reduction * increment(target, force, p_new)
        position = target
        x = target + increment(target, force, p_new)
        a = (x - x_pred) / (beta * dt * dt)
        v = v_pred + gamma * dt * a
        paths.append(path)
    return paths


@pytest.mark.parametrize('beta', [0.25, 1.0 / 6.0])
@pytest.mark.parametrize('iterations', [1, 2, 4])
def test_implicit_with_a_linear_k_initial_specimen_is_exact_newmark(
    beta: float, iterations: int
) -> None:
    m, k, dt = M_SDOF, K_SDOF, 0.05  # Omega = 0.55
    c = 2.0 * 0.05 * math.sqrt(k * m)
    loads = [3.0e4 * math.sin(6.0 * i * dt) for i in range(300)]
    xs, _ = run_implicit({'beta': beta, 'iterations': iterations}, m, c, k, k, dt, 0.01, loads)
    reference = newmark_reference(m, c, k, dt, beta, 0.01, loads)
    np.testing.assert_allclose(xs, reference, rtol=0, atol=1e-12)


@pytest.mark.parametrize('ratio', [0.6, 0.85])
@pytest.mark.parametrize('reduction', [1.0, 0.9])
def test_implicit_iterations_converge_to_the_exact_average_acceleration_result(
    ratio: float, reduction: float
) -> None:
    # Softening linear specimen k = ratio k_I at Omega_I = 2 (large steps), damped free
    # vibration: each scaled correction multiplies the step error by
    # 1 - s k_hat_true/k_hat (0.2 and 0.075 for s = 1).
    m, k_initial, c = 1.0, 1.0, 0.05
    k = ratio * k_initial
    dt = 2.0
    loads = [0.0] * 150
    reference = newmark_reference(m, c, k, dt, 0.25, 0.1, loads)
    errors = []
    for iterations in range(1, 9):
        xs, _ = run_implicit({'iterations': iterations, 'increment_reduction': reduction},
                             m, c, k_initial, k, dt, 0.1, loads)
        errors.append(float(np.max(np.abs(np.array(xs) - reference))))
    assert all(later < earlier for earlier, later in zip(errors, errors[1:])), errors
    k_hat = 4.0 * m / dt**2 + 2.0 * c / dt + k_initial
    factor = 1.0 - reduction * (4.0 * m / dt**2 + 2.0 * c / dt + k) / k_hat
    assert errors[-1] / errors[-2] == pytest.approx(factor, rel=0.05), errors
    assert errors[-1] < 1e-3 * errors[0]


def seismic_like(dt: float, duration: float, scale: float) -> list[float]:
    """A smooth multi-frequency load history sampled at dt."""
    return [scale * (math.sin(0.9 * i * dt) + 0.5 * math.sin(2.3 * i * dt + 1.0)
                     + 0.3 * math.sin(5.1 * i * dt)) for i in range(round(duration / dt))]


@pytest.mark.parametrize(
    'ratio, reduction, omega_dt',
    [(0.6, 0.9, 0.2), (0.95, 0.9, 0.2), (1.0, 1.0, 0.2), (0.6, 1.0, 2.0), (2.0, 0.9, 0.2),
     (2.0, 1.0, 2.0), (3.0, 0.9, 1.0)],
)
def test_implicit_actuator_path_only_goes_forward_within_a_step(
    ratio: float, reduction: float, omega_dt: float
) -> None:
    # Per step the actuator goes from the previous target through the iterated targets:
    # that path must be monotonic (softening, K_I, stiffening; small and large steps).
    m, k_initial = 1.0, 1.0
    k = ratio * k_initial
    dt = omega_dt
    loads = seismic_like(dt, 40.0, 0.3)
    _, paths = run_implicit({'iterations': 4, 'increment_reduction': reduction}, m, 0.05,
                            k_initial, k, dt, 0.0, loads)
    assert len(paths) == len(loads) - 1 and all(len(path) == 5 for path in paths)
    for path in paths:
        moves = np.diff(path)
        assert np.all(moves >= -1e-15) or np.all(moves <= 1e-15), path


def test_plain_modified_newton_would_reverse() -> None:
    # Guards the test above. With a softening specimen in free vibration the safeguard never
    # acts and the integrator commands exactly the plain modified-Newton targets; with a
    # stiffening one (k = 2 k_I at Omega_I = 2: error factor 1 - k_hat_t/k_hat = -0.5) the
    # plain iterates overshoot, i.e. the actuator would go back and forth.
    m, k_initial, dt = 1.0, 1.0, 2.0
    loads = [0.0] * 60
    for reduction in (1.0, 0.9):
        _, paths = run_implicit({'iterations': 4, 'increment_reduction': reduction}, m, 0.02,
                                k_initial, 0.6, dt, 0.1, loads)
        plain = plain_modified_newton_paths(m, 0.02, k_initial, 0.6, dt, 0.1, loads, 4,
                                            reduction)
        np.testing.assert_allclose(paths, plain, rtol=0, atol=1e-12)
    plain = plain_modified_newton_paths(m, 0.02, k_initial, 2.0, dt, 0.1, loads, 4)
    reversing = [path for path in plain
                 if not (np.all(np.diff(path) >= 0) or np.all(np.diff(path) <= 0))]
    assert len(reversing) > len(plain) // 2
    # With a seismic-like load even a specimen with K = K_I would reverse at s = 1: the
    # predictor's extrapolated load over- or undershoots at random.
    loads = seismic_like(0.2, 40.0, 0.3)
    plain = plain_modified_newton_paths(m, 0.05, k_initial, 1.0, 0.2, 0.0, loads, 4)
    reversing = [path for path in plain
                 if not (np.all(np.diff(path) >= -1e-15) or np.all(np.diff(path) <= 1e-15))]
    assert len(reversing) > len(plain) // 4


def test_implicit_iterations_improve_on_a_single_trial_at_realistic_steps() -> None:
    # Omega_I = 0.2, softening specimen, seismic-like load: with the default s = 0.9 the
    # forward-only safeguard rarely acts, and three trials per step get much closer to the
    # exact implicit (average acceleration) solution than one.
    m, k_initial, c, dt = 1.0, 1.0, 0.05, 0.2
    k = 0.7 * k_initial
    loads = seismic_like(dt, 60.0, 0.3)
    reference = np.array(newmark_reference(m, c, k, dt, 0.25, 0.0, loads))
    errors = {}
    for iterations in (1, 3):
        xs, _ = run_implicit({'iterations': iterations}, m, c, k_initial, k, dt, 0.0, loads)
        errors[iterations] = float(np.max(np.abs(np.array(xs) - reference)))
    assert errors[3] < 0.05 * errors[1], errors
    assert errors[3] < 1e-3 * float(np.max(np.abs(reference)))


def test_implicit_iteration_contract_and_revert() -> None:
    integrator = make_integrator('average_acceleration', mass=1.0, damping=0.0, dt=0.1,
                                 initial_stiffness=4.0, iterations=3)
    assert integrator.iterations_per_step == 3
    integrator.initialize(0.1, 0.0, 0.0, 0.3)  # specimen r = 3 x, softer than K_I
    assert integrator.iteration == 0 and integrator.phase == 'committed'
    first = integrator.predict()
    assert integrator.iteration == 0 and integrator.phase == 'predicted'
    with pytest.raises(IntegratorError, match='predict'):
        integrator.predict()
    with pytest.raises(IntegratorError):
        integrator.commit()
    integrator.correct(3.0 * first, 0.0)
    assert integrator.phase == 'iterating' and integrator.iteration == 1
    with pytest.raises(IntegratorError):
        integrator.commit()
    with pytest.raises(IntegratorError, match='predict'):
        integrator.correct(0.0, 0.0)
    second = integrator.predict()
    assert integrator.iteration == 1 and integrator.phase == 'predicted'
    assert not np.array_equal(second, first)
    integrator.revert_to_last_step()
    assert integrator.iteration == 0 and integrator.phase == 'committed'
    assert integrator.step == 0
    np.testing.assert_array_equal(integrator.predict(), first)  # the step starts over
    integrator.correct(3.0 * first, 0.0)
    np.testing.assert_array_equal(integrator.predict(), second)
    integrator.correct(3.0 * second, 0.0)
    third = integrator.predict()
    assert integrator.iteration == 2
    integrator.correct(3.0 * third, 0.0)
    assert integrator.phase == 'corrected' and integrator.iteration == 2
    integrator.commit()
    assert integrator.step == 1 and integrator.iteration == 0
    assert integrator.phase == 'committed'


@pytest.mark.parametrize('name', sorted(n for n in numerical_schemes() if 'implicit' not in n
                                        and n not in ('average_acceleration',
                                                      'linear_acceleration')))
def test_single_iteration_schemes_reach_corrected_after_one_correct(name: str) -> None:
    integrator = make_integrator(name, mass=1.0, damping=0.0, dt=0.1, initial_stiffness=4.0)
    assert integrator.iterations_per_step == 1
    integrator.initialize(0.1, 0.0, 0.0, 0.4)
    for _ in range(3):
        integrator.predict()
        assert integrator.iteration == 0
        integrator.correct(0.3, 0.0)
        assert integrator.phase == 'corrected'
        integrator.commit()


@pytest.mark.filterwarnings('ignore:overflow:RuntimeWarning')
@pytest.mark.filterwarnings('ignore:invalid value:RuntimeWarning')
@pytest.mark.parametrize('case', CASES, ids=case_id)
def test_divergence_fails_cleanly(case: tuple) -> None:
    # A specimen far stiffer than the model (and beyond any explicit limit) blows up; the
    # integrator must stop with IntegratorError, never commit an inf/nan state.
    name, parameters, _ = case
    integrator = make_integrator(name, mass=1.0, damping=0.0, dt=1.0, initial_stiffness=1.0,
                                 **parameters)
    integrator.initialize(1.0, 0.0, 0.0, 100.0)
    with pytest.raises(IntegratorError, match='finite'):
        for _ in range(100_000):
            step(integrator, lambda target: 100.0 * float(target[0]), 0.0)
            state = np.concatenate([integrator.x, integrator.v, integrator.a, integrator.r])
            assert np.all(np.isfinite(state))
    assert integrator.step > 5
