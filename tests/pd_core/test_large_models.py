"""Large models (issue 13, goal 4): the O(n) paths of lumped-mass, tridiagonal models.

From :data:`~pd_core.schemes.linalg.LARGE_MODEL_DOF` DOFs on, a diagonal mass
matrix is checked and inverted in O(n), a tridiagonal stiffness gets its modes from a
tridiagonal eigensolver, a tridiagonal effective matrix is factorised by LAPACK ``?pttrf``,
Newmark explicit takes ``C (v + Δt/2 a)`` as one product, and a session's commands carry
their target as a tuple that also holds the integrator's array. These tests lower the
threshold so that small models take those paths, and compare them with the default ones.
"""

from __future__ import annotations

import copy
import pickle
import platform
from collections import deque
from typing import Any

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse

from pd_common.protocol import Command
from pd_core.dynamics import structure as structure_module
from pd_core.dynamics.structure import modal_analysis, omega_max
from pd_core.model.damping import rayleigh_damping
from pd_core.run.loop.dispatch import StepDispatcher
from pd_core.run.loop.session import TestSession as Session  # not a test class
from pd_core.run.runner import serve_queue, site_servers
from pd_core.run.test_file import from_dict
from pd_core.schemes import linalg as scheme_linalg
from pd_core.schemes import newmark_explicit as newmark_module
from pd_core.schemes.newmark_explicit import NewmarkExplicit


def large_from(monkeypatch: pytest.MonkeyPatch, n_dof: int) -> None:
    """Models of ``n_dof`` DOFs and more take the large-model paths."""
    monkeypatch.setattr(scheme_linalg, 'LARGE_MODEL_DOF', n_dof)
    monkeypatch.setattr(newmark_module, 'LARGE_MODEL_DOF', n_dof)
    monkeypatch.setattr(structure_module, 'LARGE_MODEL_DOF', n_dof)


def chain(n: int, seed: int = 13) -> tuple[np.ndarray, np.ndarray]:
    """A shear building's dense lumped mass and tridiagonal stiffness (varied storeys)."""
    rng = np.random.default_rng(seed)
    masses = rng.uniform(0.5e4, 1.5e4, n)
    stories = rng.uniform(0.5e8, 1.5e8, n)
    k = np.diag(stories + np.append(stories[1:], 0.0))
    k -= np.diag(stories[1:], 1) + np.diag(stories[1:], -1)
    return np.diag(masses), k


def building(n: int, scheme: str, steps: int = 60) -> dict[str, Any]:
    """An ``n``-story shear building whose first story is a bilinear specimen at a site."""
    names = [f'u{i + 1}' for i in range(n)]
    k, dt = 1.0e8, 0.005
    elements: list[dict[str, Any]] = [
        {'type': 'experimental', 'name': 'story1', 'site': 'lab', 'dofs': ['u1'],
         'initial_stiffness': k}]
    elements += [{'type': 'story', 'dofs': [names[i - 1], names[i]], 'stiffness': k}
                 for i in range(1, n)]
    t = np.arange(steps + 1) * dt
    record = (3.0 * np.sin(2 * np.pi * 1.3 * t) * np.minimum(t / 0.1, 1.0)).tolist()
    return {
        'test': {'id': f'large-{n}', 'scheme': scheme, 'dt': dt, 'duration': steps * dt},
        'structure': {'dof_names': names, 'mass': [1.0e4] * n, 'elements': elements,
                      'damping': {'rayleigh': {'modes': [1, 2], 'ratios': [0.05, 0.05]}}},
        'ground_motion': {'inline': {'dt': dt, 'acceleration': record}, 'units': 'm/s2'},
        'sites': {'lab': {'specimen': {'elements': [
            {'model': 'bilinear', 'stiffness': k, 'yield_force': 2.0e4,
             'hardening_ratio': 0.05}]}}},
    }


def run_session(raw: dict[str, Any]) -> Session:
    definition = from_dict(copy.deepcopy(raw), source='large.yaml')
    session = Session(definition)
    servers = site_servers(definition)
    queue: deque[tuple[str, Command]] = deque()
    dispatcher = StepDispatcher(session, lambda site, command: queue.append((site, command)))
    dispatcher.start()
    serve_queue(queue, servers, dispatcher)
    assert session.state.name == 'FINISHED', session.message
    return session


def test_modes_of_a_large_chain_equal_the_dense_eigensolver(monkeypatch: pytest.MonkeyPatch
                                                            ) -> None:
    m, k = chain(300)
    dense_omegas, dense_shapes = modal_analysis(m, k)
    dense_max = omega_max(m, k)
    large_from(monkeypatch, 64)
    assert structure_module._large_tridiagonal(m, k) is not None
    omegas, shapes = modal_analysis(m, k)
    np.testing.assert_allclose(omegas, dense_omegas, rtol=1e-10)
    np.testing.assert_allclose(shapes.T @ m @ shapes, np.eye(300), atol=1e-10)
    np.testing.assert_allclose(k @ shapes, m @ shapes * omegas**2,
                               atol=1e-9 * float(np.max(np.abs(k @ shapes))))
    # Distinct frequencies: the same shapes, with the same sign convention.
    scale = float(np.max(np.abs(dense_shapes[:, :20])))
    np.testing.assert_allclose(shapes[:, :20], dense_shapes[:, :20], atol=1e-8 * scale)
    assert omega_max(m, k) == pytest.approx(dense_max, rel=1e-12)


def test_large_checks_refuse_what_the_dense_ones_refuse(monkeypatch: pytest.MonkeyPatch
                                                        ) -> None:
    large_from(monkeypatch, 64)
    m, k = chain(100)
    bad_mass = m.copy()
    bad_mass[5, 5] = 0.0
    with pytest.raises(Exception, match='mass'):
        modal_analysis(bad_mass, k)
    with pytest.raises(Exception, match='mass'):
        NewmarkExplicit(bad_mass, np.zeros_like(m), 0.001)
    with pytest.raises(Exception, match='negative eigenvalue'):
        omega_max(m, -k)
    with pytest.raises(Exception, match='negative eigenvalue'):
        modal_analysis(m, -k)
    assert structure_module._is_symmetric(k) and structure_module._is_symmetric(m)
    skew = k.copy()
    skew[3, 4] *= 1.0 + 1e-9
    assert not structure_module._is_symmetric(skew)


@pytest.mark.parametrize('scheme', ['newmark_explicit', 'alpha_os', 'kr_alpha'])
def test_large_paths_give_the_default_paths_response(monkeypatch: pytest.MonkeyPatch,
                                                     scheme: str) -> None:
    raw = building(200, scheme)
    default = run_session(raw).history
    large_from(monkeypatch, 64)
    session = run_session(raw)
    integrator: Any = session._integrator
    factor = integrator._factor if scheme == 'newmark_explicit' else (
        integrator._effective if scheme == 'alpha_os' else integrator._d_minus_b)._factor
    assert factor[0] == 'tridiagonal'
    scale = float(np.max(np.abs(default.displacement)))
    assert scale > 1e-3
    for name in ('displacement', 'velocity', 'acceleration', 'restoring_force'):
        values = getattr(default, name)
        np.testing.assert_allclose(getattr(session.history, name), values, rtol=0.0,
                                   atol=1e-9 * float(np.max(np.abs(values))), err_msg=name)


def test_newmark_explicit_of_a_large_model_is_the_recursion_of_eqs_3_20_to_3_22() -> None:
    """Unpatched, at the threshold: the scheme against a dense numpy recursion."""
    n = scheme_linalg.LARGE_MODEL_DOF
    m, k = chain(n)
    c = 0.4 * m + 2e-4 * k
    dt = 0.001
    integrator = NewmarkExplicit(m, c, dt)
    assert integrator._factor[0] == 'tridiagonal'
    lu = scipy.linalg.lu_factor(m + dt * 0.5 * c)
    rng = np.random.default_rng(4)
    p = rng.normal(0.0, 1e4, (40, n))
    x, v, a = np.zeros(n), np.zeros(n), np.linalg.solve(m, p[0])
    integrator.initialize(np.zeros(n), np.zeros(n), p[0], np.zeros(n))
    np.testing.assert_allclose(integrator.a, a, rtol=1e-12, atol=1e-15)
    for i in range(1, 40):
        x = x + dt * v + a * dt * dt * 0.5
        target = integrator.predict()
        np.testing.assert_allclose(target, x, rtol=1e-10, atol=1e-14)
        a_new = scipy.linalg.lu_solve(lu, p[i] - k @ x - c @ v - dt * 0.5 * c @ a)
        v = v + dt * 0.5 * (a + a_new)
        a = a_new
        integrator.correct(k @ target, p[i])
        integrator.commit()
        np.testing.assert_allclose(integrator.v, v, rtol=1e-9, atol=1e-12 * np.max(np.abs(v)))
        np.testing.assert_allclose(integrator.a, a, rtol=1e-9, atol=1e-12 * np.max(np.abs(a)))


def test_a_large_command_target_is_a_tuple_holding_its_array() -> None:
    session = Session(from_dict(building(40, 'newmark_explicit', steps=4), source='t.yaml'))
    first = session.next_command()
    assert first is not None
    target = first.target_displacement
    assert isinstance(target, tuple) and len(target) == 40
    assert all(type(value) is float for value in target)
    array = np.array(target, dtype=float)
    np.testing.assert_array_equal(array, np.array(tuple(target)))
    array[0] = 1.0  # np.array copies: the command is unchanged
    assert target[0] == 0.0
    assert not np.asarray(target).flags.writeable
    for clone in (copy.deepcopy(first), pickle.loads(pickle.dumps(first))):
        assert clone == first
        np.testing.assert_array_equal(np.array(clone.target_displacement), array * 0.0)
    assert target == tuple(0.0 for _ in range(40))


def test_mode_frequencies_of_a_large_chain_are_the_dense_eigenvalues(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Bisection for the asked modes only (no mode shapes) against LAPACK's dense ``eigh``."""
    m, k = chain(300, seed=5)
    exact = scipy.linalg.eigh(k, m, eigvals_only=True)  # ω², ascending
    large_from(monkeypatch, 64)

    def no_shapes(*_: Any) -> None:
        raise AssertionError('a large tridiagonal model must not compute mode shapes')

    monkeypatch.setattr(structure_module, 'modal_analysis', no_shapes)
    modes = (1, 2, 17, 300)
    omegas = structure_module.mode_frequencies(m, k, modes)
    # Both solvers are accurate to a few ulps of the largest eigenvalue (LAPACK's bound for
    # bisection and for eigh), far below the spacing of neighbouring modes (> 1e-6 × it here).
    wanted = exact[[mode - 1 for mode in modes]]
    np.testing.assert_allclose(omegas**2, wanted, rtol=0.0,
                               atol=64 * np.finfo(float).eps * float(exact[-1]))
    assert float(np.min(np.diff(exact))) > 1e-6 * float(exact[-1])
    with pytest.raises(Exception, match=r'modes: expected mode numbers in 1\.\.300'):
        structure_module.mode_frequencies(m, k, (0, 2))
    with pytest.raises(Exception, match='negative eigenvalue'):
        structure_module.mode_frequencies(m, -k, (1, 2))


def test_rayleigh_damping_of_a_large_chain_is_the_dense_one(monkeypatch: pytest.MonkeyPatch
                                                            ) -> None:
    m, k = chain(300, seed=8)
    w = np.sqrt(scipy.linalg.eigh(k, m, eigvals_only=True))
    a1 = 2.0 * (0.05 * w[2] - 0.02 * w[0]) / (w[2] ** 2 - w[0] ** 2)  # closed form
    a0 = 2.0 * 0.02 * w[0] - a1 * w[0] ** 2
    large_from(monkeypatch, 64)
    c = rayleigh_damping(m, k, (1, 3), (0.02, 0.05))
    np.testing.assert_allclose(c, a0 * m + a1 * k, rtol=1e-9, atol=1e-9 * float(np.max(abs(c))))


def test_tridiagonal_products_are_the_csr_products_to_the_bit(monkeypatch: pytest.MonkeyPatch
                                                             ) -> None:
    m, k = chain(400, seed=3)
    large_from(monkeypatch, 64)
    bands = scheme_linalg.large_bands(k)
    assert bands is not None
    banded = scheme_linalg.operator(k)
    assert isinstance(banded, scheme_linalg.Tridiagonal)
    csr = scipy.sparse.csr_matrix(k)
    from_csr = scheme_linalg.Tridiagonal.of_csr(csr)
    assert from_csr is not None
    rng = np.random.default_rng(21)
    # scipy's CSR loop sums a row in order, one rounding per product and per addition, as
    # x86-64 builds without FMA do (bit for bit); a build that fuses them (aarch64) differs by
    # at most a rounding or two per term.
    bitwise = platform.machine().lower() in ('x86_64', 'amd64')
    for scale in (1e-6, 1.0, 1e6):
        x = rng.normal(0.0, scale, 400)
        expected = csr @ x
        bound = 4.0 * np.finfo(float).eps * (np.abs(k) @ np.abs(x))
        for product in (banded @ x, from_csr @ x):
            if bitwise:
                assert np.array_equal(product, expected)
            else:
                assert np.all(np.abs(product - expected) <= bound)
    columns = rng.normal(size=(400, 3))
    assert np.array_equal(banded @ columns, csr @ columns)  # (the same CSR product)
    lumped = scheme_linalg.operator(m)
    x = rng.normal(size=400)
    assert np.array_equal(lumped @ x, np.diag(m) * x)
    # Not tridiagonal, or small: the general paths.
    wide = k.copy()
    wide[0, 5] = wide[5, 0] = 1.0
    assert scheme_linalg.large_bands(wide) is None
    assert scheme_linalg.Tridiagonal.of_csr(scipy.sparse.csr_matrix(wide)) is None
    assert not isinstance(scheme_linalg.operator(wide), scheme_linalg.Tridiagonal)
    assert scheme_linalg.large_bands(k[:32, :32]) is None


def test_a_large_diagonal_system_solves_as_the_tridiagonal_one(monkeypatch: pytest.MonkeyPatch
                                                              ) -> None:
    m, _ = chain(500, seed=2)
    large_from(monkeypatch, 64)
    bands = scheme_linalg.large_bands(m)
    factor = scheme_linalg.cholesky_or_lu(m, True, bands)
    assert factor[0] == 'diagonal'
    general = scheme_linalg.cholesky_or_lu(m, True)  # no bands given: the LDLᵀ path
    assert general[0] == 'tridiagonal'
    rhs = np.random.default_rng(9).normal(0.0, 1e3, 500)
    solution = scheme_linalg.solve_factored(factor, rhs)
    assert np.array_equal(solution, scheme_linalg.solve_factored(general, rhs))
    np.testing.assert_allclose(m @ solution, rhs, rtol=1e-14)
    negative = m.copy()
    negative[7, 7] = -1.0  # not positive definite: not the division
    assert scheme_linalg.cholesky_or_lu(negative, True,
                                        scheme_linalg.large_bands(negative))[0] != 'diagonal'
