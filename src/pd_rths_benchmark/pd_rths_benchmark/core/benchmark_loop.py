"""The vRTHS benchmark's own loop (``--loop benchmark``), as its Simulink model runs it.

One sample ``k`` of period ``h`` (1/4096 s), in this order (the model's block diagram:
numerical substructure → controller → plant → sensors → feedback force → unit delay):

1. ``x_d[k] = x_1(t_k)``: the numerical substructure's displacement of DOF 1 (its state at
   ``t_k``; the three floors are recorded);
2. ``y[k]`` = the plant's displacement at ``t_k``; ``x_m[k] = y[k] + n_x[k]`` (the LVDT's
   noise); the controller receives ``quantise(x_m[k])`` (A/D) — the recorded x_m, which the
   J's use, is not quantised, as in the benchmark;
3. ``u[k] = quantise(compensator.command(x_d[k], quantise(x_m[k])))`` (D/A), held over
   ``[t_k, t_{k+1}]`` by the plant;
4. ``F_m[k] = k_e y[k] + c_e (y[k] − y[k−1])/h + m_e (y[k] − 2y[k−1] + y[k−2])/h² + n_f[k]``
   (the model's two Derivative blocks are these backward differences; y before the start is
   0), the load cell's force with its noise;
5. the plant advances with ``u[k]``;
6. the numerical substructure ``M_N ẍ + C_N ẋ + K_N x = −M ι ẍ_g − [F; 0; 0]`` advances
   from ``t_k`` to ``t_{k+1}`` by one classical RK4 step (Simulink's ode4 at the fixed step
   h) with ``F = F_m[k−1]``: the force goes through a unit delay, whose output is held
   over the step (``F_m[−1] = 0``); ``ẍ_g`` is linear between the loop's samples (RK4's
   midpoint stages take the mean of ``ẍ_g[k]`` and ``ẍ_g[k+1]``; the benchmark's From File
   block interpolates the 50 Hz record itself, which differs only within the loop sample
   around each record sample).

The numerical substructure is linear: one RK4 step is exactly the linear map
``z ← A_rk z + P ẍ_g[k] + Q ẍ_g[k+1] + R F`` (the RK4 stages applied to unit vectors), run as
plain float arithmetic.

The noise: ``rng = noise.generator()``; first ``n`` standard normal draws times σ_x for the
displacement, then ``n`` times σ_f for the force (σ = √(power/h), Simulink's band-limited white
noise). MATLAB's generator cannot be reproduced: the J-values agree with the benchmark's
statistically, not to the digit.

The capacity: the actuator force of :class:`~pd_common.rths.plant.BenchmarkPlant` (its
``actuator_force()``, the signal the benchmark's ±8,900 N saturation sits on) is recorded;
another transfer system without one (e.g. the ideal plant) is judged on the specimen force
``k_e y + c_e ẏ + m_e ÿ`` of its displacement (backward differences, no noise). A run whose
peak reaches the capacity (or whose force is not finite: it diverged) is flagged
(``capacity_reached``); the force is not clipped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pd_common.rths import Compensator, PhysicalSpecimen, SensorNoise, TransferSystem, quantise
from pd_common.rths.plant import BenchmarkPlant
from pd_core.errors import ConfigError

from .problem import (
    BenchmarkCase,
    numerical_substructure,
    sampled_ground_motion,
    state_matrix,
)

__all__ = ['BenchmarkLoopResult', 'rk4_linear_map', 'run_benchmark_loop',
           'substructure_state_space']


@dataclass(frozen=True, eq=False)
class BenchmarkLoopResult:
    """The histories of one run of the benchmark's loop (``n`` samples each).

    Attributes:
        t: Times, s.
        x_d: Desired displacement of DOF 1, m.
        x_m: Measured displacement (plant + LVDT noise, not quantised), m.
        u: Command sent to the plant (quantised), m.
        force: Measured force fed back (with the load cell's noise), N.
        actuator_force: The actuator's force (the capacity's signal), N.
        floors: The numerical substructure's floor displacements, ``(n, 3)``, m.
        capacity_reached: Whether ``peak_force`` reached the capacity.
        peak_force: max |actuator_force|, N.
    """

    t: NDArray[np.float64]
    x_d: NDArray[np.float64]
    x_m: NDArray[np.float64]
    u: NDArray[np.float64]
    force: NDArray[np.float64]
    actuator_force: NDArray[np.float64]
    floors: NDArray[np.float64]
    capacity_reached: bool
    peak_force: float


def substructure_state_space(case: BenchmarkCase, specimen: PhysicalSpecimen
                             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(A, B)`` of the numerical substructure, state ``[x; ẋ]``, input ``[ẍ_g; F]``.

    ``ẍ = −M_N⁻¹ (K_N x + C_N ẋ) − M_N⁻¹ M ι ẍ_g − M_N⁻¹ e_1 F``.
    """
    m_n, c_n, k_n = numerical_substructure(case, specimen)
    n = m_n.shape[0]
    m_n_inv = np.linalg.inv(m_n)
    a = state_matrix(m_n, c_n, k_n)
    b = np.zeros((2 * n, 2))
    b[n:, 0] = -(m_n_inv @ case.mass @ np.ones(n))
    b[n:, 1] = -m_n_inv[:, 0]
    return a, b


def rk4_linear_map(a: NDArray[np.float64], b: NDArray[np.float64], h: float
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                              NDArray[np.float64]]:
    """One classical RK4 step of ``ż = A z + b_g g(t) + b_f F`` as ``(A_rk, P, Q, R)``.

    ``z⁺ = A_rk z + P g₀ + Q g₁ + R F``, with ``g`` at the stages ``g₀``, ``(g₀ + g₁)/2``, ``(g₀ +
    g₁)/2``, ``g₁`` and ``F`` constant. Exact (the step is linear in its inputs).
    """
    n = a.shape[0]

    def step(z: NDArray[np.float64], g0: float, g1: float, force: float
             ) -> NDArray[np.float64]:
        gm = 0.5 * (g0 + g1)

        def f(x: NDArray[np.float64], g: float) -> NDArray[np.float64]:
            return np.asarray(a @ x + b[:, 0] * g + b[:, 1] * force)

        k1 = f(z, g0)
        k2 = f(z + 0.5 * h * k1, gm)
        k3 = f(z + 0.5 * h * k2, gm)
        k4 = f(z + h * k3, g1)
        return np.asarray(z + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4))

    zero = np.zeros(n)
    a_rk = np.column_stack([step(np.eye(n)[:, i], 0.0, 0.0, 0.0) for i in range(n)])
    return (a_rk, step(zero, 1.0, 0.0, 0.0), step(zero, 0.0, 1.0, 0.0),
            step(zero, 0.0, 0.0, 1.0))


def run_benchmark_loop(case: BenchmarkCase, t: ArrayLike, ag: ArrayLike,
                       compensator: Compensator, plant: TransferSystem,
                       specimen: PhysicalSpecimen, noise: SensorNoise | None = None,
                       quantum: float = 0.0, capacity: float = math.inf, *,
                       perfect_actuator: bool = False) -> BenchmarkLoopResult:
    """Run the benchmark's own loop (module docstring) over the samples ``t``.

    Args:
        case: The reference structure's case.
        t: The loop's sample times, s (uniform; the step is ``t[1] − t[0]``).
        ag: Ground acceleration at ``t``, m/s².
        compensator: The controller (reset here), at the loop's step.
        plant: The transfer system (reset here), at the loop's step.
        specimen: The physical substructure (removed from the case; its force is measured).
        noise: Sensor noise, or None for none.
        quantum: The converters' quantisation step, m (0: none).
        capacity: The actuator's force capacity, N.
        perfect_actuator: A perfect actuator without delay: ``y[k] = quantise(x_d[k])`` and
            ``u[k] = y[k]`` (the compensator and the plant are not used; the force is the
            specimen force of y). What is left is the loop's own error: the force's unit delay
            and backward differences.

    Raises:
        ConfigError: On inconsistent inputs (lengths, step, rates of plant and compensator).
    """
    times, ground, h = sampled_ground_motion(t, ag, 'benchmark loop')
    for name, dt in (('plant', plant.dt), ('compensator', compensator.dt)):
        if not math.isclose(dt, h, rel_tol=1e-9):
            msg = f'benchmark loop: the {name} runs at dt={dt!r}, the loop at {h!r}'
            raise ConfigError(msg)
    if not (math.isfinite(quantum) and quantum >= 0.0):
        msg = f'benchmark loop: quantum must be >= 0, got {quantum!r}'
        raise ConfigError(msg)
    n = times.size
    a, b = substructure_state_space(case, specimen)
    a_rk, p, q, r = rk4_linear_map(a, b, h)
    rows = tuple((*(float(v) for v in a_rk[i]), float(p[i]), float(q[i]), float(r[i]))
                 for i in range(a_rk.shape[0]))
    if noise is None:
        noise_x = np.zeros(n)
        noise_f = np.zeros(n)
    else:
        rng = noise.generator()
        noise_x = rng.standard_normal(n) * noise.displacement_std(h)
        noise_f = rng.standard_normal(n) * noise.force_std(h)
    k_e, c_e, m_e = specimen.stiffness, specimen.damping, specimen.mass
    c_h, m_h2 = c_e / h, m_e / (h * h)
    plant_force = plant.actuator_force if isinstance(plant, BenchmarkPlant) else None

    compensator.reset()
    plant.reset()
    y: float
    x_d = np.empty(n)
    x_m = np.empty(n)
    u_out = np.empty(n)
    force_out = np.empty(n)
    actuator = np.empty(n)
    floors = np.empty((n, 3))
    g = ground.tolist()
    g.append(g[-1])
    nx = noise_x.tolist()
    nf = noise_f.tolist()
    z0 = z1 = z2 = z3 = z4 = z5 = 0.0
    y1 = y2 = 0.0            # y[k−1], y[k−2]
    force_prev = 0.0         # F_m[k−1] (the unit delay's output)
    r0, r1, r2, r3, r4, r5 = rows
    command = compensator.command
    for k in range(n):
        floors[k, 0] = z0
        floors[k, 1] = z1
        floors[k, 2] = z2
        if perfect_actuator:
            u = y = quantise(z0, quantum)
            measured = y + nx[k]
        else:
            y = plant.output()
            measured = y + nx[k]
            u = quantise(command(z0, quantise(measured, quantum)), quantum)
        specimen_force = k_e * y + c_h * (y - y1) + m_h2 * (y - 2.0 * y1 + y2)
        force = specimen_force + nf[k]
        actuator[k] = (specimen_force if plant_force is None or perfect_actuator
                       else plant_force())
        x_m[k] = measured
        u_out[k] = u
        force_out[k] = force
        if not perfect_actuator:
            plant.advance(u)
        g0 = g[k]
        g1 = g[k + 1]
        fd = force_prev
        z0, z1, z2, z3, z4, z5 = (
            r0[0] * z0 + r0[1] * z1 + r0[2] * z2 + r0[3] * z3 + r0[4] * z4 + r0[5] * z5
            + r0[6] * g0 + r0[7] * g1 + r0[8] * fd,
            r1[0] * z0 + r1[1] * z1 + r1[2] * z2 + r1[3] * z3 + r1[4] * z4 + r1[5] * z5
            + r1[6] * g0 + r1[7] * g1 + r1[8] * fd,
            r2[0] * z0 + r2[1] * z1 + r2[2] * z2 + r2[3] * z3 + r2[4] * z4 + r2[5] * z5
            + r2[6] * g0 + r2[7] * g1 + r2[8] * fd,
            r3[0] * z0 + r3[1] * z1 + r3[2] * z2 + r3[3] * z3 + r3[4] * z4 + r3[5] * z5
            + r3[6] * g0 + r3[7] * g1 + r3[8] * fd,
            r4[0] * z0 + r4[1] * z1 + r4[2] * z2 + r4[3] * z3 + r4[4] * z4 + r4[5] * z5
            + r4[6] * g0 + r4[7] * g1 + r4[8] * fd,
            r5[0] * z0 + r5[1] * z1 + r5[2] * z2 + r5[3] * z3 + r5[4] * z4 + r5[5] * z5
            + r5[6] * g0 + r5[7] * g1 + r5[8] * fd,
        )
        force_prev = force
        y2 = y1
        y1 = y
    x_d[:] = floors[:, 0]
    with np.errstate(invalid='ignore'):
        peak = float(np.max(np.abs(actuator)))
    # A diverged run (a non-finite force) went through the capacity on its way.
    return BenchmarkLoopResult(t=times.copy(), x_d=x_d, x_m=x_m, u=u_out, force=force_out,
                               actuator_force=actuator, floors=floors,
                               capacity_reached=not peak < capacity, peak_force=peak)
