"""Structural elements: stiffness, assembly, condensation, damping and modal properties.

Every check compares against a closed form (beam theory, slope-deflection, the uniform shear
building's analytical modes, the damped eigenvalues of the state-space matrix), never with
the module's own output.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
import scipy.sparse

from pd_core import model
from pd_core.errors import ConfigError
from pd_core.model.damping import modal_damping, rayleigh_coefficients, rayleigh_damping
from pd_core.model.elements import (
    Condensation,
    assemble,
    beam_column_2d_stiffness,
    spring_stiffness,
    static_condensation,
)
from pd_core.model.modes import ModalProperties, modal_properties

E = 200.0e9  # Pa (steel)
A = 8.0e-3  # m²
I = 6.0e-5  # m⁴  # noqa: E741
L = 3.0  # m

GOLDEN = (1.0 + math.sqrt(5.0)) / 2.0


def cantilever(n_elements: int, angle: float = 90.0, length: float = L) -> np.ndarray:
    """Column of ``n_elements`` equal elements, base at the origin fixed, along ``angle``°.

    Free DOFs: node k (k = 1..n) has ux, uy, rz at 3(k-1) + (0, 1, 2).
    """
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    step = length / n_elements
    nodes = [(k * step * c, k * step * s) for k in range(n_elements + 1)]
    pieces = []
    for e in range(n_elements):
        first = [None, None, None] if e == 0 else [3 * (e - 1), 3 * (e - 1) + 1, 3 * (e - 1) + 2]
        second = [3 * e, 3 * e + 1, 3 * e + 2]
        pieces.append((first + second, beam_column_2d_stiffness(nodes[e], nodes[e + 1], E, A, I)))
    return assemble(3 * n_elements, pieces)


def uniform_shear_building(n: int, m: float, k: float) -> tuple[np.ndarray, np.ndarray]:
    return m * np.eye(n), assemble(n, chain(n, k), sparse=False)


def chain(n: int, k: float) -> list:
    """Storey springs of a fixed-base chain: ground–0, 0–1, …, (n−2)–(n−1)."""
    springs = [((None, 0), spring_stiffness(k))]
    return springs + [((j, j + 1), spring_stiffness(k)) for j in range(n - 1)]


def uniform_shear_building_omegas(n: int, m: float, k: float) -> np.ndarray:
    """Fixed-base uniform chain: ω_j = 2 √(k/m) sin((2j−1)π / (2(2n+1)))."""
    j = np.arange(1, n + 1)
    return 2.0 * math.sqrt(k / m) * np.sin((2 * j - 1) * math.pi / (2 * (2 * n + 1)))


def state_space_modes(mass: np.ndarray, damping: np.ndarray, stiffness: np.ndarray):
    """(ω_j, ζ_j) of the damped system from the eigenvalues λ = −ζω ± iω√(1−ζ²)."""
    n = mass.shape[0]
    minv = np.linalg.inv(mass)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ stiffness, -minv @ damping]])
    lam = np.linalg.eigvals(a)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))]
    omegas = np.abs(lam)
    return omegas, -lam.real / omegas


# --------------------------------------------------------------------------- spring


def test_spring_stiffness_matrix() -> None:
    np.testing.assert_array_equal(spring_stiffness(2.5e6), [[2.5e6, -2.5e6], [-2.5e6, 2.5e6]])


@pytest.mark.parametrize('k', [0.0, -1.0, math.nan, math.inf, 'stiff', None])
def test_spring_rejects_bad_stiffness_naming_the_element(k: object) -> None:
    with pytest.raises(ConfigError, match='storey2') as info:
        spring_stiffness(k, name='storey2')  # type: ignore[arg-type]
    assert '\n' not in str(info.value)


def test_three_storey_shear_building_from_springs() -> None:
    k1, k2, k3 = 6.0e7, 4.5e7, 3.0e7
    stiffness = assemble(
        3,
        [
            ((None, 0), spring_stiffness(k1)),
            ((0, 1), spring_stiffness(k2)),
            ((1, 2), spring_stiffness(k3)),
        ],
    )
    expected = np.array([[k1 + k2, -k2, 0.0], [-k2, k2 + k3, -k3], [0.0, -k3, k3]])
    assert isinstance(stiffness, np.ndarray)
    np.testing.assert_array_equal(stiffness, expected)


# --------------------------------------------------------------------------- beam-column


def test_cantilever_tip_stiffness_after_condensing_rotation() -> None:
    k = cantilever(1)
    result = static_condensation(k, [2])
    assert result.retained == (0, 1)
    assert result.condensed == (2,)
    # Vertical column: global x is lateral (3EI/L³), global y axial (EA/L), uncoupled.
    expected = np.diag([3 * E * I / L**3, E * A / L])
    np.testing.assert_allclose(result.stiffness, expected, rtol=1e-12, atol=1e-9 * E * A / L)
    # Tip rotation under a tip load: θ/δ = (PL²/2EI)/(PL³/3EI) = 3/(2L), clockwise for +x.
    assert result.recovery[0, 0] == pytest.approx(-3.0 / (2.0 * L), rel=1e-12)
    assert result.recovery[0, 1] == pytest.approx(0.0, abs=1e-12)


def test_guided_column_and_tip_moment_stiffness() -> None:
    element = beam_column_2d_stiffness((0.0, 0.0), (0.0, L), E, A, I)
    guided = assemble(2, [([None, None, None, 0, 1, None], element)])
    np.testing.assert_allclose(guided, np.diag([12 * E * I / L**3, E * A / L]), rtol=1e-12)
    # Cantilever under a tip moment with the tip free to translate: M/θ = EI/L.
    rotation_only = static_condensation(cantilever(1), [0, 1]).stiffness
    assert rotation_only[0, 0] == pytest.approx(E * I / L, rel=1e-12)


@pytest.mark.parametrize('angle', [0.0, 30.0, 90.0, 135.0, -60.0, 210.0])
def test_inclined_cantilever_in_its_own_axes(angle: float) -> None:
    k_tip = static_condensation(cantilever(1, angle), [2]).stiffness
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    axial = np.array([c, s])
    transverse = np.array([-s, c])
    assert axial @ k_tip @ axial == pytest.approx(E * A / L, rel=1e-12)
    assert transverse @ k_tip @ transverse == pytest.approx(3 * E * I / L**3, rel=1e-9)
    assert abs(axial @ k_tip @ transverse) < 1e-9 * 3 * E * I / L**3
    # The whole 2x2 matrix is the rotated diagonal one.
    expected = E * A / L * np.outer(axial, axial) + 3 * E * I / L**3 * np.outer(
        transverse, transverse
    )
    np.testing.assert_allclose(k_tip, expected, rtol=1e-9, atol=1e-9 * E * A / L)


@pytest.mark.parametrize('n_elements', [2, 4])
def test_multi_element_column_is_exact_under_tip_load(n_elements: int) -> None:
    k = cantilever(n_elements)
    tip = [3 * (n_elements - 1), 3 * (n_elements - 1) + 1]
    condensed = [i for i in range(3 * n_elements) if i not in tip]
    result = static_condensation(k, condensed)
    np.testing.assert_allclose(
        result.stiffness,
        np.diag([3 * E * I / L**3, E * A / L]),
        rtol=1e-10,
        atol=1e-6 * E * I / L**3,
    )
    # Deflected shape under a tip load: u(y)/u(L) = y²(3L − y)/(2L³) (cubic, so exact).
    full = result.expand([1.0, 0.0])
    for node in range(1, n_elements + 1):
        y = node * L / n_elements
        assert full[3 * (node - 1)] == pytest.approx(y**2 * (3 * L - y) / (2 * L**3), rel=1e-10)
        # Slope du/dy = 3y(2L − y)/(2L³); rz = −du/dy for a vertical column.
        assert full[3 * (node - 1) + 2] == pytest.approx(
            -3 * y * (2 * L - y) / (2 * L**3), rel=1e-10
        )


@pytest.mark.parametrize(
    'xi, xj', [((0.0, 0.0), (4.0, 0.0)), ((1.0, 2.0), (-2.0, 6.0)), ((3.0, 3.0), (3.0, -1.0))]
)
def test_free_element_is_symmetric_psd_with_three_rigid_body_modes(xi: tuple, xj: tuple) -> None:
    k = beam_column_2d_stiffness(xi, xj, E, A, I)
    assert k.shape == (6, 6)
    np.testing.assert_array_equal(k, k.T)
    eigenvalues = np.linalg.eigvalsh(k)
    scale = eigenvalues[-1]
    assert np.sum(np.abs(eigenvalues) < 1e-10 * scale) == 3
    assert np.all(eigenvalues > -1e-10 * scale)
    # The rigid-body motions produce no force: two translations and a rotation about (0, 0)
    # (ux = −θ y, uy = θ x, rz = θ).
    rigid = [
        [1.0, 0.0, 0.0, 1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0, 1.0, 0.0],
        [-xi[1], xi[0], 1.0, -xj[1], xj[0], 1.0],
    ]
    for motion in rigid:
        assert np.max(np.abs(k @ np.array(motion))) < 1e-9 * scale


@pytest.mark.parametrize(
    'kwargs, match',
    [
        ({'xj': (0.0, 0.0)}, 'zero length'),
        ({'E': 0.0}, 'E'),
        ({'A': -1.0}, 'A'),
        ({'I': math.nan}, 'I'),
        ({'xi': (0.0,)}, 'xi'),
        ({'xj': 'top'}, 'xj'),
    ],
)
def test_beam_column_rejects_bad_parameters(kwargs: dict, match: str) -> None:
    args = {'xi': (0.0, 0.0), 'xj': (0.0, L), 'E': E, 'A': A, 'I': I, 'name': 'col_A1'}
    args.update(kwargs)
    with pytest.raises(ConfigError, match=match) as info:
        beam_column_2d_stiffness(**args)
    assert str(info.value).startswith('col_A1: ')
    assert '\n' not in str(info.value)


# --------------------------------------------------------------------------- portal frame


def portal_lateral_stiffness(h: float, span: float, i_col: float, i_beam: float) -> float:
    """Fixed-base portal with its beam tied axially (rigid link) and columns of area 100 m².

    Global DOFs: 0 = sway (ux of both top nodes), 1/2 = uy/rz left top, 3/4 = uy/rz right top.
    """
    big_a = 100.0  # axially rigid members, as in the slope-deflection closed form
    left = beam_column_2d_stiffness((0.0, 0.0), (0.0, h), E, big_a, i_col)
    right = beam_column_2d_stiffness((span, 0.0), (span, h), E, big_a, i_col)
    beam = beam_column_2d_stiffness((0.0, h), (span, h), E, big_a, i_beam)
    k = assemble(
        5,
        [
            ([None, None, None, 0, 1, 2], left),
            ([None, None, None, 0, 3, 4], right),
            ([0, 1, 2, 0, 3, 4], beam),
        ],
    )
    return float(static_condensation(k, [1, 2, 3, 4]).stiffness[0, 0])


def slope_deflection_portal(h: float, span: float, i_col: float, i_beam: float) -> float:
    """Lateral stiffness of a fixed-base portal frame (axially rigid members).

    Derivation (slope-deflection, M_ab = (2EI/ℓ)(2θ_a + θ_b − 3Δ/ℓ), clockwise positive),
    k_c = I_c/h, k_b = I_b/L, both joints rotate by θ under the sway Δ (antisymmetry):

        column top    M_t = 2E k_c (2θ − 3Δ/h),   column base M_b = 2E k_c (θ − 3Δ/h)
        beam end      M   = 2E k_b (2θ + θ) = 6E k_b θ
        joint:        M_t + 6E k_b θ = 0         ⇒ θ = 3 k_c Δ / (h (2 k_c + 3 k_b))
        storey shear  H = 2 · (−(M_t + M_b)/h) = (4E k_c/h)(6Δ/h − 3θ)

    ⇒ K = H/Δ = (12 E I_c / h³) (k_c + 6 k_b) / (2 k_c + 3 k_b).

    Limits: k_b → ∞ gives 24EI_c/h³ (two guided columns), k_b → 0 gives 6EI_c/h³ (two
    cantilevers). With ρ = k_b/(2 k_c) this is Chopra's (Dynamics of Structures, Ex. 1.1 with
    L = 2h, ρ = I_b/4I_c) K = (24EI_c/h³)(12ρ + 1)/(12ρ + 4).
    """
    k_c, k_b = i_col / h, i_beam / span
    return 12.0 * E * i_col / h**3 * (k_c + 6.0 * k_b) / (2.0 * k_c + 3.0 * k_b)


def test_portal_frame_with_rigid_beam_is_two_guided_columns() -> None:
    h, span = 3.5, 6.0
    stiffness = portal_lateral_stiffness(h, span, I, 1.0e6 * I)
    assert stiffness == pytest.approx(2 * 12 * E * I / h**3, rel=5e-6)


@pytest.mark.parametrize('ratio', [1e-6, 0.25, 0.5, 1.0, 2.0, 4.0, 10.0])
@pytest.mark.parametrize('h, span', [(3.5, 6.0), (4.0, 8.0), (3.0, 3.0)])
def test_portal_frame_matches_slope_deflection(ratio: float, h: float, span: float) -> None:
    stiffness = portal_lateral_stiffness(h, span, I, ratio * I)
    # Residual ~1e-6: the members are axially stiff (A = 100 m²), not rigid.
    assert stiffness == pytest.approx(slope_deflection_portal(h, span, I, ratio * I), rel=2e-6)


def test_portal_closed_form_in_chopras_notation() -> None:
    # Guards the derivation above: L = 2h, ρ = I_b / (4 I_c), K = (24EI_c/h³)(12ρ+1)/(12ρ+4).
    h = 3.0
    for rho in (0.0, 0.125, 0.5, 1.0, 4.0):
        i_beam = max(4 * rho * I, 1e-12 * I)
        chopra = 24 * E * I / h**3 * (12 * rho + 1) / (12 * rho + 4)
        assert slope_deflection_portal(h, 2 * h, I, i_beam) == pytest.approx(chopra, rel=1e-9)
        assert portal_lateral_stiffness(h, 2 * h, I, i_beam) == pytest.approx(chopra, rel=1e-6)


# --------------------------------------------------------------------------- assembly


def test_assemble_drops_fixed_dofs_and_sums_overlaps() -> None:
    element = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]])
    other = np.array([[10.0, 20.0], [30.0, 40.0]])
    result = assemble(2, [((1, None, 0), element), ((0, 1), other)])
    # Element 0 maps local (0, 2) to global (1, 0).
    expected = np.array([[9.0 + 10.0, 7.0 + 20.0], [3.0 + 30.0, 1.0 + 40.0]])
    np.testing.assert_array_equal(result, expected)


def test_assemble_sparse_equals_dense() -> None:
    rng = np.random.default_rng(7)
    pieces = []
    for _ in range(40):
        idx = [int(i) if i < 12 else None for i in rng.choice(14, size=4, replace=False)]
        block = rng.normal(size=(4, 4))
        pieces.append((idx, block + block.T))
    dense = assemble(12, pieces, sparse=False)
    sparse = assemble(12, pieces, sparse=True)
    assert isinstance(dense, np.ndarray)
    assert scipy.sparse.issparse(sparse) and sparse.format == 'csr'
    np.testing.assert_allclose(sparse.toarray(), dense, rtol=1e-15, atol=1e-13)
    # Reference: explicit loops.
    reference = np.zeros((12, 12))
    for idx, block in pieces:
        for a, ga in enumerate(idx):
            for b, gb in enumerate(idx):
                if ga is not None and gb is not None:
                    reference[ga, gb] += block[a, b]
    np.testing.assert_allclose(dense, reference, rtol=1e-14, atol=1e-13)


def test_assemble_1000_dof_chain_is_sparse_and_fast() -> None:
    n, k = 1000, 2.0e6
    pieces = chain(n, k)
    start = time.perf_counter()
    stiffness = assemble(n, pieces)
    elapsed = time.perf_counter() - start
    assert scipy.sparse.issparse(stiffness)
    assert stiffness.shape == (n, n)
    assert stiffness.nnz == n + 2 * (n - 1)
    diagonal = np.full(n, 2 * k)
    diagonal[-1] = k
    expected = scipy.sparse.diags(
        [np.full(n - 1, -k), diagonal, np.full(n - 1, -k)], offsets=[-1, 0, 1]
    )
    assert abs(stiffness - expected).max() == 0.0
    print(f'1000-DOF chain assembled in {elapsed * 1e3:.1f} ms')
    assert not scipy.sparse.issparse(assemble(199, pieces[:199]))
    assert scipy.sparse.issparse(assemble(200, pieces[:200]))


@pytest.mark.parametrize(
    'n, pieces, match',
    [
        (2, [((0, 1), np.eye(2)), ((0, 2), np.eye(2))], 'element 1: DOF index 2'),
        (2, [((0, -1), np.eye(2))], 'element 0: DOF index -1'),
        (2, [((0, 1), np.eye(3))], 'element 0: matrix is 3x3 but 2'),
        (2, [((0, 1), np.ones((2, 3)))], 'element 0: matrix must be square'),
        (2, [((0, 1.0), np.eye(2))], 'element 0: DOF index must be an integer'),
        (2, [((0, 1), np.array([[1.0, math.nan], [0.0, 1.0]]))], 'element 0: matrix values'),
        (0, [], 'n must be a positive integer'),
    ],
)
def test_assemble_rejects_bad_input(n: int, pieces: list, match: str) -> None:
    with pytest.raises(ConfigError, match=match) as info:
        assemble(n, pieces)
    assert '\n' not in str(info.value)


# --------------------------------------------------------------------------- condensation


def test_condensation_of_a_spring_pair_and_recovery() -> None:
    # Two springs in series k1 (ground–1) and k2 (1–0): condensing DOF 1 gives k1 k2/(k1+k2).
    k1, k2 = 3.0e6, 6.0e6
    stiffness = assemble(2, [((None, 1), spring_stiffness(k1)), ((1, 0), spring_stiffness(k2))])
    result = static_condensation(stiffness, [1])
    assert isinstance(result, Condensation)
    assert result.stiffness[0, 0] == pytest.approx(k1 * k2 / (k1 + k2), rel=1e-14)
    assert result.recovery[0, 0] == pytest.approx(k2 / (k1 + k2), rel=1e-14)
    assert static_condensation(scipy.sparse.csr_matrix(stiffness), [1]).stiffness[0, 0] == (
        pytest.approx(k1 * k2 / (k1 + k2), rel=1e-14)
    )
    nothing = static_condensation(stiffness, [])
    np.testing.assert_array_equal(nothing.stiffness, stiffness)
    assert nothing.recovery.shape == (0, 2)


def test_condensation_reports_dofs_without_stiffness() -> None:
    stiffness = np.array([[2.0, -1.0, 0.0, 0.0], [-1.0, 1.0, 0.0, 0.0], [0.0] * 4, [0.0] * 4])
    stiffness[3, 3] = 5.0
    with pytest.raises(ConfigError, match=r'singular.*\[2\]') as info:
        static_condensation(stiffness, [3, 2])
    assert '\n' not in str(info.value)


@pytest.mark.parametrize(
    'condensed, match',
    [([3], 'out of range'), ([1, 1], 'unique'), ([0, 1, 2], 'retained'), ([True], 'integer')],
)
def test_condensation_rejects_bad_indices(condensed: list, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        static_condensation(np.diag([1.0, 2.0, 3.0]), condensed)


# --------------------------------------------------------------------------- damping


def test_rayleigh_coefficients_closed_form_for_equal_ratios() -> None:
    # ζ_i = ζ_j = ζ: a0 = 2ζ ω_i ω_j/(ω_i + ω_j), a1 = 2ζ/(ω_i + ω_j).
    w_i, w_j, zeta = 6.0, 21.0, 0.05
    a0, a1 = rayleigh_coefficients(w_i, w_j, zeta, zeta)
    assert a0 == pytest.approx(2 * zeta * w_i * w_j / (w_i + w_j), rel=1e-14)
    assert a1 == pytest.approx(2 * zeta / (w_i + w_j), rel=1e-14)
    a0, a1 = rayleigh_coefficients(6.0, 21.0, 0.02, 0.05)
    assert a0 / (2 * 6.0) + a1 * 6.0 / 2 == pytest.approx(0.02, rel=1e-13)
    assert a0 / (2 * 21.0) + a1 * 21.0 / 2 == pytest.approx(0.05, rel=1e-13)


@pytest.mark.parametrize(
    'args, match',
    [
        ((5.0, 5.0, 0.05, 0.05), 'differ'),
        ((0.0, 5.0, 0.05, 0.05), 'omega_i'),
        ((5.0, 8.0, -0.01, 0.05), 'zeta_i'),
    ],
)
def test_rayleigh_coefficients_reject_bad_input(args: tuple, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        rayleigh_coefficients(*args)


@pytest.mark.parametrize(
    'modes, ratios', [((1, 2), (0.05, 0.05)), ((1, 3), (0.02, 0.05)), ((3, 2), 0.03)]
)
def test_rayleigh_damping_hits_the_targets_and_follows_the_curve(
    modes: tuple, ratios: object
) -> None:
    n, m, k = 4, 2.0e4, 3.0e7
    mass, stiffness = uniform_shear_building(n, m, k)
    damping = rayleigh_damping(mass, stiffness, modes=modes, ratios=ratios)
    omegas_exact = uniform_shear_building_omegas(n, m, k)
    targets = (ratios, ratios) if isinstance(ratios, float) else ratios
    w_i, w_j = omegas_exact[modes[0] - 1], omegas_exact[modes[1] - 1]
    # Independent closed form for a0, a1 (Cramer's rule on ζ = a0/2ω + a1ω/2).
    det = (w_j / w_i - w_i / w_j) / 4
    a0 = (targets[0] * w_j / 2 - targets[1] * w_i / 2) / det
    a1 = (targets[1] / (2 * w_i) - targets[0] / (2 * w_j)) / det
    np.testing.assert_allclose(damping, a0 * mass + a1 * stiffness, rtol=1e-9, atol=1e-9 * a1 * k)
    # The damped eigenvalues give ζ at every mode: targets at the two modes, the curve elsewhere.
    omegas, zetas = state_space_modes(mass, damping, stiffness)
    np.testing.assert_allclose(
        zetas, a0 / (2 * omegas_exact) + a1 * omegas_exact / 2, rtol=1e-8
    )
    assert zetas[modes[0] - 1] == pytest.approx(targets[0], rel=1e-8)
    assert zetas[modes[1] - 1] == pytest.approx(targets[1], rel=1e-8)
    np.testing.assert_allclose(omegas, omegas_exact, rtol=1e-9)  # |λ| = ω for classical C


@pytest.mark.parametrize('modes', [(1, 1), (0, 2), (1, 5), (1,)])
def test_rayleigh_damping_rejects_bad_modes(modes: tuple) -> None:
    mass, stiffness = uniform_shear_building(3, 1.0, 1.0)
    with pytest.raises(ConfigError, match='damping_modes'):
        rayleigh_damping(mass, stiffness, modes=modes, ratios=(0.05, 0.05))


@pytest.mark.parametrize(
    'ratios, expected',
    [
        ([0.02, 0.05, 0.03, 0.08], [0.02, 0.05, 0.03, 0.08]),
        ([0.02, 0.04], [0.02, 0.04, 0.04, 0.04]),  # the last ratio applies to higher modes
        ([0.05], [0.05] * 4),
        (0.03, [0.03] * 4),
    ],
)
def test_modal_damping_gives_each_mode_its_ratio(ratios: object, expected: list) -> None:
    n, m, k = 4, 2.0e4, 3.0e7
    mass, stiffness = uniform_shear_building(n, m, k)
    damping = modal_damping(mass, stiffness, ratios)  # type: ignore[arg-type]
    omegas_exact = uniform_shear_building_omegas(n, m, k)
    np.testing.assert_allclose(damping, damping.T, rtol=1e-14, atol=1e-9)
    omegas, zetas = state_space_modes(mass, damping, stiffness)
    np.testing.assert_allclose(zetas, expected, rtol=1e-8)
    np.testing.assert_allclose(omegas, omegas_exact, rtol=1e-9)
    # Φᵀ C Φ = diag(2 ζ_j ω_j) with the analytical shapes sin((2j−1)πi/(2n+1)).
    i = np.arange(1, n + 1)[:, None]
    j = np.arange(1, n + 1)[None, :]
    shapes = np.sin((2 * j - 1) * math.pi * i / (2 * n + 1))
    shapes /= np.sqrt(np.einsum('ij,ik,kj->j', shapes, mass, shapes))
    modal = shapes.T @ damping @ shapes
    np.testing.assert_allclose(
        modal, np.diag(2 * np.array(expected) * omegas_exact), rtol=1e-9, atol=1e-9 * modal.max()
    )


@pytest.mark.parametrize(
    'ratios, match',
    [([], 'at least one'), ([0.05] * 5, 'only 4 modes'), ([0.05, -0.01], 'damping_ratios')],
)
def test_modal_damping_rejects_bad_ratios(ratios: list, match: str) -> None:
    mass, stiffness = uniform_shear_building(4, 1.0, 1.0)
    with pytest.raises(ConfigError, match=match):
        modal_damping(mass, stiffness, ratios)


# --------------------------------------------------------------------------- modal properties


def test_two_storey_participation_against_hand_calculation() -> None:
    # Equal m, k: mode 1 is [1, φ] with φ = golden ratio, ω₁² = (k/m)(3 − √5)/2.
    # L₁ = φᵀMι = m(1 + φ), M₁ = φᵀMφ = m(1 + φ²) = m(2 + φ).
    m, k = 1000.0, 2.0e6
    mass, stiffness = uniform_shear_building(2, m, k)
    props = modal_properties(mass, stiffness, np.ones((1, 2)))
    assert isinstance(props, ModalProperties)
    w1 = math.sqrt(k / m * (3 - math.sqrt(5)) / 2)
    w2 = math.sqrt(k / m * (3 + math.sqrt(5)) / 2)
    np.testing.assert_allclose(props.omegas, [w1, w2], rtol=1e-12)
    np.testing.assert_allclose(props.periods, [2 * math.pi / w1, 2 * math.pi / w2], rtol=1e-12)
    np.testing.assert_allclose(props.frequencies, np.array([w1, w2]) / (2 * math.pi), rtol=1e-12)
    # Γ of the mass-normalised shape: √m (1 + φ)/√(2 + φ).
    assert props.participation[0, 0] == pytest.approx(
        math.sqrt(m) * (1 + GOLDEN) / math.sqrt(2 + GOLDEN), rel=1e-12
    )
    # Normalisation-free check: Γ₁ φ₁ = (1 + φ)/(2 + φ) · [1, φ] = [0.7236, 1.1708].
    contribution = props.participation[0, 0] * props.shapes[:, 0]
    factor = (1 + GOLDEN) / (2 + GOLDEN)
    np.testing.assert_allclose(contribution, [factor, factor * GOLDEN], rtol=1e-12)
    # M₁* = m(1 + φ)²/(2 + φ): 94.72 % of the total mass 2m.
    m1_star = m * (1 + GOLDEN) ** 2 / (2 + GOLDEN)
    assert props.effective_mass[0, 0] == pytest.approx(m1_star, rel=1e-12)
    assert props.effective_mass[1, 0] == pytest.approx(2 * m - m1_star, rel=1e-10)
    assert props.effective_mass_ratio[0, 0] == pytest.approx(m1_star / (2 * m), rel=1e-12)
    assert props.effective_mass_ratio[0, 0] == pytest.approx(0.9472, abs=1e-4)
    assert props.total_mass.tolist() == [2 * m]
    np.testing.assert_allclose(props.shapes.T @ mass @ props.shapes, np.eye(2), atol=1e-12)


def test_effective_mass_ratios_sum_to_one_per_component() -> None:
    # Portal frame with the top-node rotations condensed: DOFs ux2, uy2, ux3, uy3.
    h, span = 3.5, 6.0
    col_l = beam_column_2d_stiffness((0.0, 0.0), (0.0, h), E, A, I)
    col_r = beam_column_2d_stiffness((span, 0.0), (span, h), E, A, I)
    beam = beam_column_2d_stiffness((0.0, h), (span, h), E, A, 2 * I)
    fixed = [None, None, None]
    k = assemble(
        6, [([*fixed, 0, 1, 2], col_l), ([*fixed, 3, 4, 5], col_r), ([0, 1, 2, 3, 4, 5], beam)]
    )
    k_red = static_condensation(k, [2, 5]).stiffness
    masses = np.array([4.0e3, 4.0e3, 6.0e3, 6.0e3])
    mass = np.diag(masses)
    influences = np.array([[1.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0], [1.0, 1.0, 1.0, 1.0]])
    props = modal_properties(mass, k_red, influences)
    assert props.participation.shape == (4, 3)
    np.testing.assert_allclose(props.total_mass, [1.0e4, 1.0e4, 2.0e4], rtol=1e-14)
    np.testing.assert_allclose(props.effective_mass_ratio.sum(axis=0), 1.0, rtol=1e-12)
    np.testing.assert_allclose(props.effective_mass.sum(axis=0), [1.0e4, 1.0e4, 2.0e4], rtol=1e-12)
    # Σ_j Γ_jc φ_j = ι_c (modal expansion of the influence vector).
    np.testing.assert_allclose(props.shapes @ props.participation, influences.T, atol=1e-12)


def test_uniform_building_modes_match_the_closed_form() -> None:
    n, m, k = 6, 5.0e3, 8.0e6
    mass, stiffness = uniform_shear_building(n, m, k)
    props = modal_properties(mass, stiffness, np.ones(n))
    np.testing.assert_allclose(props.omegas, uniform_shear_building_omegas(n, m, k), rtol=1e-12)
    # Shapes sin((2j−1)π i/(2n+1)), i = 1..n: same up to normalisation, largest component > 0.
    i = np.arange(1, n + 1)
    for j in range(1, n + 1):
        shape = np.sin((2 * j - 1) * math.pi * i / (2 * n + 1))
        shape /= math.sqrt(m * shape @ shape)
        if shape[np.argmax(np.abs(shape))] < 0:
            shape = -shape
        np.testing.assert_allclose(props.shapes[:, j - 1], shape, atol=1e-12 / math.sqrt(m))


def test_rigid_body_mode_has_infinite_period() -> None:
    mass = np.diag([2.0, 3.0])
    stiffness = spring_stiffness(6.0)  # free-free two-mass oscillator
    props = modal_properties(mass, stiffness, [1.0, 1.0])
    assert props.omegas[0] == pytest.approx(0.0, abs=1e-7)
    assert math.isinf(props.periods[0]) and props.frequencies[0] == pytest.approx(0.0, abs=1e-8)
    # ω₂² = k (m1 + m2)/(m1 m2); the rigid mode carries all the mass.
    assert props.omegas[1] == pytest.approx(math.sqrt(6.0 * 5.0 / 6.0), rel=1e-12)
    assert props.effective_mass_ratio[0, 0] == pytest.approx(1.0, rel=1e-12)
    assert props.effective_mass_ratio[1, 0] == pytest.approx(0.0, abs=1e-12)
    assert 'inf' in props.report()


def test_report_is_a_readable_table() -> None:
    m, k = 1000.0, 2.0e6
    mass, stiffness = uniform_shear_building(2, m, k)
    props = modal_properties(mass, stiffness, np.ones((1, 2)))
    text = props.report(['floor1', 'roof'], ['x'])
    lines = text.splitlines()
    print(text)
    assert 'Mode' in text and 'T [s]' in text and 'f [Hz]' in text and 'M* %' in text
    assert 'floor1' in text and 'roof' in text
    mode1 = next(line for line in lines if line.strip().startswith('1 '))
    w1 = math.sqrt(k / m * (3 - math.sqrt(5)) / 2)
    assert f'{2 * math.pi / w1:.4f}' in mode1
    assert f'{w1 / (2 * math.pi):.4f}' in mode1
    assert '94.72' in mode1
    assert ' 1.171 ' in mode1  # Γ₁ of the roof-normalised shape: (1 + φ)/(2 + φ) · φ
    assert '100.00' in next(line for line in lines if line.strip().startswith('2 '))
    roof = next(line for line in lines if line.startswith('roof'))
    assert roof.split()[1] == '1.0000'  # mode 1 scaled to a unit roof displacement
    floor1 = next(line for line in lines if line.startswith('floor1'))
    assert float(floor1.split()[1]) == pytest.approx(1 / GOLDEN, abs=1e-4)
    with pytest.raises(ConfigError, match='dof_names'):
        props.report(['only_one'], ['x'])
    with pytest.raises(ConfigError, match='component_names'):
        props.report(['a', 'b'], ['x', 'y'])


@pytest.mark.parametrize(
    'influences, match',
    [
        (np.ones(3), 'influences'),
        (np.zeros((1, 2)), 'zero mass'),
        (np.ones((1, 2, 1)), 'influences'),
    ],
)
def test_modal_properties_rejects_bad_influences(influences: np.ndarray, match: str) -> None:
    mass, stiffness = uniform_shear_building(2, 1.0, 1.0)
    with pytest.raises(ConfigError, match=match):
        modal_properties(mass, stiffness, influences)


def test_public_names_are_exported_from_the_model_package() -> None:
    names = ('assemble', 'beam_column_2d_stiffness', 'modal_properties', 'Condensation')
    for name in names:
        assert name in model.__all__
        assert getattr(model, name) is not None
