"""Structural elements: element stiffness, assembly, condensation, damping and modes.

Pure numerical building blocks for describing the numerical part of a hybrid test as a set
of elements instead of hand-written matrices:

* element stiffness matrices (:func:`spring_stiffness`, :func:`beam_column_2d_stiffness`);
* assembly into a global matrix with fixed (ground) DOFs removed (:func:`assemble`);
* static condensation of massless DOFs, e.g. joint rotations (:func:`static_condensation`);
* classical damping: Rayleigh (:func:`rayleigh_coefficients`, :func:`rayleigh_damping`) and
  modal (:func:`modal_damping`);
* modal properties with participation factors and effective modal masses
  (:func:`modal_properties`), with the text report an engineer checks before a test.

Sign conventions: 2-D frames lie in the global x–y plane, rotations are counter-clockwise
positive. All quantities are SI (N, m, kg, s). Only numpy/scipy are used.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse

from .errors import ConfigError
from .structure import _square, modal_analysis

__all__ = [
    'RIGID_BODY_RTOL',
    'SPARSE_THRESHOLD',
    'Condensation',
    'ModalProperties',
    'assemble',
    'beam_column_2d_stiffness',
    'modal_damping',
    'modal_properties',
    'rayleigh_coefficients',
    'rayleigh_damping',
    'spring_stiffness',
    'static_condensation',
]

#: :func:`assemble` returns a scipy.sparse CSR matrix by default from this many DOFs on.
SPARSE_THRESHOLD = 200

#: :func:`modal_properties` treats modes with ``ω² <= RIGID_BODY_RTOL · max ω²`` as rigid-body
#: modes (``ω = 0``, infinite period).
RIGID_BODY_RTOL = 1e-10


# --------------------------------------------------------------------------- helpers


def _positive(value: Any, name: str, what: str) -> float:
    """``value`` as a finite, strictly positive float, or ConfigError naming ``name``."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f'{name}: {what} must be a number, got {value!r}') from None
    if not math.isfinite(number) or number <= 0.0:
        raise ConfigError(f'{name}: {what} must be positive and finite, got {value!r}')
    return number


def _dense_square(value: Any, name: str) -> np.ndarray:
    """A square finite float matrix from an array-like, a scalar or a scipy.sparse matrix."""
    if scipy.sparse.issparse(value):
        value = value.toarray()
    return _square(value, name)


def _matching(mass: Any, stiffness: Any) -> tuple[np.ndarray, np.ndarray]:
    m = _dense_square(mass, 'mass')
    k = _dense_square(stiffness, 'stiffness')
    if m.shape != k.shape:
        raise ConfigError(f'stiffness: shape {k.shape} does not match mass shape {m.shape}')
    return m, k


def _ratio(value: Any, name: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f'{name}: expected a damping ratio, got {value!r}') from None
    if not math.isfinite(number) or number < 0.0:
        raise ConfigError(f'{name}: damping ratio must be finite and >= 0, got {value!r}')
    return number


def _readonly(array: np.ndarray) -> np.ndarray:
    array = np.array(array, dtype=float)
    array.setflags(write=False)
    return array


# --------------------------------------------------------------------------- elements


def spring_stiffness(k: float, *, name: str = 'spring') -> np.ndarray:
    """Stiffness of a linear spring (or a shear storey) between two DOFs.

    Args:
        k: Spring stiffness in N/m (or N·m/rad for a rotational spring), positive.
        name: Element name used in error messages.

    Returns:
        ``[[k, -k], [-k, k]]`` for the DOF order ``[i, j]``. Ground one end by giving it the
        index ``None`` in :func:`assemble`.

    Raises:
        ConfigError: If ``k`` is not a positive finite number.
    """
    value = _positive(k, name, 'stiffness k')
    return np.array([[value, -value], [-value, value]])


def beam_column_2d_stiffness(
    xi: tuple[float, float],
    xj: tuple[float, float],
    E: float,
    A: float,
    I: float,  # noqa: E741 - the engineering symbol
    *,
    name: str = 'beam_column_2d',
) -> np.ndarray:
    """Global stiffness of a linear elastic 2-D Euler–Bernoulli frame element.

    The local matrix (axis from node ``i`` to node ``j``, length ``L``) couples the axial
    stiffness ``EA/L`` with the flexural terms ``12EI/L³, 6EI/L², 4EI/L, 2EI/L``; it is
    rotated to global axes by ``K = Tᵀ k T`` with the direction cosines of the element.

    Args:
        xi: Global coordinates ``(x, y)`` of node ``i`` in m.
        xj: Global coordinates ``(x, y)`` of node ``j`` in m.
        E: Young's modulus in Pa, positive.
        A: Cross-section area in m², positive.
        I: Second moment of area about the bending axis in m⁴, positive.
        name: Element name used in error messages.

    Returns:
        The symmetric 6×6 stiffness for the end DOFs ``[ux_i, uy_i, rz_i, ux_j, uy_j, rz_j]``
        in global axes (rotations counter-clockwise positive). A free element has exactly
        three rigid-body modes.

    Raises:
        ConfigError: On malformed coordinates, a zero length or non-positive ``E``, ``A``
            or ``I``.
    """
    points = []
    for label, point in (('xi', xi), ('xj', xj)):
        try:
            coords = np.array(point, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise ConfigError(f'{name}: {label} must be a pair (x, y), got {point!r}') from None
        if coords.shape != (2,) or not np.all(np.isfinite(coords)):
            raise ConfigError(f'{name}: {label} must be a finite pair (x, y), got {point!r}')
        points.append(coords)
    e = _positive(E, name, 'E')
    a = _positive(A, name, 'A')
    inertia = _positive(I, name, 'I')
    dx, dy = points[1] - points[0]
    length = math.hypot(dx, dy)
    scale = max(float(np.max(np.abs(points[0]))), float(np.max(np.abs(points[1]))), 1.0)
    if length <= 1e-12 * scale:
        raise ConfigError(f'{name}: nodes xi and xj coincide (zero length)')
    c, s = dx / length, dy / length
    ea = e * a / length
    k1 = 12.0 * e * inertia / length**3
    k2 = 6.0 * e * inertia / length**2
    k3 = 4.0 * e * inertia / length
    k4 = 2.0 * e * inertia / length
    local = np.array(
        [
            [ea, 0.0, 0.0, -ea, 0.0, 0.0],
            [0.0, k1, k2, 0.0, -k1, k2],
            [0.0, k2, k3, 0.0, -k2, k4],
            [-ea, 0.0, 0.0, ea, 0.0, 0.0],
            [0.0, -k1, -k2, 0.0, k1, -k2],
            [0.0, k2, k4, 0.0, -k2, k3],
        ]
    )
    # Local (axial, transverse, rotation) = R · global (ux, uy, rz) at each node.
    rotation = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    transform = np.zeros((6, 6))
    transform[:3, :3] = rotation
    transform[3:, 3:] = rotation
    stiffness = transform.T @ local @ transform
    return 0.5 * (stiffness + stiffness.T)


# --------------------------------------------------------------------------- assembly


def assemble(
    n: int,
    element_matrices: Sequence[tuple[Sequence[int | None], np.ndarray]],
    *,
    sparse: bool | None = None,
) -> np.ndarray | scipy.sparse.csr_matrix:
    """Assemble element matrices into an ``n``×``n`` global matrix (direct stiffness).

    Each element contributes ``K[g_a, g_b] += k_e[a, b]`` where ``g`` is its list of global
    DOF indices. An index ``None`` marks a fixed (ground) DOF: its rows and columns of the
    element matrix are dropped. Two local DOFs may map onto the same global index (a rigid
    tie); their contributions are summed. The build is a single vectorised COO sum.

    Args:
        n: Number of global (free) DOFs, ``>= 1``.
        element_matrices: ``(indices, matrix)`` pairs; ``matrix`` is ``m``×``m`` with
            ``m = len(indices)``. Works for stiffness, mass or damping matrices alike.
        sparse: ``True`` returns a scipy.sparse CSR matrix, ``False`` a dense ndarray;
            ``None`` (default) chooses sparse when ``n >= SPARSE_THRESHOLD``.

    Returns:
        The assembled global matrix.

    Raises:
        ConfigError: On a bad ``n``, an index out of ``0..n-1``, a non-square matrix or a
            matrix whose size does not match its index list (naming the element by position).
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ConfigError(f'assemble: n must be a positive integer, got {n!r}')
    n = int(n)
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    values: list[np.ndarray] = []
    for number, entry in enumerate(element_matrices):
        label = f'element {number}'
        try:
            indices, matrix = entry
        except (TypeError, ValueError):
            raise ConfigError(f'{label}: expected a pair (indices, matrix)') from None
        if isinstance(indices, (str, bytes)) or not isinstance(indices, Sequence | np.ndarray):
            raise ConfigError(f'{label}: indices must be a sequence, got {indices!r}')
        local: list[int] = []
        glob: list[int] = []
        for position, index in enumerate(indices):
            if index is None:
                continue
            if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
                raise ConfigError(f'{label}: DOF index must be an integer or None, got {index!r}')
            if not 0 <= int(index) < n:
                raise ConfigError(f'{label}: DOF index {int(index)} is out of range 0..{n - 1}')
            local.append(position)
            glob.append(int(index))
        dense = _element_matrix(matrix, len(indices), label)
        if not glob:
            continue
        lidx = np.asarray(local)
        gidx = np.asarray(glob)
        block = dense[np.ix_(lidx, lidx)]
        size = gidx.size
        rows.append(np.repeat(gidx, size))
        cols.append(np.tile(gidx, size))
        values.append(block.reshape(-1))
    row = np.concatenate(rows) if rows else np.zeros(0, dtype=np.intp)
    col = np.concatenate(cols) if cols else np.zeros(0, dtype=np.intp)
    val = np.concatenate(values) if values else np.zeros(0)
    use_sparse = n >= SPARSE_THRESHOLD if sparse is None else bool(sparse)
    if use_sparse:
        return scipy.sparse.coo_matrix((val, (row, col)), shape=(n, n)).tocsr()
    flat = np.bincount(row * n + col, weights=val, minlength=n * n)
    return flat.reshape(n, n)


def _element_matrix(matrix: Any, size: int, label: str) -> np.ndarray:
    if scipy.sparse.issparse(matrix):
        matrix = matrix.toarray()
    try:
        dense = np.array(matrix, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f'{label}: matrix must contain numbers') from None
    if dense.ndim == 0 and size == 1:
        dense = dense.reshape(1, 1)
    if dense.ndim != 2 or dense.shape[0] != dense.shape[1]:
        raise ConfigError(f'{label}: matrix must be square, got shape {dense.shape}')
    if dense.shape[0] != size:
        raise ConfigError(
            f'{label}: matrix is {dense.shape[0]}x{dense.shape[1]} but {size} DOF indices '
            'were given'
        )
    if not np.all(np.isfinite(dense)):
        raise ConfigError(f'{label}: matrix values must be finite')
    return dense


# --------------------------------------------------------------------------- condensation


@dataclass(frozen=True, eq=False)
class Condensation:
    """Result of :func:`static_condensation`.

    Attributes:
        retained: Indices ``r`` of the retained DOFs in the original matrix, ascending.
        condensed: Indices ``c`` of the condensed (eliminated) DOFs, in the given order.
        stiffness: Condensed stiffness ``K_rr − K_rc K_cc⁻¹ K_cr`` (dense, ``len(r)`` square).
        recovery: ``R = −K_cc⁻¹ K_cr`` so that the condensed DOFs follow ``x_c = R x_r``
            (shape ``len(c)`` × ``len(r)``).
    """

    retained: tuple[int, ...]
    condensed: tuple[int, ...]
    stiffness: np.ndarray
    recovery: np.ndarray

    def expand(self, retained_values: Any) -> np.ndarray:
        """Full DOF vector (original ordering) from the retained DOF values."""
        x_r = np.asarray(retained_values, dtype=float)
        full = np.zeros(len(self.retained) + len(self.condensed))
        full[list(self.retained)] = x_r
        full[list(self.condensed)] = self.recovery @ x_r
        return full


def static_condensation(K: Any, condensed: Sequence[int]) -> Condensation:
    """Statically condense DOFs that carry no mass or external load (e.g. joint rotations).

    With the DOFs split into retained ``r`` and condensed ``c`` and ``f_c = 0``,
    ``K_cc x_c + K_cr x_r = 0`` gives ``x_c = −K_cc⁻¹ K_cr x_r`` and the retained stiffness
    ``K_rr − K_rc K_cc⁻¹ K_cr``.

    Args:
        K: Stiffness matrix (dense array-like or scipy.sparse), ``n``×``n``.
        condensed: Indices of the DOFs to eliminate (unique, in ``0..n-1``); may be empty.

    Returns:
        A :class:`Condensation`.

    Raises:
        ConfigError: On bad indices, when every DOF would be condensed, or when ``K_cc`` is
            singular (the message names the condensed DOFs without stiffness of their own).
    """
    k = _dense_square(K, 'stiffness')
    n = k.shape[0]
    if isinstance(condensed, (str, bytes)):
        raise ConfigError(f'condensed: expected a sequence of DOF indices, got {condensed!r}')
    cond: list[int] = []
    for index in condensed:
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise ConfigError(f'condensed: DOF index must be an integer, got {index!r}')
        if not 0 <= int(index) < n:
            raise ConfigError(f'condensed: DOF index {int(index)} is out of range 0..{n - 1}')
        cond.append(int(index))
    if len(set(cond)) != len(cond):
        raise ConfigError(f'condensed: DOF indices must be unique, got {cond}')
    chosen = set(cond)
    retained = [i for i in range(n) if i not in chosen]
    if not retained:
        raise ConfigError('condensed: at least one DOF must be retained')
    r = np.asarray(retained, dtype=np.intp)
    c = np.asarray(cond, dtype=np.intp)
    k_rr = k[np.ix_(r, r)]
    if c.size == 0:
        return Condensation(
            tuple(retained), (), _readonly(k_rr), _readonly(np.zeros((0, r.size)))
        )
    k_cc = k[np.ix_(c, c)]
    k_cr = k[np.ix_(c, r)]
    k_rc = k[np.ix_(r, c)]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter('error', scipy.linalg.LinAlgWarning)
            recovery = -scipy.linalg.solve(k_cc, k_cr)
    except (np.linalg.LinAlgError, scipy.linalg.LinAlgWarning):
        raise ConfigError(
            f'condensed: K_cc is singular; condensed DOFs {_null_dofs(k_cc, cond)} have no '
            'stiffness of their own (retain them or add stiffness)'
        ) from None
    stiffness = k_rr + k_rc @ recovery
    if np.allclose(k, k.T, rtol=1e-10, atol=1e-12 * float(np.max(np.abs(k)))):
        stiffness = 0.5 * (stiffness + stiffness.T)
    return Condensation(tuple(retained), tuple(cond), _readonly(stiffness), _readonly(recovery))


def _null_dofs(k_cc: np.ndarray, cond: list[int]) -> list[int]:
    """Condensed DOFs taking part in the (near) null space of ``K_cc``."""
    _, singular, vt = np.linalg.svd(k_cc)
    top = float(singular[0]) if singular.size else 0.0
    null = vt[singular <= max(top, 1e-300) * k_cc.shape[0] * np.finfo(float).eps * 10.0]
    if null.size == 0:  # ill-conditioned rather than exactly singular: the weakest direction
        null = vt[-1:]
    weight = np.max(np.abs(null), axis=0)
    return [cond[i] for i in np.flatnonzero(weight > 1e-6 * float(np.max(weight)))]


# --------------------------------------------------------------------------- damping


def rayleigh_coefficients(
    omega_i: float, omega_j: float, zeta_i: float, zeta_j: float
) -> tuple[float, float]:
    """Rayleigh coefficients ``(a0, a1)`` of ``C = a0 M + a1 K``.

    The damping ratio of a mode of circular frequency ``ω`` is ``ζ(ω) = a0/(2ω) + a1 ω/2``;
    imposing ``ζ(ω_i) = ζ_i`` and ``ζ(ω_j) = ζ_j`` gives

        a0 = 2 ω_i ω_j (ζ_i ω_j − ζ_j ω_i) / (ω_j² − ω_i²),
        a1 = 2 (ζ_j ω_j − ζ_i ω_i) / (ω_j² − ω_i²).

    Args:
        omega_i: First circular frequency in rad/s, positive.
        omega_j: Second circular frequency in rad/s, positive and different from ``omega_i``.
        zeta_i: Damping ratio at ``omega_i`` (≥ 0).
        zeta_j: Damping ratio at ``omega_j`` (≥ 0).

    Returns:
        ``(a0, a1)`` in 1/s and s. Either may be negative for unusual ratio pairs.

    Raises:
        ConfigError: On non-positive or equal frequencies or a negative ratio.
    """
    w_i = _positive(omega_i, 'rayleigh', 'omega_i')
    w_j = _positive(omega_j, 'rayleigh', 'omega_j')
    z_i = _ratio(zeta_i, 'rayleigh: zeta_i')
    z_j = _ratio(zeta_j, 'rayleigh: zeta_j')
    if math.isclose(w_i, w_j, rel_tol=1e-9):
        raise ConfigError(
            f'rayleigh: omega_i and omega_j must differ, got {w_i:.6g} and {w_j:.6g} rad/s'
        )
    denominator = w_j**2 - w_i**2
    a0 = 2.0 * w_i * w_j * (z_i * w_j - z_j * w_i) / denominator
    a1 = 2.0 * (z_j * w_j - z_i * w_i) / denominator
    return float(a0), float(a1)


def rayleigh_damping(
    M: Any,
    K: Any,
    modes: Sequence[int] = (1, 2),
    ratios: float | Sequence[float] = (0.05, 0.05),
) -> np.ndarray:
    """Rayleigh damping ``C = a0 M + a1 K`` matching two modal damping ratios.

    Args:
        M: Mass matrix (symmetric positive definite).
        K: Stiffness matrix (symmetric positive semi-definite).
        modes: Two distinct 1-based mode numbers ``(i, j)``.
        ratios: ``(ζ_i, ζ_j)``, or one ratio used at both modes. Default 5 % at both.

    Returns:
        The dense damping matrix. Other modes get ``ζ(ω) = a0/(2ω) + a1 ω/2``.

    Raises:
        ConfigError: On bad modes (out of range, equal, or a zero/duplicate frequency) or
            ratios.
    """
    m, k = _matching(M, K)
    n = m.shape[0]
    if isinstance(modes, (str, bytes)) or len(modes) != 2:
        raise ConfigError(f'damping_modes: expected two mode numbers, got {modes!r}')
    mode_i, mode_j = (int(modes[0]), int(modes[1]))
    if not (1 <= mode_i <= n and 1 <= mode_j <= n) or mode_i == mode_j:
        raise ConfigError(
            f'damping_modes: expected two distinct mode numbers in 1..{n}, got {tuple(modes)}'
        )
    pair = np.atleast_1d(np.asarray(ratios, dtype=object)).reshape(-1)
    if pair.size not in (1, 2):
        raise ConfigError(f'damping_ratio: expected one ratio or a pair, got {ratios!r}')
    z_i = _ratio(pair[0], 'damping_ratio')
    z_j = _ratio(pair[-1], 'damping_ratio')
    omegas, _ = modal_analysis(m, k)
    w_i, w_j = float(omegas[mode_i - 1]), float(omegas[mode_j - 1])
    if w_i <= 0.0 or w_j <= 0.0 or math.isclose(w_i, w_j, rel_tol=1e-9):
        raise ConfigError(
            f'damping_modes: modes {mode_i} and {mode_j} have frequencies {w_i:.6g} and '
            f'{w_j:.6g} rad/s; Rayleigh damping needs two distinct non-zero frequencies'
        )
    a0, a1 = rayleigh_coefficients(w_i, w_j, z_i, z_j)
    return a0 * m + a1 * k


def modal_damping(M: Any, K: Any, ratios: Sequence[float]) -> np.ndarray:
    """Classical damping with a prescribed ratio in every mode.

    ``C = M Φ diag(2 ζ_j ω_j) Φᵀ M`` with ``Φ`` mass-normalised (``Φᵀ M Φ = I``), so
    that ``Φᵀ C Φ = diag(2 ζ_j ω_j)`` exactly.

    Args:
        M: Mass matrix (symmetric positive definite).
        K: Stiffness matrix (symmetric positive semi-definite).
        ratios: Damping ratios ``ζ_1, ζ_2, …`` in mode order (ascending frequency), at least
            one and at most ``n``. **If fewer ratios than modes are given, the last ratio
            applies to all remaining (higher) modes**; a single value damps every mode alike.

    Returns:
        The dense, symmetric damping matrix.

    Raises:
        ConfigError: On empty, negative, non-finite or too many ratios.
    """
    m, k = _matching(M, K)
    n = m.shape[0]
    if isinstance(ratios, (str, bytes)):
        raise ConfigError(f'damping_ratios: expected a list of ratios, got {ratios!r}')
    if np.ndim(ratios) == 0:
        values = [ratios]
    else:
        values = list(np.asarray(ratios, dtype=object).reshape(-1))
    if not values:
        raise ConfigError('damping_ratios: at least one ratio is required')
    if len(values) > n:
        raise ConfigError(
            f'damping_ratios: {len(values)} ratios given but the model has only {n} modes'
        )
    zetas = np.array([_ratio(v, 'damping_ratios') for v in values])
    zetas = np.concatenate([zetas, np.full(n - zetas.size, zetas[-1])])
    omegas, shapes = modal_analysis(m, k)
    m_phi = m @ shapes
    damping = (m_phi * (2.0 * zetas * omegas)) @ m_phi.T
    return 0.5 * (damping + damping.T)


# --------------------------------------------------------------------------- modes


@dataclass(frozen=True, eq=False)
class ModalProperties:
    """Undamped modes with participation factors and effective modal masses.

    Mode index ``j`` runs over the ``n`` modes (ascending frequency), component ``c`` over
    the rows of the influence matrix. Arrays are read-only.

    Attributes:
        omegas: Circular frequencies ``ω_j`` in rad/s, shape ``(n,)``; rigid-body modes
            (``ω² <= RIGID_BODY_RTOL · max ω²``) are reported as exactly 0.
        periods: ``T_j = 2π/ω_j`` in s (``inf`` for ``ω = 0``).
        frequencies: ``f_j = ω_j / 2π`` in Hz.
        shapes: Mass-normalised mode shapes as columns, ``(n, n)``, signed as in
            :func:`~pd_integrator.core.structure.modal_analysis` (largest component positive).
        participation: ``Γ[j, c] = φ_jᵀ M ι_c / (φ_jᵀ M φ_j)``, shape
            ``(n, n_components)``.
        effective_mass: ``M*[j, c] = (φ_jᵀ M ι_c)² / (φ_jᵀ M φ_j)`` in kg.
        effective_mass_ratio: ``M*[j, c] / (ι_cᵀ M ι_c)``; sums to 1 over all modes.
        total_mass: ``ι_cᵀ M ι_c`` per component in kg, shape ``(n_components,)``.
    """

    omegas: np.ndarray
    periods: np.ndarray
    frequencies: np.ndarray
    shapes: np.ndarray
    participation: np.ndarray
    effective_mass: np.ndarray
    effective_mass_ratio: np.ndarray
    total_mass: np.ndarray

    @property
    def n_modes(self) -> int:
        """Number of modes (= number of DOFs)."""
        return int(self.omegas.size)

    @property
    def n_components(self) -> int:
        """Number of excitation components (rows of the influence matrix)."""
        return int(self.total_mass.size)

    def report(
        self,
        dof_names: Sequence[str] | None = None,
        component_names: Sequence[str] | None = None,
    ) -> str:
        """Readable multi-line table of the modes, as shown to the engineer before a test.

        Lists per mode the period (s), frequency (Hz), circular frequency (rad/s) and, per
        excitation component, the participation factor ``Γ``, the effective mass ratio in %
        and its cumulative sum; then the mode shapes scaled to a largest component of 1.
        The printed ``Γ`` refers to those unit-peak shapes (``Γ φ`` is scale-free), not to
        the mass-normalised :attr:`shapes` used by :attr:`participation`.

        Args:
            dof_names: One name per DOF (default ``dof1, dof2, …``).
            component_names: One name per component (default ``x`` for a single component,
                else ``c1, c2, …``).

        Raises:
            ConfigError: If a name list has the wrong length.
        """
        n, n_c = self.n_modes, self.n_components
        dofs = (
            [f'dof{i + 1}' for i in range(n)] if dof_names is None else [str(d) for d in dof_names]
        )
        if component_names is None:
            comps = ['x'] if n_c == 1 else [f'c{i + 1}' for i in range(n_c)]
        else:
            comps = [str(c) for c in component_names]
        if len(dofs) != n:
            raise ConfigError(f'dof_names: expected {n} names, got {len(dofs)}')
        if len(comps) != n_c:
            raise ConfigError(f'component_names: expected {n_c} names, got {len(comps)}')

        def period(value: float) -> str:
            return f'{value:10.4f}' if math.isfinite(value) else f'{"inf":>10}'

        head = f'{"Mode":>4} {"T [s]":>10} {"f [Hz]":>10} {"w [rad/s]":>10}'
        sub = ' ' * len(head)
        for comp in comps:
            label = f'-- {comp} --'
            head += f' | {label:^26}'
            sub += f' | {"Gamma":>9} {"M* %":>7} {"sum %":>7}'
        lines = [
            f'Modal properties: {n} modes, {n_c} excitation component(s)',
            '  total mass '
            + ', '.join(f'{c}: {m:.6g} kg' for c, m in zip(comps, self.total_mass, strict=True)),
            head,
            sub,
        ]
        peaks = np.max(np.abs(self.shapes), axis=0)
        peaks = np.where(peaks > 0.0, peaks, 1.0)
        scaled = self.shapes / peaks
        gamma = self.participation * peaks[:, None]  # Γ of the printed (unit-peak) shapes
        cumulative = np.cumsum(self.effective_mass_ratio, axis=0)
        for j in range(n):
            row = (
                f'{j + 1:>4} {period(float(self.periods[j]))} '
                f'{self.frequencies[j]:10.4f} {self.omegas[j]:10.4f}'
            )
            for c in range(n_c):
                row += (
                    f' | {gamma[j, c]:9.4g} '
                    f'{100.0 * self.effective_mass_ratio[j, c]:7.2f} '
                    f'{100.0 * cumulative[j, c]:7.2f}'
                )
            lines.append(row)
        lines.append('')
        lines.append('Mode shapes, each scaled to a largest component of +1 (Gamma above refers')
        lines.append('to these shapes; M* % is independent of the scaling):')
        width = max(8, *(len(d) for d in dofs))
        lines.append(f'{"DOF":<{width}}' + ''.join(f' {f"mode {j + 1}":>9}' for j in range(n)))
        for i, dof in enumerate(dofs):
            lines.append(f'{dof:<{width}}' + ''.join(f' {scaled[i, j]:9.4f}' for j in range(n)))
        return '\n'.join(line.rstrip() for line in lines)


def modal_properties(M: Any, K: Any, influences: Any) -> ModalProperties:
    """Modes, participation factors and effective modal masses.

    Args:
        M: Mass matrix (symmetric positive definite), ``n``×``n``.
        K: Stiffness matrix (symmetric positive semi-definite), ``n``×``n``.
        influences: Influence vectors ``ι_c`` as the rows of an ``n_components``×``n``
            array (a 1-D length-``n`` vector is one component).

    Returns:
        A :class:`ModalProperties`.

    Raises:
        ConfigError: On malformed matrices, a wrongly shaped influence array or an influence
            vector with zero mass ``ι_cᵀ M ι_c``.
    """
    m, k = _matching(M, K)
    n = m.shape[0]
    try:
        iota = np.array(influences, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError('influences: expected an array of numbers') from None
    if iota.ndim == 1:
        iota = iota.reshape(1, -1)
    if iota.ndim != 2 or iota.shape[1] != n or iota.shape[0] == 0:
        raise ConfigError(
            f'influences: expected shape (n_components, {n}), got {np.shape(influences)}'
        )
    if not np.all(np.isfinite(iota)):
        raise ConfigError('influences: all values must be finite')
    omegas, shapes = modal_analysis(m, k)
    # Rigid-body modes come out of the eigensolver with round-off ω² of either sign; treat
    # ω² below the tolerance structure.modal_analysis uses for negative values as exactly 0.
    omegas = np.where(omegas**2 <= RIGID_BODY_RTOL * float(np.max(omegas**2)), 0.0, omegas)
    m_iota = m @ iota.T  # (n, n_c)
    total = np.einsum('cn,nc->c', iota, m_iota)
    for c, value in enumerate(total):
        if not value > 0.0:
            raise ConfigError(
                f'influences: component {c} has zero mass (iota^T M iota = {value:.6g})'
            )
    modal_mass = np.einsum('nj,nk,kj->j', shapes, m, shapes)  # φ_jᵀ M φ_j (= 1 here)
    l_factor = shapes.T @ m_iota  # φ_jᵀ M ι_c, (n, n_c)
    participation = l_factor / modal_mass[:, None]
    effective = l_factor**2 / modal_mass[:, None]
    with np.errstate(divide='ignore'):
        periods = np.where(omegas > 0.0, 2.0 * np.pi / np.where(omegas > 0, omegas, 1.0), np.inf)
    return ModalProperties(
        omegas=_readonly(omegas),
        periods=_readonly(periods),
        frequencies=_readonly(omegas / (2.0 * np.pi)),
        shapes=_readonly(shapes),
        participation=_readonly(participation),
        effective_mass=_readonly(effective),
        effective_mass_ratio=_readonly(effective / total[None, :]),
        total_mass=_readonly(total),
    )
