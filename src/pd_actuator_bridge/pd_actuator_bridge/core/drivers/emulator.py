"""A servo-hydraulic actuator emulator: one closed-loop actuator per DOF driving a specimen model.

The emulator stands in for a real MOOG/MTS controller, servo-valve and actuator so that the bridge
and the pseudo-dynamic protocol can be exercised, with realistic control errors, without hardware.
It runs at a controller rate (default 1 kHz, never below 1 kHz) and is driven one controller
period at a time by :meth:`ServoHydraulicEmulator.tick`.

Plant (per DOF; Merritt, *Hydraulic Control Systems*, Wiley 1967, ch. 5-6: valve-controlled
piston; Dyke, Spencer, Quast and Sain, "Role of control-structure interaction in protective system
design", J. Eng. Mech. 121(2), 1995, for the actuator-structure coupling)::

    valve spool (first-order lag)   tau_v * d(s)/dt = o - s              o = u / u_max, |o| <= 1
    load flow (linearised)          q = Q * s                           Q: rated valve flow, m3/s
    chamber compressibility         (V / 4 beta) dp/dt = q - A v - K_ce p      F_a = A p
    piston                          m_p dv/dt = F_a - r(x) - c_p v - F_fr     dx/dt = v

``s`` is the spool opening (-1..1), ``p`` the load (differential) pressure, ``F_a = A p`` the
hydraulic force, ``r(x)`` the specimen's restoring force, ``F_fr`` the friction of the actuator's
connections and ``c_p`` the viscous damping of the piston seals. With the hydraulic (oil-column)
stiffness ``k_h = 4 beta A^2 / V`` the force equation reads
``dF_a/dt = (k_h / A) (Q s - K_ce F_a / A) - k_h v``: the ``- k_h v`` term is the "natural velocity
feedback" through which the specimen's motion, and hence its stiffness, feeds back into the
actuator dynamics (Dyke et al. 1995). Optionally, with a ``supply_pressure`` ``P_s``, the flow
follows the orifice law ``q = Q s sqrt(1 - sign(s) p / P_s)`` (Merritt ch. 5, rated at
``P_s``; the flow reverses if ``|p|`` exceeds ``P_s``), which limits the force the actuator can
develop to ``A P_s``.

Friction of the connections (swivels, guides, sliding supports; thesis section 3.4.3 "friction in
the actuator connections") is Coulomb plus viscous: ``F_fr = F_dahl + c_f v``. The Coulomb part
follows Dahl's model (Dahl, "A solid friction model", Aerospace Corp. TOR-0158(3107-18)-1, 1968),
``dF/dx = sigma_0 (1 - sign(v) F / F_c)``, integrated exactly in the displacement increment
(``F <- s F_c + (F - s F_c) exp(-sigma_0 |dx| / F_c)``): it reaches ``+-F_c`` when sliding and
keeps its value when the piston stops, so a held actuator retains a static friction force. The
friction acts in parallel with the specimen downstream of the load cell, so the load cell reads
``r(x) + F_fr``: this is a force-measurement error, :attr:`Measurement.true_force` is ``r(x)``.

Controller (per DOF, at the controller rate ``T = 1 / rate``; the sampled displacement is the
measured one, with its noise and quantisation)::

    e_k = c_{k-d} - y_k                                  (command delayed by d = delay_ticks ticks)
    I_k = I_{k-1} + k_i T e_k                            (conditional integration: frozen while
                                                          |e_k| > integral_band, or saturated
                                                          in the direction of e_k)
    D_k = (tau_d D_{k-1} - k_d (y_k - y_{k-1})) / (tau_d + T)   (filtered, on the measurement)
    u_k = clip(k_p e_k + I_k + D_k + k_ff (c_{k-d} - c_{k-d-1}) / T, -u_max, u_max)

with ``k_ff = velocity_feedforward * u_max A / Q`` (1.0 is the ideal velocity feed-forward). The
valve command is held over the period (zero-order hold, as a DAC does).

Integration: each period is split into ``substeps`` sub-steps ``h``. The linear part (valve,
compressibility, piston, viscous terms and the specimen's *initial* stiffness matrix ``K_0``) is
discretised exactly with the matrix exponential (zero-order hold on its inputs), so it is stable
for any realistic parameters. The remainder ``r(x) - K_0 x`` of the restoring force, the Dahl
friction and the orifice-law correction of the flow are held over a sub-step (evaluated at its
start). For an elastic specimen without friction the integration is exact.

Specimen state (trial/commit): the specimen's trial displacement is set at every sub-step end and
committed at once. A physical specimen cannot revert: it experiences the actuator's whole path,
overshoot and reversals included, and a path-dependent hysteresis model must see that path to
produce the spurious hysteresis that actuator errors cause (Shing and Mahin, "Cumulative
experimental errors in pseudodynamic tests", Earthquake Eng. Struct. Dyn. 15, 1987). Committing
only when a step's hold completes would treat an overshoot-and-return as one monotonic increment
and miss it. The emulator owns the specimen: nothing else may set its trial state during a test.

Default tuning (SI; see :class:`EmulatorParameters`): piston area 0.01 m2, effective bulk modulus
690 MPa (100 000 psi, the design value Merritt suggests), total chamber volume 6 L and moving mass
50 kg give ``k_h = 4.6e7 N/m``; with the 312.559 kN/m thesis column the oil-column mode is at
962 rad/s (153 Hz) with a damping ratio of 0.10 (mostly the 9.5 kN s/m seal damping; leakage
5e-12 m3/(s Pa), i.e. 3 L/min at 100 bar). A 60 L/min valve (``Q = 1e-3 m3/s``) with a 1.5 ms
spool lag gives a no-load velocity ``Q / A = 0.1 m/s``. ``k_p = 4000 V/m`` sets the velocity
constant ``K_v = k_p Q / (u_max A) = 40 1/s``, well below the limit ``2 zeta_h omega_h`` of about
190 1/s (Merritt ch. 7); the loop goes unstable at ``k_p`` of about 49 000 V/m (gain margin about
22 dB). With ``k_p`` alone the leakage under load leaves a static error of 0.039 % of the
displacement against the column (:meth:`EmulatorParameters.static_error_ratio`). The actuator is
already an integrator, so integral action makes the loop type 2, whose step error integrates to
zero: the whole rise area ``dx / K_v`` would be paid back by overshoot, slowly. Hence the
integral only acts within ``integral_band = 50 um`` of the command (conditional integration,
Astrom and Hagglund, *Advanced PID Control*, ISA 2006, on integrator windup):
``k_i = 20 000 V/(m s)`` (corner 5 rad/s) then removes the leakage error in a few tenths of a
second while the overshoot it causes stays of the order of ``integral_band * k_i / (k_p K_v)``
(about 6 um). The band must exceed the proportional-only error ``0.039 % * |x|`` (so up to
128 mm against the column). Against the column a 1 mm step command reaches 90 % at 0.055 s,
stays within 2 % from 0.091 s and within 0.5 % from 0.114 s, with a 0.36 % overshoot; the error
is below 4e-5 mm after 1 s. The closed-loop displacement bandwidth (-3 dB) is 6.95 Hz; at 1 Hz
the amplitude ratio is 0.99 and the phase lag 8.6 degrees (an equivalent delay of about
``1 / K_v`` = 24 ms). The emulator tests (``tests/core/test_emulator.py``) check these figures.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Integral
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from ..errors import BridgeConfigError, DriverError
from .emulator_parameters import EmulatorParameters


class SpecimenModel(Protocol):
    """What the emulator needs from a specimen (e.g. :class:`pd_common.specimen.Specimen`)."""

    @property
    def n_dof(self) -> int:
        """Number of DOF."""

    def restoring_force(self, x: NDArray[np.float64]) -> NDArray[np.float64] | Sequence[float]:
        """Set the trial displacement (m) and return the trial restoring force (N) per DOF."""

    def commit(self) -> None:
        """Commit the trial state."""

    def revert_to_last_commit(self) -> None:
        """Discard the trial state."""


@dataclass(frozen=True)
class Measurement:
    """What one controller period produced (one value per DOF in every array).

    Attributes:
        time: Time at which the sensors were sampled (end of the period), s.
        command: Displacement command received for this period (before the transport delay), m.
        displacement: Measured displacement (noise, quantisation), m.
        force: Measured force: load cell reading ``r(x) + F_fr`` plus bias and noise, quantised,
            N.
        true_displacement: True piston displacement, m.
        true_force: True restoring force of the specimen ``r(x)``, N.
        valve: Controller output held over the period, V.
    """

    time: float
    command: np.ndarray
    displacement: np.ndarray
    force: np.ndarray
    true_displacement: np.ndarray
    true_force: np.ndarray
    valve: np.ndarray


class ServoHydraulicEmulator:
    """One servo-hydraulic actuator per DOF under PID displacement control, driving a specimen.

    See the module docstring for the model, the integration scheme, the trial/commit policy and
    the default tuning.
    """

    def __init__(
        self,
        specimen: SpecimenModel,
        parameters: EmulatorParameters | None = None,
        *,
        stiffness: np.ndarray | Sequence[Sequence[float]] | None = None,
        position: Sequence[float] | None = None,
    ) -> None:
        """Create the emulator at rest.

        Args:
            specimen: The specimen (``restoring_force``, ``commit``, ``revert_to_last_commit``,
                ``n_dof``); the emulator owns its trial state.
            parameters: The parameters; defaults if omitted.
            stiffness: Linear stiffness matrix ``K_0`` (N/m, ``n_dof x n_dof``) integrated
                exactly; the rest of the restoring force is explicit. Default: the specimen's
                ``initial_stiffness_matrix()`` if it has one, else zeros.
            position: Initial displacement per DOF, m (default zeros); see :meth:`reset`.

        Raises:
            BridgeConfigError: On a bad specimen, parameters or stiffness.
            DriverError: If the specimen cannot be evaluated at the initial position.
        """
        for attribute in ('restoring_force', 'commit', 'revert_to_last_commit'):
            if not callable(getattr(specimen, attribute, None)):
                msg = f'ServoHydraulicEmulator: specimen has no method {attribute}()'
                raise BridgeConfigError(msg)
        n_dof = getattr(specimen, 'n_dof', None)
        if isinstance(n_dof, bool) or not isinstance(n_dof, Integral) or n_dof < 1:
            msg = (
                f'ServoHydraulicEmulator: specimen.n_dof must be a positive integer, got '
                f'{n_dof!r}'
            )
            raise BridgeConfigError(msg)
        if parameters is None:
            parameters = EmulatorParameters()
        if not isinstance(parameters, EmulatorParameters):
            msg = (
                'ServoHydraulicEmulator: parameters must be EmulatorParameters, got '
                f'{type(parameters).__name__}'
            )
            raise BridgeConfigError(msg)
        self._specimen = specimen
        self._p = parameters
        self._n = n = int(n_dof)
        self._k0 = self._stiffness_matrix(stiffness)
        self._build_discretisation()
        self._t_count = 0
        self._x_true = np.zeros(n)
        self.reset(position)

    # ------------------------------------------------------------------ setup

    def _stiffness_matrix(self, stiffness: Any) -> np.ndarray:
        n = self._n
        if stiffness is None:
            method = getattr(self._specimen, 'initial_stiffness_matrix', None)
            if not callable(method):
                return np.zeros((n, n))
            stiffness = method()
        try:
            k0 = np.array(stiffness, dtype=float)
        except (TypeError, ValueError):
            msg = 'ServoHydraulicEmulator: stiffness must be a numeric matrix'
            raise BridgeConfigError(msg) from None
        if k0.shape != (n, n) or not np.all(np.isfinite(k0)):
            msg = (
                f'ServoHydraulicEmulator: stiffness must be a finite {n}x{n} matrix, got shape '
                f'{k0.shape}'
            )
            raise BridgeConfigError(msg)
        return k0

    def _build_discretisation(self) -> None:
        """Exact zero-order-hold discretisation of the linear plant at the sub-step."""
        p, n = self._p, self._n
        eye = np.eye(n)
        k_h = p.hydraulic_stiffness
        a = p.piston_area
        # State z = [s, F_a, x, v] (blocks of n); inputs w = [o, q_extra, f_ext].
        a_c = np.zeros((4 * n, 4 * n))
        b_c = np.zeros((4 * n, 3 * n))
        s_, f_, x_, v_ = (slice(i * n, (i + 1) * n) for i in range(4))
        a_c[s_, s_] = -eye / p.valve_time_constant
        b_c[s_, 0:n] = eye / p.valve_time_constant
        a_c[f_, s_] = eye * k_h * p.valve_flow / a
        a_c[f_, f_] = -eye * k_h * p.leakage / a**2
        a_c[f_, v_] = -eye * k_h
        b_c[f_, n:2 * n] = eye * k_h / a
        a_c[x_, v_] = eye
        a_c[v_, f_] = eye / p.piston_mass
        a_c[v_, x_] = -self._k0 / p.piston_mass
        a_c[v_, v_] = -eye * (p.piston_damping + p.friction_viscous) / p.piston_mass
        b_c[v_, 2 * n:3 * n] = eye / p.piston_mass
        augmented = np.zeros((7 * n, 7 * n))
        augmented[: 4 * n, : 4 * n] = a_c
        augmented[: 4 * n, 4 * n:] = b_c
        from scipy.linalg import expm  # noqa: PLC0415 - 0.15 s to import: not at start-up

        exp = expm(augmented * p.substep)
        self._phi = exp[: 4 * n, : 4 * n]
        gamma = exp[: 4 * n, 4 * n:]
        self._gamma_o = gamma[:, 0:n]
        self._gamma_q = gamma[:, n:2 * n]
        self._gamma_f = gamma[:, 2 * n:3 * n]
        self._phi_k = self._phi.copy()
        self._phi_k[:, x_] += self._gamma_f @ self._k0
        self._orifice = p.supply_pressure is not None
        self._kff = p.velocity_feedforward * p.valve_saturation * a / (p.valve_flow * p.dt)
        self._ki_dt = p.ki * p.dt
        self._a_c = a_c

    # ------------------------------------------------------------------ properties

    @property
    def parameters(self) -> EmulatorParameters:
        """The parameters."""
        return self._p

    @property
    def specimen(self) -> SpecimenModel:
        """The specimen driven by the emulator."""
        return self._specimen

    @property
    def n_dof(self) -> int:
        """Number of actuators (DOF)."""
        return self._n

    @property
    def rate(self) -> float:
        """Controller rate, Hz."""
        return self._p.rate

    @property
    def dt(self) -> float:
        """Controller period, s."""
        return self._p.dt

    @property
    def time(self) -> float:
        """Time since the last :meth:`reset`, s (a whole number of periods)."""
        return self._t_count * self._p.dt

    @property
    def ticks(self) -> int:
        """Controller periods since the last :meth:`reset`."""
        return self._t_count

    @property
    def position(self) -> np.ndarray:
        """True piston displacement per DOF, m."""
        return self._z[2 * self._n:3 * self._n].copy()

    @property
    def velocity(self) -> np.ndarray:
        """True piston velocity per DOF, m/s."""
        return self._z[3 * self._n:].copy()

    @property
    def force(self) -> np.ndarray:
        """True restoring force of the specimen per DOF, N."""
        return self._r.copy()

    @property
    def hydraulic_force(self) -> np.ndarray:
        """Hydraulic force ``A p`` per DOF, N."""
        return self._z[self._n:2 * self._n].copy()

    @property
    def friction_force(self) -> np.ndarray:
        """Friction force of the connections ``F_dahl + c_f v`` per DOF, N."""
        return self._dahl + self._p.friction_viscous * self._z[3 * self._n:]

    @property
    def command(self) -> np.ndarray:
        """Last command received (the reset position before the first tick), m."""
        return self._last_command.copy()

    @property
    def measured_displacement(self) -> np.ndarray:
        """Last sampled (measured) displacement per DOF, m."""
        return self._y.copy()

    @property
    def measured_force(self) -> np.ndarray:
        """Last sampled (measured) force per DOF, N."""
        return self._f_meas.copy()

    @property
    def last_measurement(self) -> Measurement:
        """The sensors' last sample (after :meth:`reset`, the sample at rest)."""
        return self._last

    def plant_poles(self) -> np.ndarray:
        """Continuous-time poles of the linear plant alone (open loop, valve command held), 1/s.

        Shows the oil-column mode interacting with the specimen stiffness ``K_0``.
        """
        return np.linalg.eigvals(self._a_c)

    # ------------------------------------------------------------------ API

    def reset(self, position: Sequence[float] | None = None) -> Measurement:
        """Bring the actuators to rest, in equilibrium, at ``position``, and restart the clock.

        The specimen is moved there (trial and commit) from its committed state; its history is
        not erased. The hydraulic force balances the restoring force, the spool passes the
        leakage flow, the PID integrator holds that spool opening (bumpless start), the delay
        line is filled with ``position``, the friction is zero and the noise generator is
        re-seeded with ``parameters.seed``.

        Args:
            position: Displacement per DOF, m; ``None`` keeps the current true position (zeros
                when the emulator is created).

        Returns:
            The sensors' sample at rest.

        Raises:
            DriverError: If ``position`` is malformed or the specimen cannot be evaluated there.
        """
        p, n = self._p, self._n
        x0 = self._x_true.copy() if position is None else self._vector(position, 'position')
        r0 = self._evaluate(x0)
        self._specimen.commit()
        s0 = p.leakage * r0 / (p.piston_area * p.valve_flow)
        if p.supply_pressure is not None:
            drop = 1.0 - np.abs(r0) / (p.piston_area * p.supply_pressure)
            s0 = s0 / np.sqrt(np.maximum(drop, 1e-12))
        s0 = np.clip(s0, -1.0, 1.0)
        self._z = np.concatenate([s0, r0, x0, np.zeros(n)])
        self._x_true = x0.copy()
        self._r = r0
        self._dahl = np.zeros(n)
        self._rng = np.random.default_rng(p.seed)
        self._integral = p.valve_saturation * s0
        self._derivative = np.zeros(n)
        self._delay: deque[np.ndarray] = deque(
            [x0.copy() for _ in range(p.delay_ticks + 1)], maxlen=p.delay_ticks + 1
        )
        self._reference = x0.copy()
        self._last_command = x0.copy()
        self._t_count = 0
        self._y, self._f_meas = self._sample()
        self._y_prev = self._y.copy()
        self._last = Measurement(
            0.0, x0.copy(), self._y.copy(), self._f_meas.copy(), x0.copy(), r0.copy(),
            self._integral.copy(),
        )
        return self._last

    def tick(self, command: Sequence[float] | np.ndarray) -> Measurement:
        """Run one controller period with ``command`` and return the sensors' sample at its end.

        Args:
            command: Displacement command per DOF, m.

        Returns:
            The measurement at the end of the period.

        Raises:
            DriverError: If the command is malformed or non-finite, or the specimen fails (the
                emulator then stays at the last good sub-step and the specimen's trial state is
                reverted).
        """
        p, n = self._p, self._n
        c = self._vector(command, 'command')
        self._delay.append(c)
        reference = self._delay[0]
        y = self._y
        error = reference - y
        # PID with a filtered derivative on the measurement and conditional integration.
        base = p.kp * error
        if p.kd > 0.0:
            self._derivative = (
                p.derivative_filter * self._derivative - p.kd * (y - self._y_prev)
            ) / (p.derivative_filter + p.dt)
            base = base + self._derivative
        if p.velocity_feedforward > 0.0:
            base = base + self._kff * (reference - self._reference)
        integral = self._integral + self._ki_dt * error
        raw = base + integral
        u_max = p.valve_saturation
        freeze = ((np.abs(raw) > u_max) & (error * raw > 0.0)) | (np.abs(error) > p.integral_band)
        if freeze.any():
            integral = np.where(freeze, self._integral, integral)
            raw = base + integral
        u = np.minimum(np.maximum(raw, -u_max), u_max)
        self._integral = integral
        self._reference = reference
        self._last_command = c

        drive = self._gamma_o @ (u / u_max)
        phi, gamma_f = self._phi_k, self._gamma_f
        friction = p.friction_coulomb > 0.0
        z = self._z
        for _ in range(p.substeps):
            # phi_k folds the exactly integrated K_0 x in: only r - K_0 x is explicit.
            z_new = phi @ z + drive - gamma_f @ (self._r + self._dahl)
            if self._orifice:
                z_new += self._gamma_q @ self._extra_flow(z)
            x_new = z_new[2 * n:3 * n]
            self._r = self._evaluate(x_new)
            self._specimen.commit()
            if friction:
                self._dahl = self._dahl_update(self._dahl, x_new - z[2 * n:3 * n])
            self._z = z = z_new
        self._x_true = z[2 * n:3 * n].copy()

        self._t_count += 1
        self._y_prev = y
        self._y, self._f_meas = self._sample()
        self._last = Measurement(
            self.time, c.copy(), self._y.copy(), self._f_meas.copy(), self._x_true.copy(),
            self._r.copy(), u,
        )
        return self._last

    # ------------------------------------------------------------------ internals

    def _vector(self, values: Any, what: str) -> np.ndarray:
        try:
            vector = np.array(values, dtype=float).reshape(-1)
            if vector.shape == (self._n,) and math.isfinite(vector.sum()):
                return vector
        except (TypeError, ValueError):
            msg = f'ServoHydraulicEmulator: {what} must be {self._n} numbers, got {values!r}'
            raise DriverError(msg) from None
        if vector.shape != (self._n,):
            msg = f'ServoHydraulicEmulator: {what} has {vector.size} values, expected {self._n}'
            raise DriverError(msg)
        if not np.all(np.isfinite(vector)):
            msg = f'ServoHydraulicEmulator: non-finite {what} {vector.tolist()}'
            raise DriverError(msg)
        return vector

    def _evaluate(self, x: np.ndarray) -> np.ndarray:
        """Trial restoring force at ``x``; reverts the specimen's trial state on failure."""
        try:
            r = np.asarray(self._specimen.restoring_force(x.copy()), dtype=float).reshape(-1)
        except Exception as exc:
            self._specimen.revert_to_last_commit()
            msg = (
                f'ServoHydraulicEmulator: specimen failed at x={x.tolist()} m: '
                f'{type(exc).__name__}: {exc}'
            )
            raise DriverError(msg) from exc
        if r.shape != (self._n,) or not math.isfinite(r.sum()):
            self._specimen.revert_to_last_commit()
            msg = (
                f'ServoHydraulicEmulator: specimen returned {r.tolist()} at x={x.tolist()} m, '
                f'expected {self._n} finite forces'
            )
            raise DriverError(msg)
        return r

    def _extra_flow(self, z: NDArray[np.float64]) -> NDArray[np.float64]:
        """Orifice-law correction ``Q s (g - 1)`` of the linear flow ``Q s``.

        ``g = sign(a) sqrt(|a|)`` with ``a = 1 - sign(s) p / P_s``: the flow reverses when the
        load pressure exceeds the supply pressure.
        """
        p, n = self._p, self._n
        if p.supply_pressure is None:
            return np.zeros(n)
        spool = z[:n]
        pressure = z[n:2 * n] / p.piston_area
        drop = 1.0 - np.sign(spool) * pressure / p.supply_pressure
        factor = np.sign(drop) * np.sqrt(np.abs(drop))
        return p.valve_flow * spool * (factor - 1.0)

    def _dahl_update(self, force: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """Dahl friction after a displacement increment ``dx`` (exact for the model)."""
        f_c = self._p.friction_coulomb
        if f_c <= 0.0:
            return force
        direction = np.sign(dx)
        decay = np.exp(-self._p.friction_stiffness * np.abs(dx) / f_c)
        return np.where(dx != 0.0, direction * f_c + (force - direction * f_c) * decay, force)

    def _sample(self) -> tuple[np.ndarray, np.ndarray]:
        """Sample the displacement sensor and the load cell (noise drawn every period)."""
        p, n = self._p, self._n
        noise = self._rng.standard_normal(2 * n)
        y = _quantise(self._z[2 * n:3 * n] + p.displacement_noise * noise[:n], p.displacement_lsb)
        load = self._r + self._dahl + p.force_bias + p.force_noise * noise[n:]
        if p.friction_viscous > 0.0:
            load += p.friction_viscous * self._z[3 * n:]
        return y, _quantise(load, p.force_lsb)


def _quantise(values: np.ndarray, lsb: float) -> np.ndarray:
    """Round to the nearest multiple of ``lsb`` (unchanged if ``lsb`` is 0)."""
    if lsb <= 0.0:
        return values.copy()
    return np.round(values / lsb) * lsb
