"""Spectral stability and accuracy analysis of the integration schemes (thesis §3.3.1).

For a linear SDOF in free vibration (``m = 1``, ``c = 2ξω``, ``k = ω²``) every scheme is a
recursion ``x̂_{n+1} = A x̂_n`` (thesis eqs. 3.4–3.5) whose amplification matrix ``A`` depends
on ``Ω = ωΔt``, on the viscous damping ratio ``ξ`` and on the scheme's parameters only. Each
registered scheme provides it as the classmethod
``amplification_matrix(omega_dt, xi=0.0, **parameters)``, whose parameters are the scheme's
declared :attr:`~.schemes.Integrator.PARAMETERS`.

From the eigenvalues of ``A`` (eqs. 3.8–3.9):

* the **spectral radius** ``ρ = max |λ_k|``; the scheme is stable at ``Ω`` if ``ρ ≤ 1``;
* the **principal roots** are the complex-conjugate pair ``λ = e^{(−ξ̄ ± i) Ω̄}`` (eq. 3.10),
  the one of largest modulus when there is more than one pair; the other roots are spurious
  (the thesis's ``λ_3``) and excluded from the accuracy measures;
* the **numerical frequency** ``Ω̄ = ω̄Δt = |arg λ|`` in ``(0, π]`` (eq. 3.16 with the
  two-argument arctangent, so ``Ω̄ > π/2`` is kept on the right branch);
* the **numerical damping ratio** ``ξ̄ = −ln|λ| / Ω̄`` (eq. 3.15, the convention of Hilber,
  Hughes & Taylor 1977 and of Chung & Hulbert 1993), so that successive peaks of the free
  vibration decay by ``e^{−2πξ̄}`` per cycle;
* the **relative period error** ``(T̄ − T)/T = Ω_D/Ω̄ − 1`` (negative: the period shrinks) and
  the thesis's Figure 3.2 quantity ``(T − T̄)/T``.

With viscous damping (``ξ > 0``) the reference is the exact free vibration
``e^{−ξωt} cos(ω_D t)``, ``ω_D = ω√(1 − ξ²)``, whose exact one-step root is
``e^{(−ξ ± i√(1−ξ²)) Ω}``:

* ``T = 2π/ω_D`` is the exact *damped* period (``2π/ω`` for ``ξ = 0``), so the period error is
  zero for an exact integrator at any ``ξ``;
* :attr:`SpectralProperties.numerical_damping` is the **total** ``ξ̄`` (viscous + algorithmic),
  i.e. exactly what a free-vibration record shows;
* :attr:`SpectralProperties.algorithmic_damping` is the scheme's own part
  ``ξ̄ − ξ/√(1 − ξ²)``: the exact root has ``ξ̄ = ξ/√(1 − ξ²)`` under the definition of
  eq. 3.15, so this part is zero for an exact integrator. It differs from the literature's
  plain ``ξ̄ − ξ`` by ``ξ/√(1 − ξ²) − ξ ≈ ξ³/2`` (6·10⁻⁵ for ``ξ = 0.05``).

Beyond the bifurcation (all roots real) there is no oscillation: ``Ω̄``, ``ξ̄`` and the period
errors are NaN; two coincident negative real roots (e.g. Newmark explicit at ``Ω = 2``) count
as the limiting oscillation of period two steps, ``Ω̄ = π``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..schemes import Integrator, scheme_class

__all__ = [
    'STABILITY_TOLERANCE',
    'SWEEP_COLUMNS',
    'SpectralProperties',
    'amplification_matrix',
    'default_parameters',
    'expected_period_error',
    'has_amplification_matrix',
    'omega_grid',
    'spectral_properties',
    'sweep',
]

#: A spectral radius up to ``1 + STABILITY_TOLERANCE`` counts as stable. It absorbs the
#: ``O(√ε)`` error of computed eigenvalues at a double root on the unit circle (Newmark
#: explicit at ``Ω = 2``, which eq. 3.14 counts as stable).
STABILITY_TOLERANCE = 1e-6

#: Leading columns of a :func:`sweep`, as written by
#: :func:`~.analysis_figures.write_sweep_csv` (more columns follow them).
SWEEP_COLUMNS = ('omega_dt', 'dt_over_T', 'spectral_radius', 'numerical_damping',
                 'period_error', 'period_shrinkage')

# A root with |Im λ| at most this (relative to max(1, ρ)) is real: rounding noise only.
_IMAG_TOLERANCE = 1e-12
# Two real roots this close (relative) are a double root at the bifurcation.
_COINCIDENT_TOLERANCE = 1e-6


# ----------------------------------------------------------------------------- schemes


def has_amplification_matrix(scheme: str | type[Integrator] | Integrator) -> bool:
    """Whether the scheme's amplification matrix is available for the analysis.

    Raises:
        ConfigError: On an unknown scheme name.
    """
    cls = scheme_class(scheme)
    try:
        cls.amplification_matrix(0.1, 0.0)
    except NotImplementedError:
        return False
    except Exception:  # noqa: BLE001 - e.g. a required parameter: the matrix exists
        return True
    return True


def default_parameters(scheme: str | type[Integrator] | Integrator) -> dict[str, Any]:
    """The scheme's declared parameters and their defaults (``PARAMETERS``).

    Raises:
        ConfigError: On an unknown scheme name.
    """
    return scheme_class(scheme).parameter_defaults()


def amplification_matrix(
    scheme: str | type[Integrator] | Integrator, omega_dt: float, xi: float = 0.0,
    **parameters: Any,
) -> np.ndarray:
    """Amplification matrix of a scheme for the linear SDOF free vibration.

    Args:
        scheme: Scheme name, integrator class or instance.
        omega_dt: ``Ω = ωΔt`` (≥ 0).
        xi: Viscous damping ratio ``ξ`` in ``[0, 1)``.
        **parameters: The scheme's parameters (defaults where omitted).

    Returns:
        The square amplification matrix as a float or complex array.

    Raises:
        ConfigError: On an unknown scheme or parameter, a scheme without an amplification
            matrix, or an out-of-range ``Ω`` or ``ξ``.
    """
    cls = scheme_class(scheme)
    omega = _check_omega(omega_dt)
    damping = _check_xi(xi)
    declared = cls.parameter_defaults()
    for name in parameters:
        if name not in declared:
            known = ', '.join(sorted(declared)) or 'none'
            msg = f'scheme {cls.name!r}: unknown parameter {name!r}; parameters: {known}'
            raise ConfigError(msg)
    try:
        matrix = cls.amplification_matrix(omega, damping, **parameters)
    except NotImplementedError:
        msg = f'scheme {cls.name!r}: no amplification_matrix, cannot be analysed'
        raise ConfigError(msg) from None
    except (TypeError, ConfigError) as err:  # e.g. a parameter out of its range
        msg = f'scheme {cls.name!r}: {err}'
        raise ConfigError(msg) from None
    array = np.asarray(matrix)
    if array.ndim != 2 or array.shape[0] != array.shape[1] or array.shape[0] == 0:
        msg_0 = (
            f'scheme {cls.name!r}: amplification_matrix returned shape {array.shape}, '
            'expected a square matrix'
        )
        raise ConfigError(msg_0)
    if not np.all(np.isfinite(array)):
        msg_0 = f'scheme {cls.name!r}: amplification_matrix is not finite at Ω = {omega:g}'
        raise ConfigError(msg_0)
    return array


def _check_omega(omega_dt: float) -> float:
    try:
        omega = float(omega_dt)
    except (TypeError, ValueError):
        msg = f'omega_dt: expected a number, got {omega_dt!r}'
        raise ConfigError(msg) from None
    if not (math.isfinite(omega) and omega >= 0.0):
        msg = f'omega_dt: must be finite and ≥ 0, got {omega_dt!r}'
        raise ConfigError(msg)
    return omega


def _check_xi(xi: float) -> float:
    try:
        value = float(xi)
    except (TypeError, ValueError):
        msg = f'xi: expected a number, got {xi!r}'
        raise ConfigError(msg) from None
    if not (0.0 <= value < 1.0):
        msg = f'xi: viscous damping ratio must be in [0, 1), got {xi!r}'
        raise ConfigError(msg)
    return value


# ----------------------------------------------------------------------------- spectrum


@dataclass(frozen=True)
class SpectralProperties:
    """Stability and accuracy of a scheme at one ``Ω`` (see the module docstring).

    Attributes:
        omega_dt: ``Ω = ωΔt``.
        xi: Viscous damping ratio ``ξ`` of the analysed SDOF.
        spectral_radius: ``ρ = max |λ_k|`` over all roots (spurious ones included).
        principal_radius: ``|λ|`` of the principal pair (NaN if the roots are real).
        numerical_frequency: ``Ω̄ = |arg λ|`` in rad per step (NaN without oscillation).
        numerical_damping: Total ``ξ̄ = −ln|λ|/Ω̄`` (viscous + algorithmic).
        algorithmic_damping: The scheme's part, ``ξ̄ − ξ/√(1 − ξ²)``.
        period_error: ``(T̄ − T)/T`` with ``T`` the exact damped period (negative: shrinks).
        period_shrinkage: The thesis's ``(T − T̄)/T = −period_error`` (Figure 3.2).
        stable: ``ρ ≤ 1 +`` :data:`STABILITY_TOLERANCE`.
    """

    omega_dt: float
    xi: float
    spectral_radius: float
    principal_radius: float
    numerical_frequency: float
    numerical_damping: float
    algorithmic_damping: float
    period_error: float
    period_shrinkage: float
    stable: bool

    @property
    def dt_over_T(self) -> float:  # noqa: N802 - the thesis's Δt/T
        """``Δt/T = Ω/(2π)`` with the undamped period ``T = 2π/ω`` (Figure 3.2 abscissa)."""
        return self.omega_dt / (2.0 * math.pi)

    @property
    def oscillatory(self) -> bool:
        """Whether the principal roots are a complex pair (finite ``Ω̄``)."""
        return not math.isnan(self.numerical_frequency)

    @property
    def decay_per_cycle(self) -> float:
        """Ratio of successive free-vibration peaks, ``e^{−2πξ̄}`` (NaN without oscillation)."""
        return math.exp(-2.0 * math.pi * self.numerical_damping)


def _eigenvalues(matrix: np.ndarray) -> np.ndarray:
    """Eigenvalues of ``A``.

    Computed after an exact diagonal similarity that balances the principal eigenvector.

    For small ``Ω`` the principal eigenvectors of a state such as ``(x, Δt·v, Δt²·a)`` are
    nearly parallel (``(1, ±iΩ, −Ω²)``), so the eigenvalues of ``A`` itself carry an absolute
    error of about ``ε/Ω``. Rescaling the state by the moduli of that eigenvector, rounded to
    powers of two (``D⁻¹ A D`` is then formed without rounding and has the same eigenvalues),
    makes them well conditioned: ``Ω̄`` comes out with a relative error of about ``ε/Ω``
    instead of ``ε/Ω²``.
    """
    values, vectors = np.linalg.eig(matrix)
    upper = np.nonzero(values.imag > 0.0)[0]
    candidates = upper if upper.size else np.arange(values.size)
    k = int(candidates[np.argmax(np.abs(values[candidates]))])
    moduli = np.abs(vectors[:, k])
    if not np.all(np.isfinite(moduli)) or np.max(moduli) == 0.0:
        return values.astype(complex)
    moduli = np.where(moduli > 0.0, moduli / np.max(moduli), 1.0)
    scale = 2.0 ** np.clip(np.round(np.log2(moduli)), -200.0, 0.0)
    balanced = matrix * scale[np.newaxis, :] / scale[:, np.newaxis]
    return np.linalg.eigvals(balanced).astype(complex)


def _principal_root(eigenvalues: np.ndarray) -> complex | None:
    """The principal root with ``Im λ ≥ 0``, or ``None`` if the principal roots are real."""
    moduli = np.abs(eigenvalues)
    scale = max(1.0, float(np.max(moduli)))
    upper = eigenvalues[eigenvalues.imag > _IMAG_TOLERANCE * scale]
    if upper.size:
        return complex(upper[int(np.argmax(np.abs(upper)))])
    if eigenvalues.size < 2:
        return None
    real = eigenvalues.real[np.argsort(-moduli)]
    first, second = float(real[0]), float(real[1])
    size = max(abs(first), abs(second))
    if first < 0.0 and second < 0.0 and abs(first - second) <= _COINCIDENT_TOLERANCE * size:
        # A double negative root at the bifurcation: the two-step limit oscillation.
        return complex(-math.sqrt(first * second), 0.0)
    return None


def spectral_properties(
    scheme: str | type[Integrator] | Integrator, omega_dt: float, xi: float = 0.0,
    **parameters: Any,
) -> SpectralProperties:
    """Spectral radius, numerical damping and period error of a scheme at ``Ω = ωΔt``.

    For Newmark explicit with ``ξ = 0`` this is the thesis's eqs. 3.10–3.16: ``Ω̄`` equals
    eq. 3.19, ``ξ̄ = 0`` and ``ρ = 1`` for ``Ω ≤ 2``. At ``Ω = 0`` the limit values are
    returned (period error 0, ``ξ̄ = ξ/√(1 − ξ²)``).

    Args:
        scheme: Scheme name, integrator class or instance.
        omega_dt: ``Ω = ωΔt`` (≥ 0).
        xi: Viscous damping ratio ``ξ`` in ``[0, 1)``.
        **parameters: The scheme's parameters (defaults where omitted).

    Returns:
        The :class:`SpectralProperties`.

    Raises:
        ConfigError: As :func:`amplification_matrix`.
    """
    matrix = amplification_matrix(scheme, omega_dt, xi, **parameters)
    omega = float(omega_dt)
    damping = float(xi)
    eigenvalues = _eigenvalues(matrix)
    rho = float(np.max(np.abs(eigenvalues)))
    stable = rho <= 1.0 + STABILITY_TOLERANCE
    exact_damping = damping / math.sqrt(1.0 - damping * damping)
    if omega == 0.0:
        return SpectralProperties(omega, damping, rho, 1.0, 0.0, exact_damping, 0.0, 0.0, 0.0,
                                  stable)
    root = _principal_root(eigenvalues)
    if root is None:
        nan = math.nan
        return SpectralProperties(omega, damping, rho, nan, nan, nan, nan, nan, nan, stable)
    radius = abs(root)
    omega_bar = abs(math.atan2(root.imag, root.real))
    numerical_damping = -math.log(radius) / omega_bar if radius > 0.0 else math.inf
    omega_damped = omega * math.sqrt(1.0 - damping * damping)
    period_error = omega_damped / omega_bar - 1.0
    return SpectralProperties(
        omega_dt=omega,
        xi=damping,
        spectral_radius=rho,
        principal_radius=radius,
        numerical_frequency=omega_bar,
        numerical_damping=numerical_damping,
        algorithmic_damping=numerical_damping - exact_damping,
        period_error=period_error,
        period_shrinkage=-period_error,
        stable=stable,
    )


def expected_period_error(
    scheme: str | type[Integrator] | Integrator, omega_dt: float, xi: float = 0.0,
    **parameters: Any,
) -> float:
    """Relative period error ``(T̄ − T)/T`` a test at ``Ω`` should show (for the report).

    Args:
        scheme: Scheme name, integrator class or instance.
        omega_dt: ``Ω = ωΔt`` of the mode of interest (the highest, before a test).
        xi: Viscous damping ratio of that mode.
        **parameters: The scheme's parameters.

    Returns:
        The period error, NaN if the scheme has no amplification matrix, if it is unstable at
        ``Ω`` or if the principal roots are real (no oscillation).

    Raises:
        ConfigError: On an unknown scheme or parameter, or an out-of-range ``Ω`` or ``ξ``.
    """
    if not has_amplification_matrix(scheme):
        return math.nan
    properties = spectral_properties(scheme, omega_dt, xi, **parameters)
    return properties.period_error if properties.stable else math.nan


# ----------------------------------------------------------------------------- sweeps


def omega_grid(omega_max: float = 4.0, points: int = 400) -> np.ndarray:
    """``points`` equally spaced values of ``Ω`` in ``(0, omega_max]``.

    Raises:
        ConfigError: If ``omega_max`` is not positive and finite or ``points < 2``.
    """
    if not (math.isfinite(omega_max) and omega_max > 0.0):
        msg = f'omega_max: must be positive and finite, got {omega_max!r}'
        raise ConfigError(msg)
    if int(points) != points or points < 2:
        msg = f'points: must be an integer ≥ 2, got {points!r}'
        raise ConfigError(msg)
    return omega_max * np.arange(1, int(points) + 1) / int(points)


def sweep(
    scheme: str | type[Integrator] | Integrator, omegas: Sequence[float] | np.ndarray,
    xi: float = 0.0, **parameters: Any,
) -> dict[str, np.ndarray]:
    """:func:`spectral_properties` over a range of ``Ω``.

    Args:
        scheme: Scheme name, integrator class or instance.
        omegas: Values of ``Ω = ωΔt``.
        xi: Viscous damping ratio.
        **parameters: The scheme's parameters.

    Returns:
        Arrays by name: the :data:`SWEEP_COLUMNS`, then ``numerical_frequency``,
        ``algorithmic_damping``, ``principal_radius``, ``stable`` (bool) and ``xi``.

    Raises:
        ConfigError: As :func:`amplification_matrix`.
    """
    values = np.asarray(omegas, dtype=float).reshape(-1)
    rows = [spectral_properties(scheme, omega, xi, **parameters) for omega in values]
    result: dict[str, np.ndarray] = {
        'omega_dt': values.copy(),
        'dt_over_T': values / (2.0 * math.pi),
    }
    for name in ('spectral_radius', 'numerical_damping', 'period_error', 'period_shrinkage',
                 'numerical_frequency', 'algorithmic_damping', 'principal_radius'):
        result[name] = np.array([getattr(row, name) for row in rows], dtype=float)
    result['stable'] = np.array([row.stable for row in rows], dtype=bool)
    result['xi'] = np.full(values.shape, float(xi))
    return result
