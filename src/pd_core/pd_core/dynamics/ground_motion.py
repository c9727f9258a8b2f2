"""Ground-motion records: a uniformly sampled acceleration history and its transforms.

A :class:`GroundMotion` is a uniformly sampled base acceleration history in m/s², validated on
construction, with scaling, resampling onto another time step and padding with zeros. The file
readers that build one are in :mod:`.record_readers`.

Records in g are converted with ``g = 9.81`` m/s² (:data:`G_THESIS`) by default, the value
hard-coded in the thesis's MATLAB code, so that results can be compared with it; pass
``g=G_STANDARD`` to a reader for the standard gravity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import GroundMotionError

__all__ = [
    'G_STANDARD',
    'G_THESIS',
    'GroundMotion',
    'dt_close',
]

G_STANDARD = 9.80665
"""Standard gravity in m/s² (the thesis's MATLAB code uses 9.81, the readers' default)."""

G_THESIS = 9.81
"""Gravity in m/s² used by the thesis's MATLAB code; the default of every reader."""


# Relative tolerance for deciding that two time steps are equal or integer multiples.
_DT_RTOL = 1e-9
# Absolute slack when counting samples: n = floor(duration / dt + _COUNT_EPS) + 1.
_COUNT_EPS = 1e-9


@dataclass(frozen=True, eq=False, repr=False)
class GroundMotion:
    """A uniformly sampled ground acceleration history.

    Attributes:
        dt: Time step in s (positive, finite).
        acceleration: Ground acceleration in m/s², sample ``i`` at ``t = i * dt``; stored as a
            read-only 1-D float64 copy of what was passed.
        source: Where the record came from: the file name, or ``'inline'``.

    Raises:
        GroundMotionError: If ``dt`` is not positive and finite, the acceleration is not 1-D,
            has fewer than 2 samples or holds a non-finite value.
    """

    dt: float
    acceleration: np.ndarray
    source: str = field(default='inline')

    def __post_init__(self) -> None:
        """Validate the fields and freeze a float64 copy of the acceleration."""
        source = str(self.source)
        object.__setattr__(self, 'source', source)
        try:
            dt = float(self.dt)
        except (TypeError, ValueError):
            msg = f"ground motion '{source}': time step dt must be a number, got {self.dt!r}"
            raise GroundMotionError(msg) from None
        if not (math.isfinite(dt) and dt > 0.0):
            msg = f"ground motion '{source}': time step dt must be positive and finite, got {dt!r}"
            raise GroundMotionError(msg)
        object.__setattr__(self, 'dt', dt)

        if np.iscomplexobj(self.acceleration):
            msg = f"ground motion '{source}': acceleration must be real"
            raise GroundMotionError(msg)
        try:
            acc = np.array(self.acceleration, dtype=np.float64, copy=True)
        except (TypeError, ValueError) as exc:
            msg = f"ground motion '{source}': acceleration is not numeric ({exc})"
            raise GroundMotionError(msg) from None
        if acc.ndim != 1:
            msg = f"ground motion '{source}': acceleration must be 1-D, got shape {acc.shape}"
            raise GroundMotionError(msg)
        if acc.size < 2:
            msg = f"ground motion '{source}': need at least 2 samples, got {acc.size}"
            raise GroundMotionError(msg)
        bad = np.flatnonzero(~np.isfinite(acc))
        if bad.size:
            index = int(bad[0])
            msg = (
                f"ground motion '{source}': non-finite acceleration {acc[index]!r} "
                f'at index {index}'
            )
            raise GroundMotionError(msg)
        acc.setflags(write=False)
        object.__setattr__(self, 'acceleration', acc)

    # ------------------------------------------------------------------ properties

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return int(self.acceleration.size)

    @property
    def duration(self) -> float:
        """Duration in s, ``(n_samples - 1) * dt``."""
        return (self.n_samples - 1) * self.dt

    @property
    def time(self) -> np.ndarray:
        """Sample times in s, ``[0, dt, 2 dt, ...]`` (a new array on each call)."""
        return np.arange(self.n_samples, dtype=np.float64) * self.dt

    @property
    def pga(self) -> float:
        """Peak ground acceleration, ``max |a|``, in m/s²."""
        return float(np.max(np.abs(self.acceleration)))

    # ------------------------------------------------------------------ dunder

    def __eq__(self, other: object) -> bool:
        """Records are equal when dt, source and every sample are exactly equal."""
        if not isinstance(other, GroundMotion):
            return NotImplemented
        return (
            self.dt == other.dt
            and self.source == other.source
            and np.array_equal(self.acceleration, other.acceleration)
        )

    # Unhashable (equality compares the samples). typeshed declares object.__hash__ as a method
    # only, though the data model allows None: hence the ignore.
    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        """Short summary without the samples."""
        return (
            f'GroundMotion(source={self.source!r}, dt={self.dt!r}, n_samples={self.n_samples}, '
            f'duration={self.duration:.6g} s, pga={self.pga:.6g} m/s2)'
        )

    # ------------------------------------------------------------------ transforms

    def scaled(self, factor: float) -> GroundMotion:
        """Return the record with every sample multiplied by ``factor``.

        Args:
            factor: Finite scale factor (may be negative to flip the direction).

        Returns:
            A new record with the same dt and source.

        Raises:
            GroundMotionError: If ``factor`` is not finite, or takes the peak beyond the
                largest float (one line, no numpy warning).
        """
        factor = float(factor)
        if not math.isfinite(factor):
            msg = f"ground motion '{self.source}': scale factor must be finite, got {factor!r}"
            raise GroundMotionError(msg)
        if not math.isfinite(factor * self.pga):
            msg = (f"ground motion '{self.source}': scale factor {factor:g} × the peak "
                   f'{self.pga:.4g} m/s2 is beyond the largest number')
            raise GroundMotionError(msg)
        return GroundMotion(self.dt, self.acceleration * factor, self.source)

    def resampled(self, dt: float) -> GroundMotion:
        """Return the record linearly interpolated onto ``t = 0, dt, 2 dt, ...``.

        The new record has ``floor(duration / dt + 1e-9) + 1`` samples, so it never extends
        past the original duration. Special cases, exact rather than merely close:

        - ``dt`` equal to the record's dt (within 1e-9 relative): an identical copy.
        - The record's dt an integer multiple ``k`` of ``dt`` (e.g. 0.02 s -> 0.01 s): the
          original samples are kept at every ``k``-th index and the points in between are
          interpolated; a midpoint is ``(a_i + a_{i+1}) * 0.5``, exactly what the thesis's
          MATLAB code (Appendix A, lines 48–56) computes when halving the time step.
        - ``dt`` an integer multiple of the record's dt: every ``k``-th sample (no anti-alias
          filtering is applied when coarsening).

        Args:
            dt: New time step in s.

        Returns:
            The resampled record (same source).

        Raises:
            GroundMotionError: If ``dt`` is not positive and finite, or so long that fewer than
                2 samples would remain.
        """
        dt = float(dt)
        if not (math.isfinite(dt) and dt > 0.0):
            msg = (
                f"ground motion '{self.source}': resampling dt must be positive and finite, "
                f'got {dt!r}'
            )
            raise GroundMotionError(msg)
        acc = self.acceleration
        if dt_close(dt, self.dt):
            return GroundMotion(self.dt, acc.copy(), self.source)

        n_new = math.floor(self.duration / dt + _COUNT_EPS) + 1
        if n_new < 2:
            msg = (
                f"ground motion '{self.source}': resampling dt={dt!r} s is longer than the "
                f'record duration {self.duration!r} s'
            )
            raise GroundMotionError(msg)

        finer = self.dt / dt
        k = round(finer)
        if k >= 2 and dt_close(finer, k):
            out = np.empty((self.n_samples - 1) * k + 1, dtype=np.float64)
            out[::k] = acc
            left, right = acc[:-1], acc[1:]
            for j in range(1, k):
                if 2 * j == k:
                    out[j::k] = (left + right) * 0.5
                else:
                    out[j::k] = left * ((k - j) / k) + right * (j / k)
            return GroundMotion(dt, out[:n_new], self.source)

        coarser = dt / self.dt
        m = round(coarser)
        if m >= 2 and dt_close(coarser, m):
            return GroundMotion(dt, acc[::m][:n_new].copy(), self.source)

        t_old = self.time
        t_new = np.arange(n_new, dtype=np.float64) * dt
        return GroundMotion(dt, np.interp(t_new, t_old, acc), self.source)

    def padded(self, duration: float) -> GroundMotion:
        """Return the record followed by zeros up to a total ``duration`` (free vibration).

        The result has ``floor(duration / dt + 1e-9) + 1`` samples; the original samples are
        unchanged.

        Args:
            duration: Total duration in s; at least the record's duration.

        Returns:
            The padded record (same dt and source); a copy if no sample needs adding.

        Raises:
            GroundMotionError: If ``duration`` is not finite or shorter than the record.
        """
        duration = float(duration)
        if not math.isfinite(duration):
            msg = (
                f"ground motion '{self.source}': padded duration must be finite, "
                f'got {duration!r}'
            )
            raise GroundMotionError(msg)
        n_total = math.floor(duration / self.dt + _COUNT_EPS) + 1
        if n_total < self.n_samples:
            msg = (
                f"ground motion '{self.source}': cannot pad to {duration!r} s, the record is "
                f'already {self.duration!r} s long'
            )
            raise GroundMotionError(msg)
        out = np.zeros(n_total, dtype=np.float64)
        out[: self.n_samples] = self.acceleration
        return GroundMotion(self.dt, out, self.source)


def dt_close(a: float, b: float) -> bool:
    """Whether two positive numbers agree within the relative dt tolerance (1e-9).

    Args:
        a: A time step (or a ratio of time steps).
        b: The other.

    Returns:
        ``|a − b| ≤ 1e-9 · max(|a|, |b|)``.
    """
    return abs(a - b) <= _DT_RTOL * max(abs(a), abs(b))
