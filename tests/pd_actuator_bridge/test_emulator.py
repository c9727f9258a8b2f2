"""Tests of the servo-hydraulic actuator emulator (pd_actuator_bridge.core.drivers.emulator)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pd_actuator_bridge.core.drivers.emulator import Measurement, ServoHydraulicEmulator
from pd_actuator_bridge.core.drivers.emulator_parameters import EmulatorParameters
from pd_actuator_bridge.core.errors import BridgeConfigError, DriverError
from pd_common.specimen import Elastic, ElasticPerfectlyPlastic, Specimen

K_COLUMN = 312559.0
"""Initial stiffness of the thesis column, N/m."""


def column(stiffness: float = K_COLUMN) -> Specimen:
    return Specimen([Elastic(stiffness)])


def emulator(stiffness: float = K_COLUMN, **parameters: object) -> ServoHydraulicEmulator:
    return ServoHydraulicEmulator(column(stiffness), EmulatorParameters(**parameters))


def run(emu: ServoHydraulicEmulator, commands: np.ndarray) -> list[Measurement]:
    return [emu.tick([c]) for c in commands]


def true_x(measurements: list[Measurement]) -> np.ndarray:
    return np.array([m.true_displacement[0] for m in measurements])


def step_response(
    amplitude: float = 1.0e-3, duration: float = 1.0, stiffness: float = K_COLUMN, **parameters
) -> tuple[np.ndarray, np.ndarray]:
    """Normalised true displacement after a step command, and the sample times."""
    emu = emulator(stiffness, **parameters)
    n = round(duration * emu.rate)
    x = true_x(run(emu, np.full(n, amplitude))) / amplitude
    return np.arange(1, n + 1) / emu.rate, x


def settling_time(t: np.ndarray, x: np.ndarray, band: float) -> float:
    outside = np.nonzero(np.abs(x - 1.0) > band)[0]
    return float(t[outside[-1] + 1]) if outside.size else 0.0


def sine_response(frequency: float, cycles: int = 6, **parameters) -> tuple[float, float]:
    """Amplitude ratio and phase (degrees) of the true displacement to a sine command."""
    emu = emulator(**parameters)
    n = round(cycles / frequency * emu.rate)
    t = np.arange(1, n + 1) / emu.rate
    x = true_x(run(emu, 1.0e-3 * np.sin(2 * np.pi * frequency * t)))
    keep = t > (cycles // 2) / frequency
    basis = np.column_stack(
        [np.sin(2 * np.pi * frequency * t[keep]), np.cos(2 * np.pi * frequency * t[keep])]
    )
    a, b = np.linalg.lstsq(basis, x[keep], rcond=None)[0]
    return math.hypot(a, b) / 1.0e-3, math.degrees(math.atan2(b, a))


# ---------------------------------------------------------------------- parameters


def test_default_parameters_and_derived_quantities() -> None:
    p = EmulatorParameters()
    assert p.rate == 1000.0 and p.dt == pytest.approx(1.0e-3)
    assert p.hydraulic_stiffness == pytest.approx(4.6e7)
    assert p.loop_gain == pytest.approx(40.0)
    assert p.hydraulic_frequency(K_COLUMN) == pytest.approx(962.4, rel=1e-3)
    assert p.hydraulic_damping_ratio() == pytest.approx(0.10, abs=0.005)
    assert p.static_error_ratio(K_COLUMN) == pytest.approx(3.907e-4, rel=1e-3)


@pytest.mark.parametrize(
    ('values', 'name'),
    [
        ({'rate': 500.0}, 'rate'),
        ({'piston_area': -0.01}, 'piston_area'),
        ({'bulk_modulus': 0.0}, 'bulk_modulus'),
        ({'kp': math.nan}, 'kp'),
        ({'ki': -1.0}, 'ki'),
        ({'substeps': 0}, 'substeps'),
        ({'delay_ticks': 1.5}, 'delay_ticks'),
        ({'delay_ticks': True}, 'delay_ticks'),
        ({'seed': -3}, 'seed'),
        ({'integral_band': 0.0}, 'integral_band'),
        ({'force_bias': 'big'}, 'force_bias'),
        ({'displacement_noise': -1e-6}, 'displacement_noise'),
        ({'supply_pressure': -1.0}, 'supply_pressure'),
        ({'friction_coulomb': 100.0, 'friction_stiffness': 1.0e12}, 'friction_stiffness'),
    ],
)
def test_invalid_parameters_raise_one_line_naming_the_parameter(
    values: dict[str, object], name: str
) -> None:
    with pytest.raises(BridgeConfigError) as info:
        EmulatorParameters(**values)
    message = str(info.value)
    assert name in message
    assert '\n' not in message


def test_from_mapping_builds_and_names_unknown_keys() -> None:
    p = EmulatorParameters.from_mapping({'kp': 5000, 'delay_ticks': 3}, source='bridge.yaml')
    assert p.kp == 5000.0 and isinstance(p.kp, float)
    assert p.delay_ticks == 3
    with pytest.raises(BridgeConfigError, match=r'^bridge.yaml: emulator.kq: unknown key$'):
        EmulatorParameters.from_mapping({'kq': 1.0}, source='bridge.yaml', path='emulator')
    with pytest.raises(BridgeConfigError,
                       match=r'^bridge.yaml: emulator.rate: must be >= 1000, got 100.0$'):
        EmulatorParameters.from_mapping({'rate': 100.0}, source='bridge.yaml', path='emulator')
    with pytest.raises(BridgeConfigError, match='mapping'):
        EmulatorParameters.from_mapping([('kp', 1.0)])


def test_bad_specimen_and_stiffness_are_rejected() -> None:
    with pytest.raises(BridgeConfigError, match='restoring_force'):
        ServoHydraulicEmulator(object())
    with pytest.raises(BridgeConfigError, match='stiffness'):
        ServoHydraulicEmulator(column(), stiffness=np.eye(2))


# ---------------------------------------------------------------------- static behaviour


def test_static_gain_is_one_with_integral_action() -> None:
    """With ``k_i`` the steady-state error vanishes; without it, it is the leakage error."""
    p = EmulatorParameters()
    eps = p.static_error_ratio(K_COLUMN)
    # Proportional only: e / x_target = eps / (1 + eps), exactly the leakage error.
    _, x = step_response(duration=1.0, ki=0.0)
    assert 1.0 - x[-1] == pytest.approx(eps / (1.0 + eps), rel=1e-3)
    # Default PI: the static gain is 1.
    t, x = step_response(duration=2.0)
    assert abs(x[-1] - 1.0) < 1e-3 * eps
    assert np.all(np.abs(x[t > 1.5] - 1.0) < 1e-2 * eps)


def test_stiffer_specimen_changes_the_dynamics_in_the_expected_direction() -> None:
    """Control-structure interaction (Dyke et al. 1995): the specimen loads the actuator."""
    p = EmulatorParameters()
    errors = {}
    for k in (K_COLUMN, 10.0 * K_COLUMN):
        _, x = step_response(duration=0.6, stiffness=k, ki=0.0)
        errors[k] = 1.0 - x[-1]
        eps = p.static_error_ratio(k)
        assert errors[k] == pytest.approx(eps / (1.0 + eps), rel=2e-3)
    # A stiffer specimen needs more pressure, hence more leakage: a larger proportional error.
    assert errors[10.0 * K_COLUMN] > 9.0 * errors[K_COLUMN]
    # ... and it stiffens the oil column: a higher hydraulic natural frequency.
    frequencies = []
    for k in (K_COLUMN, 30.0 * K_COLUMN):
        poles = emulator(k).plant_poles()
        frequencies.append(np.max(np.abs(poles[np.abs(poles.imag) > 1.0])))
        assert frequencies[-1] == pytest.approx(p.hydraulic_frequency(k), rel=0.02)
    assert frequencies[1] > frequencies[0] * 1.08


def test_reset_is_bumpless_at_a_loaded_position() -> None:
    emu = emulator()
    emu.tick([0.5e-3])
    sample = emu.reset([2.0e-3])
    assert emu.time == 0.0 and emu.ticks == 0
    assert sample.true_force[0] == pytest.approx(K_COLUMN * 2.0e-3)
    run(emu, np.full(300, 2.0e-3))
    assert abs(emu.position[0] - 2.0e-3) < 1e-12
    assert emu.force[0] == pytest.approx(K_COLUMN * 2.0e-3, rel=1e-9)
    assert emu.time == pytest.approx(0.3)


# ---------------------------------------------------------------------- dynamics


def test_step_response_of_the_default_tuning() -> None:
    """The figures documented in the module docstring (thesis column, 1 mm step)."""
    t, x = step_response(duration=1.0)
    rise_90 = float(t[np.argmax(x >= 0.9)])
    overshoot = float(x.max() - 1.0)
    assert 0.045 <= rise_90 <= 0.065  # documented 0.055 s
    assert 0.08 <= settling_time(t, x, 0.02) <= 0.10  # documented 0.091 s
    assert 0.10 <= settling_time(t, x, 0.005) <= 0.13  # documented 0.114 s: within 0.1-0.3 s
    assert 0.0 < overshoot < 0.006  # documented 0.36 %
    assert abs(x[-1] - 1.0) < 4e-5


def test_closed_loop_bandwidth_and_phase_lag() -> None:
    ratio, _ = sine_response(6.95)
    assert ratio == pytest.approx(2**-0.5, abs=0.02)  # documented -3 dB at 6.95 Hz
    ratio, phase = sine_response(1.0, cycles=3)
    assert ratio == pytest.approx(0.99, abs=0.01)
    assert -9.5 < phase < -7.5  # documented 8.6 degrees of lag at 1 Hz


def test_integration_converges_with_the_substep() -> None:
    """Explicit parts (hysteresis remainder, Dahl friction) converge; the default is accurate."""
    amplitude = 2.0e-3
    results = {}
    for substeps in (1, 2, 8):
        emu = ServoHydraulicEmulator(
            Specimen([ElasticPerfectlyPlastic(K_COLUMN, 200.0)]),
            EmulatorParameters(substeps=substeps, friction_coulomb=100.0),
        )
        t = np.arange(1, 1001) / 1000.0
        results[substeps] = true_x(run(emu, amplitude * np.sin(2 * np.pi * t)))
    error_1 = np.max(np.abs(results[1] - results[8]))
    error_2 = np.max(np.abs(results[2] - results[8]))
    assert error_2 < 0.7 * error_1
    assert error_2 < 5e-5 * amplitude
    assert EmulatorParameters().substeps == 2


def test_delay_shifts_the_response_by_exactly_the_delay() -> None:
    delay = 7
    commands = np.concatenate([np.zeros(10), np.full(200, 1.0e-3), np.linspace(1e-3, 0, 100)])
    reference = run(emulator(), commands)
    delayed = run(emulator(delay_ticks=delay), commands)
    x0, xd = true_x(reference), true_x(delayed)
    np.testing.assert_array_equal(xd[:10 + delay], 0.0)
    np.testing.assert_array_equal(xd[delay:], x0[:-delay])
    f0 = np.array([m.force[0] for m in reference])
    fd = np.array([m.force[0] for m in delayed])
    np.testing.assert_array_equal(fd[delay:], f0[:-delay])
    # The measurement reports the command as received, before the delay.
    assert delayed[10].command[0] == 1.0e-3


def test_valve_saturates_on_a_huge_step() -> None:
    emu = emulator()
    measurements = run(emu, np.full(200, 0.2))
    assert max(abs(m.valve[0]) for m in measurements) == 10.0
    # At full opening the piston moves at the no-load velocity Q / A, less the leakage.
    assert 0.097 < emu.velocity[0] <= 0.1


def test_orifice_law_limits_the_force_to_the_supply_pressure() -> None:
    p_s = 1.0e5  # A * P_s = 1000 N, less than the 3126 N needed for 10 mm
    emu = emulator(supply_pressure=p_s)
    run(emu, np.full(1500, 10.0e-3))
    assert emu.force[0] == pytest.approx(0.01 * p_s, rel=0.02)
    assert emu.position[0] == pytest.approx(0.01 * p_s / K_COLUMN, rel=0.02)
    assert emu.last_measurement.valve[0] == 10.0


def test_velocity_feedforward_reduces_the_ramp_lag() -> None:
    ramp = np.linspace(0.0, 2.0e-3, 201)[1:]  # 10 mm/s
    lags = []
    for feedforward in (0.0, 1.0):
        x = true_x(run(emulator(velocity_feedforward=feedforward), ramp))
        lags.append(ramp[150] - x[150])
    assert lags[0] == pytest.approx(0.01 / 40.0, rel=0.1)  # v / K_v
    assert abs(lags[1]) < 0.1 * lags[0]


def test_derivative_term_is_stable_and_settles() -> None:
    t, x = step_response(duration=0.5, kd=20.0, derivative_filter=0.002)
    assert settling_time(t, x, 0.02) < 0.3
    assert x.max() < 1.02


def test_multi_dof_shear_building() -> None:
    specimen = Specimen([Elastic(2.0e6), Elastic(1.0e6)], topology='shear_building')
    emu = ServoHydraulicEmulator(specimen)
    run_target = np.array([1.0e-3, 2.0e-3])
    for _ in range(1000):
        m = emu.tick(run_target)
    np.testing.assert_allclose(m.true_displacement, run_target, atol=1e-7)
    # r_0 = k_0 x_0 - k_1 (x_1 - x_0), r_1 = k_1 (x_1 - x_0).
    np.testing.assert_allclose(m.true_force, [1000.0, 1000.0], rtol=1e-4)


# ---------------------------------------------------------------------- specimen state


def test_specimen_is_committed_along_the_whole_actuator_path() -> None:
    """The hysteresis sees every sub-step (overshoot and reversals included)."""
    k, f_y = K_COLUMN, 150.0  # yields at 0.48 mm
    emu = ServoHydraulicEmulator(
        Specimen([ElasticPerfectlyPlastic(k, f_y)]), EmulatorParameters(substeps=1)
    )
    t = np.arange(1, 2001) / 1000.0
    measurements = run(emu, 1.5e-3 * np.sin(2 * np.pi * t))
    replay = ElasticPerfectlyPlastic(k, f_y)
    forces = []
    for m in measurements:
        forces.append(replay.set_trial_displacement(m.true_displacement[0]))
        replay.commit()
    np.testing.assert_allclose([m.true_force[0] for m in measurements], forces, rtol=1e-12)
    element = emu.specimen.elements[0]
    assert element.committed_displacement == emu.position[0]
    assert element.trial_displacement == element.committed_displacement
    # It yielded both ways.
    assert max(forces) == pytest.approx(f_y) and min(forces) == pytest.approx(-f_y)


class FailingSpecimen:
    """Elastic until ``x_fail``, then raises; counts reverts."""

    n_dof = 1

    def __init__(self, x_fail: float) -> None:
        self.x_fail = x_fail
        self.reverts = 0
        self.commits = 0

    def restoring_force(self, x: np.ndarray) -> list[float]:
        if x[0] > self.x_fail:
            raise ValueError('beyond the last backbone point')
        return [1.0e5 * x[0]]

    def commit(self) -> None:
        self.commits += 1

    def revert_to_last_commit(self) -> None:
        self.reverts += 1


def test_specimen_failure_is_a_driver_error_and_reverts_the_trial() -> None:
    specimen = FailingSpecimen(0.5e-3)
    emu = ServoHydraulicEmulator(specimen)
    with pytest.raises(DriverError, match=r'specimen failed .*beyond the last backbone point'):
        for _ in range(500):
            emu.tick([1.0e-3])
    assert specimen.reverts == 1
    assert emu.position[0] <= 0.5e-3
    assert np.all(np.isfinite(emu.position))


@pytest.mark.parametrize('command', [[1.0, 2.0], [math.nan], ['x'], [[1.0, 2.0]]])
def test_malformed_commands_are_driver_errors(command: list[object]) -> None:
    emu = emulator()
    with pytest.raises(DriverError):
        emu.tick(command)
    assert emu.ticks == 0


# ---------------------------------------------------------------------- sensors and friction


def test_noise_standard_deviations_are_visible_in_the_measurement() -> None:
    emu = emulator(displacement_noise=2.0e-6, force_noise=5.0, seed=11)
    measurements = run(emu, np.zeros(4000))
    dx = np.array([m.displacement[0] - m.true_displacement[0] for m in measurements])
    df = np.array([m.force[0] - m.true_force[0] for m in measurements])
    assert np.std(dx) == pytest.approx(2.0e-6, rel=0.05)
    assert np.std(df) == pytest.approx(5.0, rel=0.05)
    assert abs(np.mean(dx)) < 2e-7 and abs(np.mean(df)) < 0.5
    # The controller feeds back the noisy measurement: the true position jitters.
    assert np.std(true_x(measurements)) > 0.0


def test_quantisation_step_is_visible_in_the_measurement() -> None:
    lsb_x, lsb_f = 1.0e-5, 10.0
    emu = emulator(displacement_lsb=lsb_x, force_lsb=lsb_f)
    measurements = run(emu, np.full(400, 0.333e-3))
    x = np.array([m.displacement[0] for m in measurements])
    f = np.array([m.force[0] for m in measurements])
    np.testing.assert_allclose(x / lsb_x, np.round(x / lsb_x), atol=1e-9)
    np.testing.assert_allclose(f / lsb_f, np.round(f / lsb_f), atol=1e-9)
    assert np.all(np.abs(x - true_x(measurements)) <= lsb_x / 2 + 1e-15)
    steps = np.unique(np.round(np.diff(np.unique(x)) / lsb_x))
    assert steps.min() == 1.0


def test_force_bias_shifts_the_measured_force_by_exactly_the_bias() -> None:
    measurements = run(emulator(force_bias=-42.5), np.full(100, 1.0e-3))
    offsets = np.array([m.force[0] - m.true_force[0] for m in measurements])
    np.testing.assert_allclose(offsets, -42.5, atol=1e-9)
    np.testing.assert_array_equal(
        [m.displacement[0] for m in measurements], true_x(measurements)
    )


def test_friction_causes_a_steady_state_force_offset() -> None:
    f_c = 300.0
    ramp_up = np.linspace(0.0, 1.0e-3, 101)[1:]
    ramp_down = np.linspace(1.0e-3, 0.5e-3, 101)[1:]
    commands = np.concatenate([ramp_up, np.full(1000, 1.0e-3), ramp_down, np.full(1000, 0.5e-3)])
    with_friction = run(emulator(friction_coulomb=f_c), commands)
    without = run(emulator(), commands)
    offset = np.array([m.force[0] - m.true_force[0] for m in with_friction])
    no_offset = np.array([m.force[0] - m.true_force[0] for m in without])
    np.testing.assert_allclose(no_offset, 0.0, atol=1e-9)
    held_up, held_down = offset[800:1100], offset[1900:]
    # Static friction is retained while held: a constant offset in the direction of the last
    # motion, never beyond the Coulomb force.
    assert 0.3 * f_c < held_up.mean() <= f_c
    assert -f_c <= held_down.mean() < -0.3 * f_c
    assert np.ptp(held_up) < 0.02 * f_c and np.ptp(held_down) < 0.02 * f_c
    # The position still reaches the command (friction is a force, not a position, error).
    assert abs(with_friction[-1].true_displacement[0] - 0.5e-3) < 1e-6


def test_deterministic_with_a_seed() -> None:
    def history(seed: int) -> np.ndarray:
        emu = emulator(displacement_noise=1e-6, force_noise=2.0, seed=seed)
        measurements = run(emu, np.full(300, 1.0e-3))
        return np.array([[m.displacement[0], m.force[0], m.true_displacement[0]]
                         for m in measurements])

    np.testing.assert_array_equal(history(5), history(5))
    assert not np.array_equal(history(5), history(6))
    emu = emulator(displacement_noise=1e-6, seed=5)
    first = [emu.tick([1e-3]).displacement[0] for _ in range(50)]
    emu.reset([0.0])
    second = [emu.tick([1e-3]).displacement[0] for _ in range(50)]
    assert first == second
