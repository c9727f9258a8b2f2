"""Accuracy and stability of the integration schemes (thesis §3.3.1).

For a linear elastic SDOF the Newmark explicit scheme is the recursion
``x̂_{i+1} = A x̂_i`` (eq. 3.4–3.5) with the amplification matrix ``A`` of eq. 3.7. Its
principal eigenvalues ``λ = A ± iB = e^{(−ζ̄ ± i) Ω̄}`` (eqs. 3.10–3.12) have modulus one for
``Ω = ωΔt ≤ 2`` (eq. 3.14): no numerical damping (``ζ̄ = 0``, eq. 3.15) and a numerical
frequency ``Ω̄ = ω̄Δt`` (eqs. 3.16, 3.19) larger than ``Ω``, i.e. a period shrinkage
(Figure 3.2). Above ``Ω = 2`` one eigenvalue is real with modulus greater than one and the
response grows without bound.

Conventions used here (``T = 2π/ω``, ``T̄ = 2π/ω̄``, so ``T̄/T = Ω/Ω̄``):

* :func:`period_distortion` is ``(T̄ − T)/T``, negative for a period shrinkage;
* :func:`period_shrinkage` is the thesis's ``(T − T̄)/T`` (Figure 3.2), positive for a shrinkage.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ConfigError, PdIntegratorError, StabilityError
from ..schemes import Integrator, scheme_class
from . import analysis
from .structure import omega_max as structure_omega_max

__all__ = [
    'StabilityReport',
    'check_stability',
    'period_distortion',
    'period_error',
    'period_shrinkage',
    'require_stable',
    'spectral_radius',
]


def spectral_radius(matrix: Any) -> float:
    """Largest eigenvalue modulus ``ρ(A) = max |λ_k|`` of a square matrix."""
    return float(np.max(np.abs(np.linalg.eigvals(np.asarray(matrix, dtype=float)))))


def period_distortion(omega_dt: float, scheme: str = 'newmark_explicit') -> float:
    """Relative period error ``(T̄ − T)/T = Ω/Ω̄ − 1`` (negative: the period shrinks).

    A scheme with a closed-form numerical frequency (its
    :meth:`~pd_core.schemes.Integrator.numerical_frequency`: Newmark explicit,
    eq. 3.19) uses it; any other registered scheme with an ``amplification_matrix`` (default
    parameters, no viscous damping) uses the spectral analysis of
    :mod:`pd_core.dynamics.analysis`.

    Args:
        omega_dt: ``Ω = ωΔt``.
        scheme: Scheme name (a key of ``SCHEMES``).

    Returns:
        The distortion, ``0`` at ``Ω = 0``, NaN above the stability limit, for an unknown
        scheme or for a scheme without a known numerical frequency.
    """
    try:
        cls = scheme_class(scheme)
    except ConfigError:
        return math.nan
    omega = float(omega_dt)
    omega_bar = cls.numerical_frequency(omega)
    if omega_bar is None:
        return _expected_accuracy(cls, omega_dt, {})[0]
    if omega == 0.0:
        return 0.0
    if math.isnan(omega_bar):
        return math.nan
    return omega / omega_bar - 1.0


def period_shrinkage(omega_dt: float, scheme: str = 'newmark_explicit') -> float:
    """Thesis Figure 3.2 quantity ``(T − T̄)/T = 1 − Ω/Ω̄`` (positive: the period shrinks).

    Args:
        omega_dt: ``Ω = ωΔt``.
        scheme: Scheme name.

    Returns:
        ``−period_distortion(omega_dt)``; NaN above the stability limit.
    """
    return -period_distortion(omega_dt, scheme)


#: Alias of :func:`period_shrinkage`, the thesis's ``(T − T̄)/T``.
period_error = period_shrinkage


@dataclass(frozen=True)
class StabilityReport:
    """Outcome of :func:`check_stability`.

    Attributes:
        scheme: Scheme name.
        omega_max: Highest circular frequency of the model in rad/s.
        dt: Time step in s.
        omega_dt: ``Ω = ω_max·Δt``.
        limit: The scheme's stability limit on ``Ω`` (``math.inf`` if unconditional).
        stable: ``Ω ≤ limit`` (thesis eq. 3.14 counts ``Ω = 2`` as stable).
        period_distortion: ``(T̄ − T)/T`` of the highest mode (NaN if unstable or unknown).
        message: One human-readable line summarising the above.
        numerical_damping: The scheme's numerical damping ratio ``ξ̄`` of the highest mode
            (without viscous damping; NaN if unstable or unknown).
    """

    scheme: str
    omega_max: float
    dt: float
    omega_dt: float
    limit: float
    stable: bool
    period_distortion: float
    message: str
    numerical_damping: float = math.nan

    @property
    def max_stable_dt(self) -> float:
        """Largest stable time step ``limit/ω_max`` in s (``inf`` if unconditional or ω = 0)."""
        if math.isinf(self.limit) or self.omega_max == 0.0:
            return math.inf
        return self.limit / self.omega_max


def _expected_accuracy(
    scheme: str | type[Integrator], omega_dt: float, parameters: dict[str, Any]
) -> tuple[float, float, float]:
    """``(period distortion, numerical damping, spectral radius)`` from the analysis, or NaNs.

    For the undamped mode (``ξ = 0``): the scheme's own distortion and damping. NaN for an
    unknown scheme, one without ``amplification_matrix``, or parameters the analysis rejects;
    NaN distortion and damping where the spectrum is unstable.
    """
    nan = (math.nan, math.nan, math.nan)
    try:
        if not analysis.has_amplification_matrix(scheme):
            return nan
        properties = analysis.spectral_properties(scheme, omega_dt, 0.0, **parameters)
    except (PdIntegratorError, ValueError, TypeError, ArithmeticError, np.linalg.LinAlgError):
        return nan
    if not properties.stable:  # no meaningful period or damping of a growing response
        return math.nan, math.nan, properties.spectral_radius
    return (properties.period_error, properties.numerical_damping,
            properties.spectral_radius)


def _format_limit(limit: float) -> str:
    return '∞' if math.isinf(limit) else f'{limit:g}'


def check_stability(
    scheme: str | type[Integrator] | Integrator, mass: Any, stiffness: Any, dt: float,
    *, softening: bool = False,
) -> StabilityReport:
    """Check ``Ω = ω_max·Δt`` against the scheme's stability limit (thesis eq. 3.14).

    Args:
        scheme: Scheme name, integrator class or instance.
        mass: Mass matrix (or scalar for an SDOF), kg.
        stiffness: Initial stiffness matrix (or scalar), N/m.
        dt: Time step in s.
        softening: The structure may reach a negative tangent (the test states a collapse
            drift): the message adds what the scheme assumes of the tangent (its
            :attr:`~pd_core.schemes.Integrator.softening_note`).

    Returns:
        A :class:`StabilityReport` (use :func:`require_stable` to raise on instability).

    Raises:
        ConfigError: On an unknown scheme, a non-positive ``dt`` or malformed matrices.
    """
    cls = scheme_class(scheme)
    try:
        dt_value = float(dt)
    except (TypeError, ValueError):
        msg = f'dt: expected a number, got {dt!r}'
        raise ConfigError(msg) from None
    if not (dt_value > 0.0 and math.isfinite(dt_value)):
        msg = f'dt: must be positive and finite, got {dt!r}'
        raise ConfigError(msg)
    w_max = structure_omega_max(mass, stiffness)
    omega_dt = w_max * dt_value
    # An instance may have a parameter-dependent limit (e.g. rho_b of generalized-alpha).
    limit = float(scheme.stability_limit if isinstance(scheme, Integrator) else
                  cls.stability_limit)
    stable = omega_dt <= limit
    distortion = damping = rho = math.nan
    if stable:
        # An instance's parameters (e.g. its rho_inf) shape its spectrum; a class: defaults.
        parameters = getattr(scheme, 'parameters', None) if isinstance(scheme, Integrator) else {}
        distortion, damping, rho = _expected_accuracy(cls, omega_dt, dict(parameters or {}))
    head = f'ω_max·Δt = {omega_dt:.6g} (limit {_format_limit(limit)} for {cls.name})'
    if stable:
        message = f'{head}: stable'
        if not math.isnan(distortion):
            message += f'; period distortion {100.0 * distortion:.2g} %'.replace('-', '−')
        if abs(damping) >= 1e-6:  # False for NaN
            message += f'; numerical damping {100.0 * damping:.2g} %'.replace('-', '−')
        if rho > 1.0 + 1e-6:
            message += f'; but the spectral radius is {rho:.6g} > 1'
        if softening and cls.softening_note:
            message += f'; softening: {cls.softening_note}'
    else:
        message = (
            f'{head}: UNSTABLE; dt = {dt_value:g} s must be ≤ {limit / w_max:.6g} s '
            f'(ω_max = {w_max:.6g} rad/s)'
        )
    return StabilityReport(
        scheme=cls.name,
        omega_max=w_max,
        dt=dt_value,
        omega_dt=omega_dt,
        limit=limit,
        stable=stable,
        period_distortion=distortion,
        message=message,
        numerical_damping=damping,
    )


def require_stable(report: StabilityReport) -> StabilityReport:
    """Raise if the report is unstable, else return it unchanged.

    Args:
        report: Result of :func:`check_stability`.

    Returns:
        ``report``.

    Raises:
        StabilityError: If ``ω_max·Δt`` exceeds the limit; the one-line message names ``dt``
            and the largest stable time step ``limit/ω_max``.
    """
    if report.stable:
        return report
    msg = (
        f'dt: {report.dt:g} s is unstable for {report.scheme}: ω_max·Δt = '
        f'{report.omega_dt:.6g} > {_format_limit(report.limit)} (ω_max = '
        f'{report.omega_max:.6g} rad/s); use dt ≤ {report.max_stable_dt:.6g} s'
    )
    raise StabilityError(msg)
