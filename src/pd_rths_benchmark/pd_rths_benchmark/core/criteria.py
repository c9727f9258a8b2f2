"""The vRTHS benchmark's evaluation criteria J1–J9 and the measurement-noise floor.

As the benchmark's evaluation script defines them (``F4_evaluation.m`` of the benchmark's
MATLAB files, Silva et al. 2020), with x_d the desired (numerical) displacement of DOF 1, x_m
the measured one, x_i the numerical substructure's floor i and x_ref,i the reference
structure's (all sampled alike):

- J1: the time shift (ms) maximising the correlation coefficient (Pearson, MATLAB ``corr``)
  of ``x_m[j:]`` with ``x_d[:n−j]`` over lags ``j`` = 0…49 samples: ``j dt`` (the benchmark
  also rounds it to 0.1 ms; here it is not rounded);
- J2 = 100 std(x_m − x_d) / std(x_d) (the "normalised RMS" tracking error: the script uses
  ``std``, so a constant offset does not count);
- J3 = 100 max|x_m − x_d| / max|x_d| (peak tracking error);
- J4 = 100 std(x_m − x_ref,1) / std(x_ref,1), J5 = 100 max|x_m − x_ref,1| / max|x_ref,1|:
  floor 1 is the *measured* displacement x_m, as in the script;
- J6, J7 = 100 std(x_i − x_ref,i) / std(x_ref,i) for floors 2, 3 (numerical);
- J8, J9 = 100 max|x_i − x_ref,i| / max|x_ref,i| for floors 2, 3.

All J2–J9 are in %. The benchmark rounds each J to two decimals; these are not rounded.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pd_core.errors import ConfigError

__all__ = ['J_KEYS', 'MAX_LAG_SAMPLES', 'j_criteria', 'native_j_criteria', 'noise_floor_percent',
           'tracking_delay']

#: The keys of :func:`j_criteria`'s result, in order.
J_KEYS = ('J1', 'J2', 'J3', 'J4', 'J5', 'J6', 'J7', 'J8', 'J9')
#: J1 searches lags 0 … MAX_LAG_SAMPLES − 1.
MAX_LAG_SAMPLES = 50


def _vector(name: str, values: ArrayLike, n: int | None = None) -> NDArray[np.float64]:
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1 or array.size < 2 or (n is not None and array.size != n):
        expected = f' of length {n}' if n is not None else ''
        msg = f'j_criteria: {name} must be 1-D{expected} with 2 or more samples'
        raise ConfigError(msg)
    return array


def _nrms(error: NDArray[np.float64], reference: NDArray[np.float64]) -> float:
    """100 std(error) / std(reference).

    NaN for a reference at rest (a run that stopped before the motion: no criterion).
    """
    scale = float(np.std(reference, ddof=1))
    return float(100.0 * np.std(error, ddof=1) / scale) if scale > 0.0 else math.nan


def _peak(error: NDArray[np.float64], reference: NDArray[np.float64]) -> float:
    """100 max|error| / max|reference|; NaN for a reference at rest."""
    scale = float(np.max(np.abs(reference)))
    return float(100.0 * np.max(np.abs(error)) / scale) if scale > 0.0 else math.nan


def tracking_delay(x_d: ArrayLike, x_m: ArrayLike, dt: float,
                   max_lag: int = MAX_LAG_SAMPLES) -> float:
    """J1: the lag (s) in 0 … ``max_lag`` − 1 samples maximising corr(x_m[j:], x_d[:n−j]).

    Raises:
        ConfigError: On bad inputs.
    """
    desired = _vector('x_d', x_d)
    measured = _vector('x_m', x_m, desired.size)
    if not (math.isfinite(dt) and dt > 0.0):
        msg = f'j_criteria: dt must be positive and finite, got {dt!r}'
        raise ConfigError(msg)
    best_lag, best = 0, -math.inf
    n = desired.size
    for lag in range(min(max_lag, n - 1)):
        a = measured[lag:]
        b = desired[:n - lag]
        a = a - a.mean()
        b = b - b.mean()
        denominator = math.sqrt(float(a @ a) * float(b @ b))
        r = float(a @ b) / denominator if denominator > 0.0 else -math.inf
        if r > best:
            best_lag, best = lag, r
    return best_lag * dt


def j_criteria(x_d: ArrayLike, x_m: ArrayLike, floors: ArrayLike, reference: ArrayLike,
               dt: float) -> dict[str, float]:
    """J1 (ms) and J2–J9 (%) of one run (module docstring).

    Args:
        x_d: Desired displacement of DOF 1, m, ``(n,)``.
        x_m: Measured displacement of DOF 1, m, ``(n,)``.
        floors: The numerical substructure's floor displacements, ``(n, 3)`` (column 0 is x_d).
        reference: The reference structure's floor displacements, ``(n, 3)``.
        dt: Sample period, s.

    Returns:
        ``{'J1': ..., ..., 'J9': ...}``.

    Raises:
        ConfigError: On arrays of the wrong shapes or a bad ``dt``.
    """
    desired = _vector('x_d', x_d)
    n = desired.size
    measured = _vector('x_m', x_m, n)
    numerical = np.asarray(floors, dtype=np.float64)
    ref = np.asarray(reference, dtype=np.float64)
    for name, array in (('floors', numerical), ('reference', ref)):
        if array.ndim != 2 or array.shape[0] != n or array.shape[1] < 3:
            msg = f'j_criteria: {name} must be (n, 3) with n = {n}, got shape {array.shape}'
            raise ConfigError(msg)
    j = {'J1': 1000.0 * tracking_delay(desired, measured, dt)}
    j['J2'] = _nrms(measured - desired, desired)
    j['J3'] = _peak(measured - desired, desired)
    j['J4'] = _nrms(measured - ref[:, 0], ref[:, 0])
    j['J5'] = _peak(measured - ref[:, 0], ref[:, 0])
    j['J6'] = _nrms(numerical[:, 1] - ref[:, 1], ref[:, 1])
    j['J7'] = _nrms(numerical[:, 2] - ref[:, 2], ref[:, 2])
    j['J8'] = _peak(numerical[:, 1] - ref[:, 1], ref[:, 1])
    j['J9'] = _peak(numerical[:, 2] - ref[:, 2], ref[:, 2])
    return {key: j[key] for key in J_KEYS}


def native_j_criteria(x_d: ArrayLike, x_m: ArrayLike, reference_at_samples: ArrayLike,
                      floors: ArrayLike, reference_at_steps: ArrayLike,
                      dt: float) -> dict[str, float]:
    """J1–J9 of a run whose floors are known at the integration steps only (``--loop native``).

    J1–J5 at the controller samples (x_d, x_m against the reference's floor 1 at the same instants,
    ``(n, 3)``), J6–J9 at the integration steps (``floors`` against ``reference_at_steps``, both
    ``(m, 3)``).

    Raises:
        ConfigError: On arrays of the wrong shapes or a bad ``dt``.
    """
    x_d = _vector('x_d', x_d)
    x_m = _vector('x_m', x_m, x_d.size)
    reference_at_samples = np.asarray(reference_at_samples, dtype=np.float64)
    floors = np.asarray(floors, dtype=np.float64)
    reference_at_steps = np.asarray(reference_at_steps, dtype=np.float64)
    if reference_at_samples.shape[0] != x_m.size or floors.shape != reference_at_steps.shape:
        msg = ('native_j_criteria: the reference must have the shape of the samples '
               f'({reference_at_samples.shape} for {x_m.size}) and of the floors '
               f'({reference_at_steps.shape} for {floors.shape})')
        raise ConfigError(msg)
    ref1 = reference_at_samples[:, 0]
    j = {'J1': 1000.0 * tracking_delay(x_d, x_m, dt),
         'J2': _nrms(x_m - x_d, x_d), 'J3': _peak(x_m - x_d, x_d),
         'J4': _nrms(x_m - ref1, ref1), 'J5': _peak(x_m - ref1, ref1),
         'J6': _nrms(floors[:, 1] - reference_at_steps[:, 1], reference_at_steps[:, 1]),
         'J7': _nrms(floors[:, 2] - reference_at_steps[:, 2], reference_at_steps[:, 2]),
         'J8': _peak(floors[:, 1] - reference_at_steps[:, 1], reference_at_steps[:, 1]),
         'J9': _peak(floors[:, 2] - reference_at_steps[:, 2], reference_at_steps[:, 2])}
    return {key: j[key] for key in J_KEYS}


def noise_floor_percent(displacement_noise_std: float, x_d: ArrayLike) -> float:
    """100 σ_noise / std(x_d): the J2 (and about the J4) no controller can go below, %."""
    desired = _vector('x_d', x_d)
    if not (math.isfinite(displacement_noise_std) and displacement_noise_std >= 0.0):
        msg = ('noise_floor_percent: displacement_noise_std must be >= 0, got '
               f'{displacement_noise_std!r}')
        raise ConfigError(msg)
    return float(100.0 * displacement_noise_std / np.std(desired, ddof=1))
