"""Lumped-mass structural model (thesis §3.2): validation, modes, damping, loads."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pd_core.dynamics.structure import (
    Structure,
    damping_from_ratio,
    effective_load,
    modal_analysis,
    omega_max,
    rayleigh_frequencies,
)
from pd_core.errors import ConfigError
from pd_core.matrices import as_matrix, as_vector

M_THESIS = 2543.4
K_THESIS = 312559.0


def shear_building() -> tuple[np.ndarray, np.ndarray]:
    masses = np.array([3.0e4, 2.5e4, 2.0e4])
    k1, k2, k3 = 6.0e7, 4.5e7, 3.0e7
    stiffness = np.array([[k1 + k2, -k2, 0.0], [-k2, k2 + k3, -k3], [0.0, -k3, k3]])
    return np.diag(masses), stiffness


def valid_kwargs() -> dict:
    mass, stiffness = shear_building()
    return {
        'dof_names': ('floor1', 'floor2', 'roof'),
        'mass': mass,
        'damping': 1e-3 * stiffness,
        'initial_stiffness': stiffness,
        'influence': np.ones(3),
    }


# --------------------------------------------------------------------------- Structure


def test_structure_stores_read_only_copies() -> None:
    kwargs = valid_kwargs()
    structure = Structure(**kwargs)
    assert structure.n_dof == 3
    assert structure.dof_names == ('floor1', 'floor2', 'roof')
    kwargs['mass'][0, 0] = -1.0  # the caller's array
    assert structure.mass[0, 0] == 3.0e4
    with pytest.raises(ValueError):
        structure.mass[0, 0] = 1.0
    with pytest.raises(AttributeError):
        structure.mass = np.eye(3)  # type: ignore[misc]


def test_structure_equality_and_hash() -> None:
    first = Structure(**valid_kwargs())
    second = Structure(**valid_kwargs())
    assert first == second
    assert hash(first) == hash(second)
    changed = valid_kwargs()
    changed['influence'] = np.array([1.0, 1.0, 0.0])
    assert Structure(**changed) != first


def test_sdof_structure_from_nested_lists() -> None:
    structure = Structure(('x',), [[M_THESIS]], [[2819.0]], [[K_THESIS]], [1.0])
    assert structure.n_dof == 1
    assert structure.mass.shape == (1, 1)
    assert structure.influence.tolist() == [1.0]


@pytest.mark.parametrize(
    'field, value',
    [
        ('mass', np.eye(2)),
        ('damping', np.zeros((3, 2))),
        ('initial_stiffness', np.eye(4)),
        ('influence', np.ones(2)),
        ('influence', np.ones((3, 1))),
        ('mass', np.diag([1.0, 2.0, math.nan])),
        ('damping', np.full((3, 3), math.inf)),
        ('initial_stiffness', 'stiff'),
        ('mass', np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])),
        ('initial_stiffness', np.array([[2.0, -1.0, 0.0], [-1.1, 2.0, 0.0], [0.0, 0.0, 1.0]])),
        ('mass', np.diag([1.0, 0.0, 1.0])),
        ('mass', np.diag([1.0, -5.0, 1.0])),
    ],
)
def test_structure_validation_names_the_field(field: str, value: object) -> None:
    kwargs = valid_kwargs()
    kwargs[field] = value
    with pytest.raises(ConfigError, match=field) as info:
        Structure(**kwargs)
    assert '\n' not in str(info.value)


@pytest.mark.parametrize(
    'names', [(), ('a', 'a', 'b'), ('a', '', 'b'), 'abc', ('a', 2, 'b')]
)
def test_structure_validates_dof_names(names: object) -> None:
    kwargs = valid_kwargs()
    kwargs['dof_names'] = names
    with pytest.raises(ConfigError, match='dof_names'):
        Structure(**kwargs)


def test_damping_need_not_be_symmetric() -> None:
    kwargs = valid_kwargs()
    kwargs['damping'] = np.array([[1.0, 2.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    assert Structure(**kwargs).damping[0, 1] == 2.0


# --------------------------------------------------------------------------- as_matrix


def test_as_matrix_forms() -> None:
    np.testing.assert_array_equal(as_matrix(5.0, 3, 'mass'), 5.0 * np.eye(3))
    np.testing.assert_array_equal(as_matrix([1.0, 2.0, 3.0], 3, 'mass'), np.diag([1, 2, 3]))
    full = [[2.0, -1.0], [-1.0, 1.0]]
    np.testing.assert_array_equal(as_matrix(full, 2, 'stiffness'), np.array(full))
    np.testing.assert_array_equal(as_matrix(7, 1, 'mass'), np.array([[7.0]]))


@pytest.mark.parametrize(
    'value', [[1.0, 2.0], np.eye(2), np.ones((3, 2)), 'heavy', [1.0, math.nan, 2.0], None]
)
def test_as_matrix_rejects_bad_values_naming_the_parameter(value: object) -> None:
    with pytest.raises(ConfigError, match='my_matrix'):
        as_matrix(value, 3, 'my_matrix')


def test_as_vector_forms() -> None:
    np.testing.assert_array_equal(as_vector(1.0, 3, 'influence'), np.ones(3))
    np.testing.assert_array_equal(as_vector([1, 0, 1], 3, 'influence'), [1.0, 0.0, 1.0])
    with pytest.raises(ConfigError, match='influence'):
        as_vector([1.0, 0.0], 3, 'influence')


# --------------------------------------------------------------------------- modes


def test_modal_analysis_of_a_uniform_two_storey_shear_building() -> None:
    # Equal masses m and storey stiffnesses k: omega^2 = (k/m) (3 -+ sqrt(5)) / 2.
    m, k = 1000.0, 2.0e6
    mass = np.diag([m, m])
    stiffness = np.array([[2 * k, -k], [-k, k]])
    omegas, shapes = modal_analysis(mass, stiffness)
    expected = np.sqrt(k / m * np.array([(3 - math.sqrt(5)) / 2, (3 + math.sqrt(5)) / 2]))
    np.testing.assert_allclose(omegas, expected, rtol=1e-12)
    # First mode: both floors in phase, roof moves (1 + sqrt 5)/2 times the first floor.
    assert shapes[1, 0] / shapes[0, 0] == pytest.approx((1 + math.sqrt(5)) / 2, rel=1e-12)
    assert shapes[0, 1] * shapes[1, 1] < 0


def test_modal_analysis_is_mass_normalised_and_ascending() -> None:
    mass, stiffness = shear_building()
    omegas, shapes = modal_analysis(mass, stiffness)
    assert np.all(np.diff(omegas) > 0)
    np.testing.assert_allclose(shapes.T @ mass @ shapes, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(
        stiffness @ shapes, mass @ shapes @ np.diag(omegas**2), rtol=1e-10, atol=1e-3
    )
    assert omega_max(mass, stiffness) == pytest.approx(omegas[-1], rel=1e-14)


def test_sdof_omega_is_sqrt_k_over_m() -> None:
    omegas, shapes = modal_analysis(M_THESIS, K_THESIS)
    assert omegas[0] == pytest.approx(math.sqrt(K_THESIS / M_THESIS), rel=1e-14)
    assert shapes[0, 0] == pytest.approx(1 / math.sqrt(M_THESIS), rel=1e-14)
    assert omega_max(M_THESIS, K_THESIS) == math.sqrt(K_THESIS / M_THESIS)
    assert omega_max(M_THESIS, K_THESIS) == pytest.approx(11.0856, abs=1e-4)


def test_modal_analysis_rejects_bad_matrices() -> None:
    with pytest.raises(ConfigError, match='mass'):
        modal_analysis(np.diag([1.0, -1.0]), np.eye(2))
    with pytest.raises(ConfigError, match='stiffness'):
        modal_analysis(np.eye(2), np.diag([1.0, -1.0]))
    with pytest.raises(ConfigError, match='stiffness'):
        modal_analysis(np.eye(2), np.eye(3))


# --------------------------------------------------------------------------- damping


def test_sdof_damping_is_the_thesis_value() -> None:
    c = damping_from_ratio(M_THESIS, K_THESIS, 0.05)
    assert c.shape == (1, 1)
    assert c[0, 0] == pytest.approx(2 * 0.05 * math.sqrt(K_THESIS * M_THESIS), rel=1e-14)
    # Thesis: c = 2 m omega zeta with omega = 11.0856 rad/s (rounded), about 2819 N s/m.
    assert c[0, 0] == pytest.approx(2 * 2543.4 * 11.0856 * 0.05, rel=1e-5)
    # Appendix A, lines 21-22, literally: the same float.
    w = math.sqrt(K_THESIS / M_THESIS)
    assert c[0, 0] == 2 * M_THESIS * w * 0.05


@pytest.mark.parametrize('modes', [(1, 2), (1, 3), (3, 2)])
def test_rayleigh_damping_gives_the_requested_ratio_at_both_modes(modes: tuple) -> None:
    mass, stiffness = shear_building()
    damping = damping_from_ratio(mass, stiffness, 0.05, modes=modes)
    omegas, shapes = modal_analysis(mass, stiffness)
    modal = shapes.T @ damping @ shapes
    ratios = np.diag(modal) / (2 * omegas)
    for mode in modes:
        assert ratios[mode - 1] == pytest.approx(0.05, rel=1e-10)
    other = ({1, 2, 3} - set(modes)).pop()
    assert ratios[other - 1] != pytest.approx(0.05, rel=1e-3)  # Rayleigh, not modal
    # Classical damping: C = a0 M + a1 K is diagonal in the modal basis.
    off_diagonal = modal - np.diag(np.diag(modal))
    assert np.max(np.abs(off_diagonal)) < 1e-10 * np.max(np.abs(modal))
    np.testing.assert_allclose(damping, damping.T, rtol=1e-14)


def test_rayleigh_damping_with_two_ratios() -> None:
    mass, stiffness = shear_building()
    damping = damping_from_ratio(mass, stiffness, (0.02, 0.05), modes=(1, 3))
    omegas, shapes = modal_analysis(mass, stiffness)
    ratios = np.diag(shapes.T @ damping @ shapes) / (2 * omegas)
    assert ratios[0] == pytest.approx(0.02, rel=1e-10)
    assert ratios[2] == pytest.approx(0.05, rel=1e-10)


@pytest.mark.parametrize(
    'ratio, modes, match',
    [
        (-0.05, (1, 2), 'damping_ratio'),
        (math.nan, (1, 2), 'damping_ratio'),
        (0.05, (1, 1), 'damping_modes'),
        (0.05, (0, 2), 'damping_modes'),
        (0.05, (1, 4), 'damping_modes'),
        (0.05, (1,), 'damping_modes'),
        ((0.01, 0.02, 0.03), (1, 2), 'damping_ratio'),
    ],
)
def test_damping_from_ratio_rejects_bad_input(ratio: object, modes: tuple, match: str) -> None:
    mass, stiffness = shear_building()
    with pytest.raises(ConfigError, match=match):
        damping_from_ratio(mass, stiffness, ratio, modes=modes)


# --------------------------------------------------------------------------- loads


def test_effective_load_sdof_is_minus_m_ag() -> None:
    a_g = np.array([0.0, 0.5, -1.2, 3.0])
    p = effective_load(M_THESIS, 1.0, a_g)
    assert p.shape == (4, 1)
    np.testing.assert_array_equal(p[:, 0], -M_THESIS * a_g)
    np.testing.assert_array_equal(effective_load(M_THESIS, 1.0, 2.0), [-2.0 * M_THESIS])


def test_effective_load_mdof_is_minus_m_iota_ag() -> None:
    mass, _ = shear_building()
    mass = mass + np.array([[0.0, 10.0, 0.0], [10.0, 0.0, 0.0], [0.0, 0.0, 0.0]])  # coupled
    iota = np.array([1.0, 1.0, 0.5])
    a_g = np.linspace(-2.0, 2.0, 9)
    p = effective_load(mass, iota, a_g)
    assert p.shape == (9, 3)
    for i, value in enumerate(a_g):
        np.testing.assert_allclose(p[i], -(mass @ iota) * value, rtol=1e-15)


def test_effective_load_rejects_bad_input() -> None:
    with pytest.raises(ConfigError, match='influence'):
        effective_load(np.eye(3), [1.0, 1.0], [0.1])
    with pytest.raises(ConfigError, match='ground_acceleration'):
        effective_load(np.eye(3), 1.0, [0.1, math.nan])
    with pytest.raises(ConfigError, match='ground_acceleration'):
        effective_load(np.eye(3), 1.0, np.zeros((2, 2)))


def test_rayleigh_frequencies_are_the_generalized_eigenvalues_and_both_dampings_use_them() -> None:
    from pd_core.model.damping import rayleigh_damping  # noqa: PLC0415

    m = np.diag([2.0, 1.5, 1.0])
    k = np.array([[500.0, -200.0, 0.0], [-200.0, 350.0, -150.0], [0.0, -150.0, 150.0]])
    expected = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(m, k)).real))
    w_1, w_3 = rayleigh_frequencies(m, k, (1, 3))
    assert w_1 == pytest.approx(expected[0], rel=1e-12)
    assert w_3 == pytest.approx(expected[2], rel=1e-12)
    # ζ(ω) = a0/(2ω) + a1 ω/2 equals 5 % at both modes for either function's matrix.
    for c in (damping_from_ratio(m, k, 0.05, (1, 3)), rayleigh_damping(m, k, (1, 3), 0.05)):
        a1 = (c[0, 1]) / k[0, 1]
        a0 = (c[0, 0] - a1 * k[0, 0]) / m[0, 0]
        for w in (w_1, w_3):
            assert a0 / (2 * w) + a1 * w / 2 == pytest.approx(0.05, rel=1e-10)
    for bad in ((2, 2), (0, 1), (1, 4), (1,), 'ab'):
        messages = set()
        for call, args in ((damping_from_ratio, (m, k, 0.05, bad)),
                           (rayleigh_damping, (m, k, bad, 0.05))):
            with pytest.raises(ConfigError, match='damping_modes') as raised:
                call(*args)
            messages.add(str(raised.value))
        assert len(messages) == 1, messages
