"""Spectral stability and accuracy analysis of the integration schemes (thesis §3.3.1).

For a linear SDOF in free vibration (``m = 1``, ``c = 2ξω``, ``k = ω²``) every scheme is a
recursion ``x̂_{n+1} = A x̂_n`` (thesis eqs. 3.4–3.5) whose amplification matrix ``A`` depends
on ``Ω = ωΔt``, on the viscous damping ratio ``ξ`` and on the scheme's parameters only. Each
registered scheme provides it as the classmethod
``amplification_matrix(omega_dt, xi=0.0, **parameters)``; for Newmark explicit without that
classmethod :func:`~pd_integrator.core.stability.amplification_matrix_newmark_explicit` is used.

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

import csv
import inspect
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .errors import ConfigError
from .schemes import SCHEMES, Integrator
from .stability import amplification_matrix_newmark_explicit

__all__ = [
    'STABILITY_TOLERANCE',
    'SWEEP_COLUMNS',
    'SpectralProperties',
    'amplification_matrix',
    'default_parameters',
    'expected_period_error',
    'has_amplification_matrix',
    'omega_grid',
    'plot_figure_3_2',
    'plot_sweeps',
    'scheme_class',
    'spectral_properties',
    'sweep',
    'write_sweep_csv',
]

#: A spectral radius up to ``1 + STABILITY_TOLERANCE`` counts as stable. It absorbs the
#: ``O(√ε)`` error of computed eigenvalues at a double root on the unit circle (Newmark
#: explicit at ``Ω = 2``, which eq. 3.14 counts as stable).
STABILITY_TOLERANCE = 1e-6

#: Columns of a sweep written by :func:`write_sweep_csv` (more columns follow them).
SWEEP_COLUMNS = ('omega_dt', 'dt_over_T', 'spectral_radius', 'numerical_damping',
                 'period_error', 'period_shrinkage')

# A root with |Im λ| at most this (relative to max(1, ρ)) is real: rounding noise only.
_IMAG_TOLERANCE = 1e-12
# Two real roots this close (relative) are a double root at the bifurcation.
_COINCIDENT_TOLERANCE = 1e-6
# Arguments of amplification_matrix and of the constructors that are not scheme parameters.
_NOT_PARAMETERS = frozenset({'self', 'cls', 'omega_dt', 'xi', 'mass', 'damping', 'dt',
                             'initial_stiffness'})


# ----------------------------------------------------------------------------- schemes


def scheme_class(scheme: str | type[Integrator] | Integrator) -> type[Integrator]:
    """Resolve a scheme name, integrator class or instance to its class.

    Raises:
        ConfigError: On an unknown scheme name (the message lists the valid names).
    """
    if isinstance(scheme, Integrator):
        return type(scheme)
    if isinstance(scheme, type) and issubclass(scheme, Integrator):
        return scheme
    try:
        return SCHEMES[scheme]  # type: ignore[index]
    except (KeyError, TypeError):
        valid = ', '.join(sorted(SCHEMES))
        raise ConfigError(
            f'scheme: unknown integration scheme {scheme!r}; valid: {valid}'
        ) from None


def _matrix_function(cls: type[Integrator]) -> Callable[..., Any] | None:
    """The scheme's ``amplification_matrix`` (eq. 3.7 for Newmark explicit without one)."""
    method = getattr(cls, 'amplification_matrix', None)
    base = getattr(Integrator, 'amplification_matrix', None)
    inherited = method is not None and base is not None and (
        getattr(method, '__func__', method) is getattr(base, '__func__', base))
    if callable(method) and not inherited:
        return method
    if cls.name == 'newmark_explicit':
        return _newmark_explicit_matrix
    return method if callable(method) else None


def _newmark_explicit_matrix(omega_dt: float, xi: float = 0.0) -> np.ndarray:
    """Δt-normalised eq. 3.7, extended with viscous damping."""
    return amplification_matrix_newmark_explicit(omega_dt, xi=xi)


def has_amplification_matrix(scheme: str | type[Integrator] | Integrator) -> bool:
    """Whether the scheme's amplification matrix is available for the analysis.

    Raises:
        ConfigError: On an unknown scheme name.
    """
    function = _matrix_function(scheme_class(scheme))
    if function is None:
        return False
    try:
        function(0.1, xi=0.0)
    except NotImplementedError:
        return False
    except Exception:  # noqa: BLE001 - e.g. a required parameter: the matrix exists
        return True
    return True


def _signature(function: Callable[..., Any]) -> tuple[dict[str, Any], bool]:
    """Named scheme parameters with their defaults, and whether ``**kwargs`` is accepted."""
    try:
        signature = inspect.signature(function)
    except (TypeError, ValueError):
        return {}, True
    named = {name: p.default for name, p in signature.parameters.items()
             if name not in _NOT_PARAMETERS and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)}
    var_keyword = any(p.kind is p.VAR_KEYWORD for p in signature.parameters.values())
    return named, var_keyword


def default_parameters(scheme: str | type[Integrator] | Integrator) -> dict[str, Any]:
    """The scheme's parameters and their defaults, as the analysis can pass them.

    Read from the signature of ``amplification_matrix`` and, if that takes ``**parameters``,
    from the constructor's. A parameter without a default maps to ``inspect.Parameter.empty``.

    Raises:
        ConfigError: On an unknown scheme name.
    """
    cls = scheme_class(scheme)
    function = _matrix_function(cls)
    if function is None or function is _newmark_explicit_matrix:
        return {}
    named, var_keyword = _signature(function)
    if var_keyword:
        named = {**_signature(cls.__init__)[0], **named}
    return named


def _accepts(cls: type[Integrator], name: str) -> bool:
    """Whether ``name`` is a parameter of the scheme's amplification matrix."""
    function = _matrix_function(cls)
    if function is None or function is _newmark_explicit_matrix:
        return False
    named, var_keyword = _signature(function)
    if name in named:
        return True
    if not var_keyword:
        return False
    constructor = _signature(cls.__init__)[0]
    return name in constructor or not constructor  # no names to check against: let it try


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
    function = _matrix_function(cls)
    if function is None:
        raise ConfigError(f'scheme {cls.name!r}: no amplification_matrix, cannot be analysed')
    for name in parameters:
        if not _accepts(cls, name):
            known = ', '.join(sorted(default_parameters(cls))) or 'none'
            raise ConfigError(
                f'scheme {cls.name!r}: unknown parameter {name!r}; parameters: {known}'
            )
    try:
        matrix = function(omega, xi=damping, **parameters)
    except NotImplementedError:
        raise ConfigError(
            f'scheme {cls.name!r}: no amplification_matrix, cannot be analysed'
        ) from None
    except (TypeError, ConfigError) as err:  # e.g. a parameter out of its range
        raise ConfigError(f'scheme {cls.name!r}: {err}') from None
    array = np.asarray(matrix)
    if array.ndim != 2 or array.shape[0] != array.shape[1] or array.shape[0] == 0:
        raise ConfigError(
            f'scheme {cls.name!r}: amplification_matrix returned shape {array.shape}, '
            'expected a square matrix'
        )
    if not np.all(np.isfinite(array)):
        raise ConfigError(
            f'scheme {cls.name!r}: amplification_matrix is not finite at Ω = {omega:g}'
        )
    return array


def _check_omega(omega_dt: float) -> float:
    try:
        omega = float(omega_dt)
    except (TypeError, ValueError):
        raise ConfigError(f'omega_dt: expected a number, got {omega_dt!r}') from None
    if not (math.isfinite(omega) and omega >= 0.0):
        raise ConfigError(f'omega_dt: must be finite and ≥ 0, got {omega_dt!r}')
    return omega


def _check_xi(xi: float) -> float:
    try:
        value = float(xi)
    except (TypeError, ValueError):
        raise ConfigError(f'xi: expected a number, got {xi!r}') from None
    if not (0.0 <= value < 1.0):
        raise ConfigError(f'xi: viscous damping ratio must be in [0, 1), got {xi!r}')
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
    """Eigenvalues of ``A``, computed after an exact diagonal similarity that balances the
    principal eigenvector.

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
        raise ConfigError(f'omega_max: must be positive and finite, got {omega_max!r}')
    if int(points) != points or points < 2:
        raise ConfigError(f'points: must be an integer ≥ 2, got {points!r}')
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


def _format(value: Any) -> str:
    if isinstance(value, (bool, np.bool_)):
        return '1' if value else '0'
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return str(value)


def write_sweep_csv(
    sweeps: Mapping[str, np.ndarray] | Sequence[Mapping[str, np.ndarray]], path: str | Path,
    *, parameters: Sequence[Mapping[str, Any]] | None = None,
) -> Path:
    """Write one or more sweeps as one CSV table, one row per ``Ω``.

    The columns are the :data:`SWEEP_COLUMNS`, then ``algorithmic_damping``, ``stable``
    (0/1), ``xi`` and one column per scheme parameter; floats are written exactly (``repr``),
    NaN as ``nan``.

    Args:
        sweeps: A result of :func:`sweep`, or a sequence of them stacked in order.
        path: The CSV file.
        parameters: The scheme parameters of each sweep (same length as ``sweeps``).

    Returns:
        ``path``.
    """
    items = [sweeps] if isinstance(sweeps, Mapping) else list(sweeps)
    tags = [dict(p) for p in parameters] if parameters is not None else [{} for _ in items]
    if len(tags) != len(items):
        raise ValueError(f'parameters: {len(tags)} sets for {len(items)} sweeps')
    parameter_names: list[str] = []
    for tag in tags:
        parameter_names += [name for name in tag if name not in parameter_names]
    columns = [*SWEEP_COLUMNS, 'algorithmic_damping', 'stable', 'xi']
    n_columns = len(columns)
    names = [*columns, *parameter_names]
    path = Path(path)
    with path.open('w', newline='', encoding='utf-8') as stream:
        writer = csv.writer(stream)
        writer.writerow(names)
        for item, tag in zip(items, tags):
            n = len(item['omega_dt'])
            for i in range(n):
                row = [_format(item[name][i]) for name in names[:n_columns]]
                row += [_format(tag.get(name, '')) for name in parameter_names]
                writer.writerow(row)
    return path


def _pyplot() -> Any:
    import matplotlib as mpl  # noqa: PLC0415 - heavy; only needed for the figures

    mpl.use('Agg')
    import matplotlib.pyplot as plt  # noqa: PLC0415

    return plt


def _add_dt_over_t_axis(axes: Any) -> None:
    top = axes.secondary_xaxis('top', functions=(lambda o: o / (2.0 * math.pi),
                                                 lambda r: r * 2.0 * math.pi))
    top.set_xlabel('Δt/T')


_LINESTYLES = ('-', '--', ':', '-.')


def plot_sweeps(
    curves: Sequence[tuple[str, Mapping[str, np.ndarray]]], directory: str | Path,
    *, title: str = '',
) -> list[Path]:
    """Plot spectral radius, numerical damping ratio and period error against ``Ω``.

    Writes ``spectral_radius.png``, ``numerical_damping.png`` and ``period_error.png``: one
    colour per label (scheme and parameters), one line style per viscous damping ratio. The
    damping and period plots show the stable range only.

    Args:
        curves: ``(label, sweep)`` pairs; the same label with several ``ξ`` shares a colour.
        directory: Folder for the PNG files (must exist).
        title: Optional suffix of the figure titles.

    Returns:
        The written paths.
    """
    plt = _pyplot()
    from matplotlib.lines import Line2D  # noqa: PLC0415

    directory = Path(directory)
    labels = list(dict.fromkeys(label for label, _ in curves))
    xis = sorted({float(item['xi'][0]) for _, item in curves if len(item['xi'])})
    colours = plt.get_cmap('tab10' if len(labels) <= 10 else 'tab20')
    omega_max = max((float(np.max(item['omega_dt'])) for _, item in curves), default=1.0)
    specs = (
        ('spectral_radius.png', 'spectral_radius', 1.0, 'Spectral radius ρ',
         'Spectral radius'),
        ('numerical_damping.png', 'numerical_damping', 100.0,
         'Numerical damping ratio ξ̄ [%] (viscous + algorithmic)', 'Numerical damping ratio'),
        ('period_error.png', 'period_error', 100.0, 'Relative period error (T̄ − T)/T [%]',
         'Relative period error'),
    )
    written: list[Path] = []
    for filename, key, factor, ylabel, heading in specs:
        figure, axes = plt.subplots(figsize=(9, 5.5), layout='constrained')
        for label, item in curves:
            colour = colours(labels.index(label) % colours.N)
            xi = float(item['xi'][0])
            style = _LINESTYLES[xis.index(xi) % len(_LINESTYLES)]
            values = factor * np.asarray(item[key], dtype=float)
            if key != 'spectral_radius':
                values = np.where(item['stable'], values, np.nan)
            axes.plot(item['omega_dt'], values, color=colour, linestyle=style, linewidth=1.3)
        if key == 'spectral_radius':
            axes.axhline(1.0, color='k', linewidth=0.6)
            axes.set_ylim(0.0, 1.5)
        else:
            axes.axhline(0.0, color='k', linewidth=0.6)
            _robust_ylim(axes, [factor * np.where(item['stable'], item[key], np.nan)
                                for _, item in curves])
        axes.set_xlim(0.0, omega_max)
        axes.set_xlabel('Ω = ωΔt')
        axes.set_ylabel(ylabel)
        _add_dt_over_t_axis(axes)
        suffix = '' if key == 'spectral_radius' else ' (stable range)'
        axes.set_title(f'{heading}{suffix} — {title}' if title else f'{heading}{suffix}')
        axes.grid(visible=True, alpha=0.4)
        handles = [Line2D([], [], color=colours(i % colours.N), linewidth=1.5, label=label)
                   for i, label in enumerate(labels)]
        handles += [Line2D([], [], color='0.3', linestyle=_LINESTYLES[i % len(_LINESTYLES)],
                           label=f'ξ = {xi:g}') for i, xi in enumerate(xis)]
        axes.legend(handles=handles, fontsize='small', loc='best')
        path = directory / filename
        figure.savefig(path, dpi=110)
        plt.close(figure)
        written.append(path)
    return written


def _robust_ylim(axes: Any, series: list[np.ndarray]) -> None:
    finite = np.concatenate([np.asarray(s, dtype=float).reshape(-1) for s in series])
    finite = finite[np.isfinite(finite)]
    if finite.size == 0:
        return
    low = min(0.0, float(np.min(finite)))
    high = max(0.0, float(np.max(finite)))
    margin = 0.05 * (high - low) or 1.0
    axes.set_ylim(low - margin, high + margin)


def plot_figure_3_2(path: str | Path, *, dt_over_t_max: float = 0.3, points: int = 300) -> Path:
    """Thesis Figure 3.2: period shrinkage ``(T − T̄)/T`` of Newmark explicit vs ``Δt/T``.

    The line comes from the eigenvalues of the amplification matrix (this module); the
    markers are the closed form of eq. 3.19. The abscissa ends at ``dt_over_t_max`` or at the
    stability limit ``Δt/T = 1/π``, whichever is smaller.

    Args:
        path: The PNG file.
        dt_over_t_max: Largest ``Δt/T``.
        points: Number of points of the line.

    Returns:
        ``path``.
    """
    from .stability import newmark_explicit_numerical_frequency  # noqa: PLC0415

    plt = _pyplot()
    limit = scheme_class('newmark_explicit').stability_limit / (2.0 * math.pi)
    upper = min(float(dt_over_t_max), limit)
    ratios = upper * np.arange(1, points + 1) / points
    shrinkage = sweep('newmark_explicit', 2.0 * math.pi * ratios)['period_shrinkage']
    marks = ratios[points // 30 - 1::points // 30]
    closed = [1.0 - 2.0 * math.pi * r / newmark_explicit_numerical_frequency(2.0 * math.pi * r)
              for r in marks]
    figure, axes = plt.subplots(figsize=(7, 5), layout='constrained')
    axes.plot(np.concatenate(([0.0], ratios)), 100.0 * np.concatenate(([0.0], shrinkage)),
              color='tab:blue', linewidth=1.5, label='eigenvalues of A (eq. 3.7)')
    axes.plot(marks, 100.0 * np.asarray(closed), 'o', color='tab:red', markersize=4,
              markerfacecolor='none', label='closed form (eq. 3.19)')
    axes.axvline(0.05, color='0.4', linestyle='--', linewidth=0.8)
    axes.annotate('Δt/T = 0.05', (0.05, 0.9), xycoords=('data', 'axes fraction'),
                  xytext=(4, 0), textcoords='offset points', fontsize='small', color='0.3')
    axes.set_xlim(0.0, upper)
    axes.set_ylim(bottom=0.0)
    axes.set_xlabel('Δt/T')
    axes.set_ylabel('Period shrinkage (T − T̄)/T [%]')
    axes.set_title('Period shrinkage by the Newmark explicit method (thesis Figure 3.2)')
    axes.grid(visible=True, alpha=0.4)
    axes.legend()
    path = Path(path)
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path
