"""The vRTHS benchmark problem (Silva, Dyke et al. 2020): structure, partition, records, reference.

The reference structure is a three-storey frame with lumped floor masses. Case 1: 1000 kg per
floor, 5 % damping in every mode; Cases 2, 3, 4 keep the stiffness and take 1100 kg and 4 %,
1300 kg and 3 %, 1000 kg and 3 %. Classical damping: ``C = M Φ diag(2 ζ ω_i) Φᵀ M`` with the
mass-normalised modes ``Φ`` (the same ratio in every mode). The physical substructure is the
spring–mass–damper on floor 1 (:data:`pd_common.rths.BENCHMARK_SPECIMEN`); the numerical
substructure is the rest (``M − M_E``, ``C − C_E``, ``K − K_E``, ``E`` non-zero only at (1, 1)).

The reference response is the full structure (``M``, ``C``, ``K``, no partition) under
``−M ι ẍ_g``, integrated exactly for a ground motion linear between samples (first-order hold:
the matrix exponential of the augmented system), the way the benchmark's ``lsim`` of its
reference model treats a smooth input.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import linalg, signal

from pd_common.rths import PhysicalSpecimen
from pd_core.errors import ConfigError

__all__ = [
    'BENCHMARK_CASES',
    'BENCHMARK_STIFFNESS',
    'BenchmarkCase',
    'benchmark_case',
    'classical_damping',
    'numerical_substructure',
    'padding_needed',
    'prepare_ground_motion',
    'reference_response',
    'sampled_ground_motion',
    'state_matrix',
]

Matrix = NDArray[np.float64]

#: The benchmark's storey stiffness matrix, N/m (every case).
BENCHMARK_STIFFNESS = np.array([
    [26054883.879603837, -23133938.877108198, 5937035.463339146],
    [-23133938.877108198, 32560774.186380334, -14419970.777236981],
    [5937035.463339146, -14419970.777236985, 9267275.506224312],
])
#: Floor mass (kg) and modal damping ratio of each case.
BENCHMARK_CASES = {1: (1000.0, 0.05), 2: (1100.0, 0.04), 3: (1300.0, 0.03), 4: (1000.0, 0.03)}


@dataclass(frozen=True, eq=False)
class BenchmarkCase:
    """One case of the reference structure.

    Attributes:
        number: The case, 1–4.
        mass: M, 3×3, kg.
        stiffness: K, 3×3, N/m.
        damping: C, 3×3, N·s/m (classical, ``damping_ratio`` in every mode).
        damping_ratio: ζ of every mode.
    """

    number: int
    mass: Matrix
    stiffness: Matrix
    damping: Matrix
    damping_ratio: float

    def natural_frequencies(self) -> NDArray[np.float64]:
        """The undamped natural frequencies, Hz, ascending."""
        eigenvalues = linalg.eigh(self.stiffness, self.mass, eigvals_only=True)
        return np.asarray(np.sqrt(np.asarray(eigenvalues, dtype=np.float64)) / (2.0 * math.pi),
                          dtype=np.float64)


def classical_damping(mass: Matrix, stiffness: Matrix, ratio: float) -> Matrix:
    """``C = M Φ diag(2 ζ ω_i) Φᵀ M``.

    Damping ratio ``ratio`` in every mode (Φ mass-normalised, ``Φᵀ M Φ = I``).
    """
    eigenvalues, modes = linalg.eigh(stiffness, mass)
    omega = np.sqrt(eigenvalues)
    damping = mass @ modes @ np.diag(2.0 * ratio * omega) @ modes.T @ mass
    return np.asarray(0.5 * (damping + damping.T), dtype=np.float64)


def benchmark_case(number: int) -> BenchmarkCase:
    """Case ``number`` (1–4) of the benchmark's reference structure.

    Raises:
        ConfigError: On a case other than 1–4.
    """
    if isinstance(number, bool) or number not in BENCHMARK_CASES:
        msg = f'benchmark case must be 1, 2, 3 or 4, got {number!r}'
        raise ConfigError(msg)
    floor_mass, ratio = BENCHMARK_CASES[number]
    mass = np.eye(3) * floor_mass
    stiffness = BENCHMARK_STIFFNESS.copy()
    return BenchmarkCase(number=number, mass=mass, stiffness=stiffness,
                         damping=classical_damping(mass, stiffness, ratio),
                         damping_ratio=ratio)


def numerical_substructure(case: BenchmarkCase, specimen: PhysicalSpecimen
                           ) -> tuple[Matrix, Matrix, Matrix]:
    """``(M_N, C_N, K_N)``: the case without the physical specimen on DOF 1.

    A perturbed plant's specimen (drawn ``k_e``, and ``c_e`` from it) is removed as drawn, as
    the benchmark does, so that the hybrid system's total is the reference structure.
    """
    m_n = case.mass.copy()
    c_n = case.damping.copy()
    k_n = case.stiffness.copy()
    m_n[0, 0] -= specimen.mass
    c_n[0, 0] -= specimen.damping
    k_n[0, 0] -= specimen.stiffness
    return m_n, c_n, k_n


def padding_needed(acceleration: ArrayLike, samples: int) -> tuple[bool, bool]:
    """Whether the record still needs its zeros before and after: ``(before, after)``.

    The benchmark ships its records (``ElCentroAccelNoScaling.mat`` etc.) with the zeros
    already added (``F1_input_file.m``: "a zero vector of around 10 sec has been added to each
    earthquake"), and runs them as they are, up to the record's last time. An end that already
    holds ``samples`` zero samples (the benchmark's 5 s, in record samples) is left as it is;
    an end that does not gets all of them, as the benchmark added them. (A record such as the
    shipped El Centro, which starts and ends with one zero sample, gets both.)
    """
    record = np.asarray(acceleration, dtype=np.float64)
    if samples <= 0:
        return False, False
    nonzero = np.flatnonzero(record != 0.0)
    if nonzero.size == 0:
        return False, False
    leading = int(nonzero[0])
    trailing = record.size - 1 - int(nonzero[-1])
    return leading < samples, trailing < samples


def prepare_ground_motion(acceleration_m_s2: ArrayLike, dt_record: float,
                          intensity: float = 0.4, rate: float = 4096.0,
                          padding: float = 5.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The benchmark's input.

    The record × ``intensity`` with ``padding`` s of zeros before and after where it does not have
    them yet (:func:`padding_needed`, ``round(padding / dt_record)`` zero samples), resampled at
    ``rate`` Hz by linear interpolation (the zeros are samples: the record goes to zero over one
    record step at each padded end, as the zero-padded array does).

    The record's sample ``i`` is at ``before + i dt_record`` (``before`` = ``padding`` or 0);
    the output runs from 0 to ``before + after + (N − 1) dt_record`` (the last loop sample at or
    before it): a record that carries its zeros (the benchmark's own) runs from 0 to its last
    time, as the benchmark runs it.

    Returns:
        ``(t, ag)``: times (s) and ground acceleration (m/s²) at the loop rate.

    Raises:
        ConfigError: On a record that is not 1-D with 2 or more finite samples, or a bad
            ``dt_record``, ``intensity``, ``rate`` or ``padding``.
    """
    record = np.asarray(acceleration_m_s2, dtype=np.float64)
    if record.ndim != 1 or record.size < 2 or not np.all(np.isfinite(record)):
        msg = 'ground motion: acceleration must be 1-D with 2 or more finite samples'
        raise ConfigError(msg)
    for name, value in (('dt_record', dt_record), ('rate', rate)):
        if not (math.isfinite(value) and value > 0.0):
            msg = f'ground motion: {name} must be positive and finite, got {value!r}'
            raise ConfigError(msg)
    for name, value in (('intensity', intensity), ('padding', padding)):
        if not (math.isfinite(value) and value >= 0.0):
            msg = f'ground motion: {name} must be >= 0 and finite, got {value!r}'
            raise ConfigError(msg)
    pad_before, pad_after = padding_needed(record, round(padding / dt_record))
    before = padding if pad_before else 0.0
    after = padding if pad_after else 0.0
    duration = before + after + (record.size - 1) * dt_record
    n = math.floor(duration * rate + 1e-9) + 1
    t = np.arange(n, dtype=np.float64) / rate
    # The zeros are samples of the record (one record step from the first and last sample to
    # zero, as a zero-padded array is interpolated), not a jump at the record's ends.
    record_t = before + np.arange(-1, record.size + 1, dtype=np.float64) * dt_record
    ag = intensity * np.interp(t, record_t, np.concatenate([[0.0], record, [0.0]]),
                               left=0.0, right=0.0)
    return t, ag


def sampled_ground_motion(t: ArrayLike, ag: ArrayLike, where: str
                          ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """``(t, ag, h)`` as float arrays with the first sample period ``h``.

    Raises:
        ConfigError: Unless both are 1-D of the same length, 2 or more (``where`` names the
            caller).
    """
    times = np.asarray(t, dtype=np.float64)
    ground = np.asarray(ag, dtype=np.float64)
    if times.ndim != 1 or ground.shape != times.shape or times.size < 2:
        msg = f'{where}: t and ag must be 1-D of the same length (2 or more)'
        raise ConfigError(msg)
    return times, ground, float(times[1] - times[0])


def state_matrix(mass: Matrix, damping: Matrix, stiffness: Matrix) -> Matrix:
    """``A`` of ``ż = A z + …`` for the state ``z = [x; ẋ]`` of ``M ẍ + C ẋ + K x = …``."""
    n = mass.shape[0]
    m_inv = np.linalg.inv(mass)
    a: Matrix = np.block([[np.zeros((n, n)), np.eye(n)], [-m_inv @ stiffness, -m_inv @ damping]])
    return a


def _foh_matrices(a: Matrix, b: Matrix, h: float) -> tuple[Matrix, Matrix, Matrix]:
    """``(Φ, Γ0, Γ1)`` of ``ż = A z + B w`` over one step with a first-order hold.

    ``(Φ, Γ0, Γ1)`` of ``ż = A z + B w`` over one step ``h`` with ``w`` linear between the
    samples: ``z[k+1] = Φ z[k] + Γ0 w[k] + Γ1 w[k+1]`` (exact).
    """
    n, m = b.shape
    augmented = np.zeros((n + 2 * m, n + 2 * m))
    augmented[:n, :n] = a * h
    augmented[:n, n:n + m] = b * h
    augmented[n:n + m, n + m:] = np.eye(m)
    exponential = linalg.expm(augmented)
    phi = exponential[:n, :n]
    gamma_hold = exponential[:n, n:n + m]       # ∫ e^{Aτ} B dτ
    gamma_ramp = exponential[:n, n + m:]        # ∫ e^{Aτ} B (h − τ)/h dτ
    return phi, gamma_hold - gamma_ramp, gamma_ramp


def reference_response(case: BenchmarkCase, t: ArrayLike, ag: ArrayLike) -> NDArray[np.float64]:
    """The floors' displacements (relative to the ground) of the full structure, ``(n, 3)``.

    ``M ẍ + C ẋ + K x = −M ι ẍ_g`` from rest, ``ẍ_g`` linear between the uniformly spaced
    samples ``t``; exact discretisation (matrix exponential) of the state ``[x; ẋ]``.

    Raises:
        ConfigError: On ``t`` not uniform or ``ag`` of another length.
    """
    times, ground, h = sampled_ground_motion(t, ag, 'reference response')
    if not h > 0.0 or np.max(np.abs(np.diff(times) - h)) > 1e-9 * max(1.0, abs(times[-1])):
        msg = 'reference response: t must be uniformly spaced and increasing'
        raise ConfigError(msg)
    n_dof = case.mass.shape[0]
    a = state_matrix(case.mass, case.damping, case.stiffness)
    b = np.concatenate([np.zeros(n_dof), -np.ones(n_dof)])[:, None]   # −M⁻¹ M ι
    phi, gamma0, gamma1 = _foh_matrices(a, b, h)
    # The sampled solution in closed form: z[k] = Σ_j Φ^{k−1−j} (Γ0 w[j] + Γ1 w[j+1]).
    # Evaluated in the modal coordinates of Φ (diagonalisable: distinct damped modes), each
    # a first-order complex recursion run by scipy's lfilter.
    eigenvalues, vectors = np.linalg.eig(phi)
    forcing = np.outer(ground[:-1], gamma0[:, 0]) + np.outer(ground[1:], gamma1[:, 0])
    modal_forcing = np.linalg.solve(vectors, forcing.T.astype(np.complex128))
    modal = np.zeros((2 * n_dof, times.size), dtype=np.complex128)
    for i, lam in enumerate(eigenvalues):
        modal[i, 1:] = signal.lfilter([1.0], [1.0, -lam], modal_forcing[i])
    state = np.real(vectors @ modal)
    return np.ascontiguousarray(state[:n_dof].T)
