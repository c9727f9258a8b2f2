"""Modal properties: modes, participation factors and effective modal masses.

:func:`modal_properties` returns the undamped modes of ``K φ = ω² M φ`` with, per excitation
component, the participation factors and effective modal masses, and
:meth:`ModalProperties.report` the text table an engineer checks before a test.

All quantities are SI (N, m, kg, s). Only numpy is used.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..dynamics.structure import modal_analysis
from ..errors import ConfigError
from ..matrices import readonly_copy
from .checks import mass_and_stiffness

__all__ = [
    'RIGID_BODY_RTOL',
    'ModalProperties',
    'modal_properties',
]

#: :func:`modal_properties` treats modes with ``ω² <= RIGID_BODY_RTOL · max ω²`` as rigid-body
#: modes (``ω = 0``, infinite period).
RIGID_BODY_RTOL = 1e-10


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
            :func:`~pd_core.dynamics.structure.modal_analysis` (largest component
            positive).
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
            msg = f'dof_names: expected {n} names, got {len(dofs)}'
            raise ConfigError(msg)
        if len(comps) != n_c:
            msg = f'component_names: expected {n_c} names, got {len(comps)}'
            raise ConfigError(msg)

        def period(value: float) -> str:
            return f'{value:10.6g}' if math.isfinite(value) else f'{"inf":>10}'

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
                f'{self.frequencies[j]:10.6g} {self.omegas[j]:10.6g}'
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
    m, k = mass_and_stiffness(M, K)
    n = m.shape[0]
    try:
        iota = np.array(influences, dtype=float)
    except (TypeError, ValueError):
        msg = 'influences: expected an array of numbers'
        raise ConfigError(msg) from None
    if iota.ndim == 1:
        iota = iota.reshape(1, -1)
    if iota.ndim != 2 or iota.shape[1] != n or iota.shape[0] == 0:
        msg = f'influences: expected shape (n_components, {n}), got {np.shape(influences)}'
        raise ConfigError(msg)
    if not np.all(np.isfinite(iota)):
        msg = 'influences: all values must be finite'
        raise ConfigError(msg)
    omegas, shapes = modal_analysis(m, k)
    # Rigid-body modes come out of the eigensolver with round-off ω² of either sign; treat
    # ω² below the tolerance structure.modal_analysis uses for negative values as exactly 0.
    omegas = np.where(omegas**2 <= RIGID_BODY_RTOL * float(np.max(omegas**2)), 0.0, omegas)
    m_iota = m @ iota.T  # (n, n_c)
    total = np.einsum('cn,nc->c', iota, m_iota)
    for c, value in enumerate(total):
        if not value > 0.0:
            msg = f'influences: component {c} has zero mass (iota^T M iota = {value:.6g})'
            raise ConfigError(msg)
    modal_mass = np.einsum('nj,nk,kj->j', shapes, m, shapes)  # φ_jᵀ M φ_j (= 1 here)
    l_factor = shapes.T @ m_iota  # φ_jᵀ M ι_c, (n, n_c)
    participation = l_factor / modal_mass[:, None]
    effective = l_factor**2 / modal_mass[:, None]
    with np.errstate(divide='ignore'):
        periods = np.where(omegas > 0.0, 2.0 * np.pi / np.where(omegas > 0, omegas, 1.0), np.inf)
    return ModalProperties(
        omegas=readonly_copy(omegas),
        periods=readonly_copy(periods),
        frequencies=readonly_copy(omegas / (2.0 * np.pi)),
        shapes=readonly_copy(shapes),
        participation=readonly_copy(participation),
        effective_mass=readonly_copy(effective),
        effective_mass_ratio=readonly_copy(effective / total[None, :]),
        total_mass=readonly_copy(total),
    )
