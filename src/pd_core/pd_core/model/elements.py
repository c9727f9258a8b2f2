"""Structural elements: element stiffness, assembly and static condensation.

Pure numerical building blocks for describing the numerical part of a hybrid test as a set
of elements instead of hand-written matrices:

* element stiffness matrices (:func:`spring_stiffness`, :func:`beam_column_2d_stiffness`);
* P-Δ under a constant axial load: the geometric stiffness of a beam-column's chord (or its
  consistent one, :func:`beam_column_2d_geometric_stiffness`), of a spring or storey
  (:func:`pdelta_stiffness`) and of a nonlinear spring (:class:`PDeltaHysteresis`);
* assembly into a global matrix with fixed (ground) DOFs removed (:func:`assemble`);
* static condensation of massless DOFs, e.g. joint rotations (:func:`static_condensation`).

Damping matrices are built by :mod:`.damping`, modal properties by :mod:`.modes`.

Sign conventions: 2-D frames lie in the global x–y plane, rotations are counter-clockwise
positive. All quantities are SI (N, m, kg, s). Only numpy/scipy are used (and the uniaxial
hysteresis interface of :mod:`pd_common.specimen`, which :class:`PDeltaHysteresis` wraps).
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

from pd_common.specimen.hysteresis import HysteresisModel, State

from ..errors import ConfigError
from ..matrices import readonly_copy
from .checks import dense_square, positive

__all__ = [
    'BEAM_COLUMN_GEOMETRIES',
    'SPARSE_THRESHOLD',
    'Condensation',
    'PDeltaHysteresis',
    'assemble',
    'beam_column_2d_geometric_stiffness',
    'beam_column_2d_stiffness',
    'pdelta_stiffness',
    'spring_stiffness',
    'static_condensation',
]

#: :func:`assemble` returns a scipy.sparse CSR matrix by default from this many DOFs on.
SPARSE_THRESHOLD = 200

#: ``geometry`` of a beam-column: ``linear`` (no axial-load effect), ``pdelta`` (the chord's
#: geometric stiffness, OpenSees's ``geomTransf PDelta`` for a linear element) and
#: ``pdelta_consistent`` (the consistent geometric stiffness of the cubic shape functions).
BEAM_COLUMN_GEOMETRIES = ('linear', 'pdelta', 'pdelta_consistent')


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
    value = positive(k, name, 'stiffness k')
    return np.array([[value, -value], [-value, value]])


def beam_column_2d_stiffness(
    xi: tuple[float, float],
    xj: tuple[float, float],
    E: float,
    A: float,
    I: float,  # noqa: E741 - the engineering symbol
    *,
    name: str = 'beam_column_2d',
    geometry: str = 'linear',
    axial_load: float = 0.0,
) -> np.ndarray:
    """Global stiffness of a linear elastic 2-D Euler–Bernoulli frame element.

    The local matrix (axis from node ``i`` to node ``j``, length ``L``) couples the axial
    stiffness ``EA/L`` with the flexural terms ``12EI/L³, 6EI/L², 4EI/L, 2EI/L``; it is
    rotated to global axes by ``K = Tᵀ k T`` with the direction cosines of the element.
    With ``geometry`` ``pdelta`` or ``pdelta_consistent`` the local geometric stiffness of
    the constant compressive ``axial_load`` (see :func:`beam_column_2d_geometric_stiffness`)
    is added to ``k`` before the rotation.

    Args:
        xi: Global coordinates ``(x, y)`` of node ``i`` in m.
        xj: Global coordinates ``(x, y)`` of node ``j`` in m.
        E: Young's modulus in Pa, positive.
        A: Cross-section area in m², positive.
        I: Second moment of area about the bending axis in m⁴, positive.
        name: Element name used in error messages.
        geometry: One of :data:`BEAM_COLUMN_GEOMETRIES`; ``linear`` (default) ignores
            ``axial_load`` and gives the elastic matrix unchanged.
        axial_load: ``P`` in N, compression positive (tension negative), held constant.

    Returns:
        The symmetric 6×6 stiffness for the end DOFs ``[ux_i, uy_i, rz_i, ux_j, uy_j, rz_j]``
        in global axes (rotations counter-clockwise positive). A free element has exactly
        three rigid-body modes (``linear``).

    Raises:
        ConfigError: On malformed coordinates, a zero length or non-positive ``E``, ``A``
            or ``I``, an unknown ``geometry`` or a non-finite ``axial_load``.
    """
    length, c, s = _frame_geometry(xi, xj, name)
    e = positive(E, name, 'E')
    a = positive(A, name, 'A')
    inertia = positive(I, name, 'I')
    geometric = _local_geometric(length, geometry, axial_load, name)
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
        ],
        dtype=np.float64,
    )
    if geometric is not None:
        local = local + geometric
    return _to_global(local, c, s)


def beam_column_2d_geometric_stiffness(
    xi: tuple[float, float],
    xj: tuple[float, float],
    axial_load: float,
    *,
    consistent: bool = False,
    name: str = 'beam_column_2d',
) -> np.ndarray:
    """Global geometric stiffness ``K_g`` of a 2-D frame element under a constant axial load.

    With the axial force ``N = −P`` (tension positive; ``P`` compression positive) the local
    matrix on the transverse and rotation DOFs ``(v_i, θ_i, v_j, θ_j)`` is

    * the chord's (P-Δ, ``consistent=False``): ``(N/L) [[1, −1], [−1, 1]]`` on ``(v_i, v_j)``,
      nothing on the rotations — the matrix OpenSees's ``geomTransf PDelta`` adds to a linear
      element (``PDeltaCrdTransf2d``);
    * the consistent one (``consistent=True``, P-δ along the member as well, the cubic
      Hermitian shape functions): ``(N/L) [[6/5, L/10, −6/5, L/10], [L/10, 2L²/15, −L/10,
      −L²/30], [−6/5, −L/10, 6/5, −L/10], [L/10, −L²/30, −L/10, 2L²/15]]``.

    No term acts on the axial DOFs. The matrix is rotated to global axes like the elastic one.

    Args:
        xi: Global coordinates ``(x, y)`` of node ``i`` in m.
        xj: Global coordinates ``(x, y)`` of node ``j`` in m.
        axial_load: ``P`` in N, compression positive.
        consistent: The consistent matrix instead of the chord's.
        name: Element name used in error messages.

    Returns:
        The symmetric 6×6 ``K_g`` for ``[ux_i, uy_i, rz_i, ux_j, uy_j, rz_j]`` (compression
        makes it negative semi-definite).

    Raises:
        ConfigError: On malformed coordinates, a zero length or a non-finite ``axial_load``.
    """
    length, c, s = _frame_geometry(xi, xj, name)
    geometric = _local_geometric(length, 'pdelta_consistent' if consistent else 'pdelta',
                                 axial_load, name)
    assert geometric is not None
    return _to_global(geometric, c, s)


def _frame_geometry(xi: tuple[float, float], xj: tuple[float, float], name: str
                    ) -> tuple[float, float, float]:
    """Length and direction cosines ``(L, cos, sin)`` of the element from ``i`` to ``j``."""
    points = []
    for label, point in (('xi', xi), ('xj', xj)):
        try:
            coords = np.array(point, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            msg = f'{name}: {label} must be a pair (x, y), got {point!r}'
            raise ConfigError(msg) from None
        if coords.shape != (2,) or not np.all(np.isfinite(coords)):
            msg = f'{name}: {label} must be a finite pair (x, y), got {point!r}'
            raise ConfigError(msg)
        points.append(coords)
    dx, dy = points[1] - points[0]
    length = math.hypot(dx, dy)
    scale = max(float(np.max(np.abs(points[0]))), float(np.max(np.abs(points[1]))), 1.0)
    if length <= 1e-12 * scale:
        msg = f'{name}: nodes xi and xj coincide (zero length)'
        raise ConfigError(msg)
    return length, float(dx / length), float(dy / length)


def _local_geometric(length: float, geometry: str, axial_load: float, name: str
                     ) -> np.ndarray | None:
    """The local 6×6 geometric stiffness of ``geometry`` (``None`` for ``linear``)."""
    if geometry not in BEAM_COLUMN_GEOMETRIES:
        msg = (f'{name}: geometry must be one of {", ".join(BEAM_COLUMN_GEOMETRIES)}, got '
               f'{geometry!r}')
        raise ConfigError(msg)
    if geometry == 'linear':
        return None
    try:
        load = float(axial_load)
    except (TypeError, ValueError):
        load = math.nan
    if isinstance(axial_load, bool) or not math.isfinite(load):
        msg = (f'{name}: axial_load must be a finite number (N, compression positive), got '
               f'{axial_load!r}')
        raise ConfigError(msg)
    n_over_l = -load / length  # N / L with the axial force N = -P (tension positive)
    geometric = np.zeros((6, 6))
    if geometry == 'pdelta':
        transverse = np.array([1, 4])
        geometric[np.ix_(transverse, transverse)] = n_over_l * np.array([[1.0, -1.0],
                                                                          [-1.0, 1.0]])
        return geometric
    ell = length
    flexural = np.array([1, 2, 4, 5])
    geometric[np.ix_(flexural, flexural)] = n_over_l * np.array(
        [
            [6.0 / 5.0, ell / 10.0, -6.0 / 5.0, ell / 10.0],
            [ell / 10.0, 2.0 * ell**2 / 15.0, -ell / 10.0, -(ell**2) / 30.0],
            [-6.0 / 5.0, -ell / 10.0, 6.0 / 5.0, -ell / 10.0],
            [ell / 10.0, -(ell**2) / 30.0, -ell / 10.0, 2.0 * ell**2 / 15.0],
        ]
    )
    return geometric


def _to_global(local: np.ndarray, c: float, s: float) -> np.ndarray:
    """``Tᵀ k T`` (symmetrised) for the direction cosines ``c, s`` of the element."""
    # Local (axial, transverse, rotation) = R · global (ux, uy, rz) at each node.
    rotation = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    transform = np.zeros((6, 6))
    transform[:3, :3] = rotation
    transform[3:, 3:] = rotation
    stiffness: np.ndarray = transform.T @ local @ transform
    symmetric: np.ndarray = 0.5 * (stiffness + stiffness.T)
    return symmetric


# --------------------------------------------------------------------------- P-Δ of springs


def pdelta_stiffness(axial_load: float, height: float, *, name: str = 'spring') -> np.ndarray:
    """The P-Δ geometric stiffness of a spring or storey: a leaning column of height ``L``.

    A constant compressive load ``P`` on a storey of height ``L`` whose drift is
    ``d = x_j − x_i`` adds the lateral force ``−P d / L`` (the overturning moment ``P d``
    balanced by a shear ``P d / L``); the spring's force becomes ``f(d) − P d / L``.

    Args:
        axial_load: ``P`` in N, compression, positive.
        height: ``L`` in m, positive.
        name: Element name used in error messages.

    Returns:
        ``−(P/L) [[1, −1], [−1, 1]]`` for the DOF order ``[i, j]``.

    Raises:
        ConfigError: If ``P`` or ``L`` is not a positive finite number.
    """
    ratio = positive(axial_load, name, 'axial_load') / positive(height, name, 'height')
    return np.array([[-ratio, ratio], [ratio, -ratio]])


class PDeltaHysteresis(HysteresisModel):
    """A uniaxial model with the P-Δ term of a constant axial load: ``f(d) − (P/L) d``.

    Wraps ``inner`` (any :class:`~pd_common.specimen.hysteresis.HysteresisModel`, owned and
    mutated): a trial evaluates ``inner`` at ``d`` and subtracts ``(P/L) d``; commit, revert
    and reset act on both. The tangent (a finite difference of trials, see
    :func:`pd_common.specimen.column.hysteresis_tangent`) and :attr:`initial_stiffness` are the
    inner model's minus ``P/L``.

    Args:
        inner: The spring's hysteresis model ``f(d)``.
        axial_load: ``P`` in N, compression, positive.
        height: ``L`` in m, positive.
        name: Element name used in error messages.

    Raises:
        ConfigError: If ``P`` or ``L`` is not a positive finite number.
    """

    def __init__(self, inner: HysteresisModel, axial_load: float, height: float, *,
                 name: str = 'nonlinear_spring') -> None:
        self._inner = inner
        self._ratio = -float(pdelta_stiffness(axial_load, height, name=name)[0, 0])
        super().__init__()

    @property
    def inner(self) -> HysteresisModel:
        """The wrapped model ``f(d)``."""
        return self._inner

    @property
    def geometric_stiffness(self) -> float:
        """``P/L`` in N/m (subtracted from the inner model's stiffness)."""
        return self._ratio

    def _initial_state(self) -> State:
        return ()

    def _evaluate(self, x: float) -> tuple[float, State]:
        force = float(self._inner.set_trial_displacement(x)) - self._ratio * x
        return force, ()

    @property
    def initial_stiffness(self) -> float:
        """The inner model's initial stiffness minus ``P/L`` in N/m (may be negative)."""
        return self._inner.initial_stiffness - self._ratio

    def commit(self) -> None:
        """Commit the inner model's trial and this one's."""
        self._inner.commit()
        super().commit()

    def revert_to_last_commit(self) -> None:
        """Discard the trial of both."""
        self._inner.revert_to_last_commit()
        super().revert_to_last_commit()

    def reset(self) -> None:
        """Return both to the virgin state."""
        self._inner.reset()
        super().reset()


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
        msg = f'assemble: n must be a positive integer, got {n!r}'
        raise ConfigError(msg)
    n = int(n)
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    values: list[np.ndarray] = []
    for number, entry in enumerate(element_matrices):
        label = f'element {number}'
        try:
            indices, matrix = entry
        except (TypeError, ValueError):
            msg = f'{label}: expected a pair (indices, matrix)'
            raise ConfigError(msg) from None
        if isinstance(indices, (str, bytes)) or not isinstance(indices, Sequence | np.ndarray):
            msg = f'{label}: indices must be a sequence, got {indices!r}'
            raise ConfigError(msg)
        local: list[int] = []
        glob: list[int] = []
        for position, index in enumerate(indices):
            if index is None:
                continue
            if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
                msg = f'{label}: DOF index must be an integer or None, got {index!r}'
                raise ConfigError(msg)
            if not 0 <= int(index) < n:
                msg = f'{label}: DOF index {int(index)} is out of range 0..{n - 1}'
                raise ConfigError(msg)
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
        msg = f'{label}: matrix must contain numbers'
        raise ConfigError(msg) from None
    if dense.ndim == 0 and size == 1:
        dense = dense.reshape(1, 1)
    if dense.ndim != 2 or dense.shape[0] != dense.shape[1]:
        msg = f'{label}: matrix must be square, got shape {dense.shape}'
        raise ConfigError(msg)
    if dense.shape[0] != size:
        msg = (
            f'{label}: matrix is {dense.shape[0]}x{dense.shape[1]} but {size} DOF indices '
            'were given'
        )
        raise ConfigError(msg)
    if not np.all(np.isfinite(dense)):
        msg = f'{label}: matrix values must be finite'
        raise ConfigError(msg)
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
    k = dense_square(K, 'stiffness')
    n = k.shape[0]
    if isinstance(condensed, (str, bytes)):
        msg = f'condensed: expected a sequence of DOF indices, got {condensed!r}'
        raise ConfigError(msg)
    cond: list[int] = []
    for index in condensed:
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            msg = f'condensed: DOF index must be an integer, got {index!r}'
            raise ConfigError(msg)
        if not 0 <= int(index) < n:
            msg = f'condensed: DOF index {int(index)} is out of range 0..{n - 1}'
            raise ConfigError(msg)
        cond.append(int(index))
    if len(set(cond)) != len(cond):
        msg = f'condensed: DOF indices must be unique, got {cond}'
        raise ConfigError(msg)
    chosen = set(cond)
    retained = [i for i in range(n) if i not in chosen]
    if not retained:
        msg = 'condensed: at least one DOF must be retained'
        raise ConfigError(msg)
    r = np.asarray(retained, dtype=np.intp)
    c = np.asarray(cond, dtype=np.intp)
    k_rr = k[np.ix_(r, r)]
    if c.size == 0:
        return Condensation(
            tuple(retained), (), readonly_copy(k_rr), readonly_copy(np.zeros((0, r.size)))
        )
    k_cc = k[np.ix_(c, c)]
    k_cr = k[np.ix_(c, r)]
    k_rc = k[np.ix_(r, c)]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter('error', scipy.linalg.LinAlgWarning)
            recovery = -scipy.linalg.solve(k_cc, k_cr)
    except (np.linalg.LinAlgError, scipy.linalg.LinAlgWarning):
        msg = (
            f'condensed: K_cc is singular; condensed DOFs {_null_dofs(k_cc, cond)} have no '
            'stiffness of their own (retain them or add stiffness)'
        )
        raise ConfigError(msg) from None
    stiffness = k_rr + k_rc @ recovery
    if np.allclose(k, k.T, rtol=1e-10, atol=1e-12 * float(np.max(np.abs(k)))):
        stiffness = 0.5 * (stiffness + stiffness.T)
    return Condensation(
        tuple(retained), tuple(cond), readonly_copy(stiffness), readonly_copy(recovery)
    )


def _null_dofs(k_cc: np.ndarray, cond: list[int]) -> list[int]:
    """Condensed DOFs taking part in the (near) null space of ``K_cc``."""
    _, singular, vt = np.linalg.svd(k_cc)
    top = float(singular[0]) if singular.size else 0.0
    null = vt[singular <= max(top, 1e-300) * k_cc.shape[0] * np.finfo(float).eps * 10.0]
    if null.size == 0:  # ill-conditioned rather than exactly singular: the weakest direction
        null = vt[-1:]
    weight = np.max(np.abs(null), axis=0)
    return [cond[i] for i in np.flatnonzero(weight > 1e-6 * float(np.max(weight)))]
