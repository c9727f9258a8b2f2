"""Closed-form free and harmonic vibration of a linear SDOF (Chopra eqs. 2.2.4, 3.2.1–3.2.4).

Exact answers the verification tests check the schemes and :func:`~.nigam_jennings.nigam_jennings`
against: the underdamped free vibration and the response to a sinusoidal load per unit mass.

Units are SI; numpy only.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ConfigError
from .checks import damping_ratio, finite, non_negative, positive

__all__ = [
    'free_vibration',
    'harmonic_response',
]


def free_vibration(
    omega: float, zeta: float, t: Any, x0: float, v0: float
) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form free vibration of an underdamped SDOF (Chopra eq. 2.2.4).

    ``x(t) = e^{−ζωt} [x0 cos ω_D t + (v0 + ζω x0)/ω_D sin ω_D t]``, ``ω_D = ω√(1 − ζ²)``.

    Args:
        omega: Natural circular frequency in rad/s.
        zeta: Damping ratio in ``[0, 1)``.
        t: Times in s (scalar or array).
        x0: Initial displacement in m.
        v0: Initial velocity in m/s.

    Returns:
        ``(x, v)`` at ``t``.
    """
    w = positive(omega, 'omega')
    z = damping_ratio(zeta, 'zeta')
    times = np.asarray(t, dtype=float)
    wd = w * math.sqrt(1.0 - z * z)
    e = np.exp(-z * w * times)
    cs = np.cos(wd * times)
    sn = np.sin(wd * times)
    b = (v0 + z * w * x0) / wd
    x = e * (x0 * cs + b * sn)
    v = e * ((wd * b - z * w * x0) * cs - (wd * x0 + z * w * b) * sn)
    return x, v


def harmonic_response(
    omega: float,
    zeta: float,
    t: Any,
    amplitude: float,
    frequency: float,
    x0: float = 0.0,
    v0: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form response to ``f(t) = amplitude·sin(Ω t)`` (per unit mass), Chopra §3.2.

    Steady state (Chopra eqs. 3.2.2–3.2.4 divided by ``m``)::

        x_ss = F [(ω² − Ω²) sin Ωt − 2ζωΩ cos Ωt] / [(ω² − Ω²)² + (2ζωΩ)²]

    plus the free vibration (:func:`free_vibration`) that makes up the initial conditions
    (the transient of Chopra eq. 3.2.1).

    Args:
        omega: Natural circular frequency in rad/s.
        zeta: Damping ratio in ``[0, 1)``.
        t: Times in s.
        amplitude: ``F`` in m/s².
        frequency: Forcing circular frequency ``Ω`` in rad/s (not at an undamped resonance).
        x0: Initial displacement in m.
        v0: Initial velocity in m/s.

    Returns:
        ``(x, v)`` at ``t``.

    Raises:
        ConfigError: At undamped resonance (``ζ = 0`` and ``Ω = ω``).
    """
    w = positive(omega, 'omega')
    z = damping_ratio(zeta, 'zeta')
    big_w = non_negative(frequency, 'frequency')
    f = finite(amplitude, 'amplitude')
    den = (w * w - big_w * big_w) ** 2 + (2.0 * z * w * big_w) ** 2
    if den == 0.0:
        msg = 'frequency: undamped resonance has no steady state'
        raise ConfigError(msg)
    cs_coef = -f * 2.0 * z * w * big_w / den
    sn_coef = f * (w * w - big_w * big_w) / den
    times = np.asarray(t, dtype=float)
    x_ss = sn_coef * np.sin(big_w * times) + cs_coef * np.cos(big_w * times)
    v_ss = big_w * (sn_coef * np.cos(big_w * times) - cs_coef * np.sin(big_w * times))
    xt, vt = free_vibration(w, z, times, x0 - cs_coef, v0 - big_w * sn_coef)
    return x_ss + xt, v_ss + vt
