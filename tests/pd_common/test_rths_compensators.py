"""The compensators polynomial, model_based and adaptive: exactness, identification, adaptation,
parameter checks."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from pd_common.errors import RthsError
from pd_common.rths import TransferSystem, compensator_names, compensator_spec, make_compensator
from pd_common.rths.compensation import DEFAULT_COMPENSATOR
from pd_common.rths.compensation.adaptive import AdaptiveTimeSeries, initial_coefficients
from pd_common.rths.compensation.model_based import (
    NOMINAL_MODEL,
    ModelBasedController,
    identification_record,
    identify_all_pole,
)
from pd_common.rths.compensation.polynomial import (
    PolynomialExtrapolation,
    backward_derivative_weights,
    lagrange_weights,
)
from pd_common.rths.plant import BenchmarkPlant

DT = 1.0 / 4096.0


class AllPolePlant(TransferSystem):
    """``G = 1/Σ c_i s^i``, discretised exactly for a held command (zero-order hold)."""

    def __init__(self, dt: float, coefficients: tuple[float, ...]) -> None:
        super().__init__(dt)
        num = [1.0]
        den = list(reversed(coefficients))
        a, b, c, _d = signal.tf2ss(num, den)
        ad, bd, cd, _dd, _dt = signal.cont2discrete((a, b, c, np.zeros((1, 1))), dt)
        self.ad, self.bd, self.cd = ad, bd[:, 0], cd[0]
        self.reset()

    def reset(self) -> None:
        self.x = np.zeros(self.ad.shape[0])

    def output(self) -> float:
        return float(self.cd @ self.x)

    def advance(self, command: float) -> None:
        self.x = self.ad @ self.x + self.bd * command


class GainDelayPlant(TransferSystem):
    """``y[k] = A u[k − d]``: a pure amplitude and a delay of ``d`` samples."""

    def __init__(self, dt: float, amplitude: float, samples: int) -> None:
        super().__init__(dt)
        self.amplitude, self.samples = amplitude, samples
        self.reset()

    def reset(self) -> None:
        self.past = [0.0] * self.samples

    def output(self) -> float:
        return self.amplitude * self.past[-1]

    def advance(self, command: float) -> None:
        self.past.insert(0, command)
        self.past.pop()


def test_registered_with_described_parameters_and_a_default() -> None:
    for name in ('polynomial', 'model_based', 'adaptive'):
        spec = compensator_spec(name)
        assert spec.description
        assert spec.parameters and all(p.description for p in spec.parameters)
    assert DEFAULT_COMPENSATOR in compensator_names()


def test_lagrange_weights_are_exact_for_polynomials() -> None:
    rng = np.random.default_rng(3)
    nodes = [0.0, -1.0, -2.0, -3.0]
    for _ in range(5):
        coefficients = rng.standard_normal(4)            # a cubic
        values = np.polyval(coefficients, nodes)
        point = rng.uniform(0.0, 50.0)
        for d in range(4):
            expected = np.polyval(np.polyder(coefficients, d), point) if d else \
                np.polyval(coefficients, point)
            got = np.dot(lagrange_weights(nodes, point, d), values)
            assert got == pytest.approx(expected, rel=1e-9, abs=1e-9 * abs(expected) + 1e-9)
    # the backward differences in time units: 3 points, first derivative (3x0 − 4x1 + x2)/2h
    np.testing.assert_allclose(backward_derivative_weights(1, 3, 0.5),
                               [3.0, -4.0, 1.0], rtol=1e-12)
    with pytest.raises(RthsError):
        lagrange_weights([0.0, 0.0], 1.0)


@pytest.mark.parametrize('order', [1, 2, 3])
def test_polynomial_extrapolation_is_exact_for_a_polynomial_of_its_order(order: int) -> None:
    delay, amplitude = 0.024, 0.9
    compensator = PolynomialExtrapolation(DT, delay=delay, order=order, amplitude=amplitude)
    rng = np.random.default_rng(order)
    coefficients = rng.standard_normal(order + 1)
    t = np.arange(40) * DT
    target = np.polyval(coefficients, t)
    commands = [compensator.command(float(x), 0.0) for x in target]
    expected = np.polyval(coefficients, t + delay) / amplitude
    # exact once order+1 targets are in (before, the zeros of rest count)
    np.testing.assert_allclose(commands[order:], expected[order:], rtol=1e-9, atol=1e-9)
    # … and not for a polynomial of one degree more
    higher = 1e3 * t ** (order + 1)
    compensator.reset()
    commands = [compensator.command(float(x), 0.0) for x in higher]
    expected = (t + delay) ** (order + 1) * 1e3 / amplitude
    assert abs(commands[-1] - expected[-1]) > 1e-6 * abs(expected[-1])


def test_polynomial_feedback_adds_pi_of_the_error() -> None:
    compensator = PolynomialExtrapolation(DT, delay=0.0, order=1, amplitude=1.0, kp=2.0,
                                          ki=100.0)
    u1 = compensator.command(1e-3, 0.0)
    u2 = compensator.command(1e-3, 0.5e-3)
    assert u1 == pytest.approx(1e-3 + 2.0 * 1e-3 + 100.0 * 1e-3 * DT)
    assert u2 == pytest.approx(1e-3 + 2.0 * 0.5e-3 + 100.0 * 1.5e-3 * DT)


def test_model_based_feed_forward_is_the_model_inverse_of_a_polynomial_target() -> None:
    c = NOMINAL_MODEL
    compensator = ModelBasedController(DT, c, kp=0.0, ki=0.0)
    poly = np.array([2e-4, 1e-3, 0.5, -2.0, 3.0])   # degree 4 = order + 1 (highest first)
    t = np.arange(30) * DT
    target = np.polyval(poly, t)
    commands = np.array([compensator.command(float(x), 0.0) for x in target])
    held = [c[0], *(c[i] + 0.5 * DT * c[i - 1] for i in range(1, len(c))), 0.5 * DT * c[-1]]
    expected = sum(ci * np.polyval(np.polyder(poly, i), t) if i else ci * target
                   for i, ci in enumerate(held))
    np.testing.assert_allclose(commands[5:], expected[5:], rtol=1e-7)


def test_model_based_inverse_in_series_with_its_model_gives_the_target_back() -> None:
    # Target: two tones; the command held over each sample through G_m = 1/Σ c_i s^i returns
    # the target (the inverse includes the hold's half sample), up to the truncation of the
    # hold's e^{s dt/2} at first order and of the derivatives.
    t = np.arange(int(3.0 / DT)) * DT
    window = np.sin(np.pi * t / t[-1]) ** 2
    target = 1e-3 * window * (np.sin(2 * np.pi * 3.6 * t) + 0.3 * np.sin(2 * np.pi * 16 * t))
    compensator = ModelBasedController(DT, NOMINAL_MODEL, kp=0.0, ki=0.0)
    plant = AllPolePlant(DT, NOMINAL_MODEL)
    y = np.empty(t.size)
    for k, x in enumerate(target):
        y[k] = plant.output()
        plant.advance(compensator.command(float(x), y[k]))
    error = np.max(np.abs(y - target)) / np.max(np.abs(target))
    assert error < 1e-3
    # without the inverse the same plant is 25 ms late: an error of tens of percent
    plant.reset()
    y0 = np.empty(t.size)
    for k, x in enumerate(target):
        y0[k] = plant.output()
        plant.advance(float(x) / NOMINAL_MODEL[0])
    assert np.max(np.abs(y0 - target)) / np.max(np.abs(target)) > 0.3


def test_model_based_feedback_is_a_pi_on_the_low_passed_error() -> None:
    compensator = ModelBasedController(DT, (1.0, 0.0), kp=2.0, ki=50.0, feedback_cutoff=0.0)
    # target 0, error −x_m: u = C(z)(−x_m), Tustin PI
    errors = np.array([1.0, 0.5, -0.25, 0.0, 0.125])
    got = [compensator.command(0.0, -e) for e in errors]
    expected = signal.lfilter([2.0 + 50.0 * DT / 2, 50.0 * DT / 2 - 2.0], [1.0, -1.0], errors)
    np.testing.assert_allclose(got, expected, rtol=1e-12)


@pytest.mark.parametrize('coefficients', [(1.0, 0.02), (1.05, 0.024, 1.1e-4),
                                          (0.98, 0.025, 1.0e-4, 3.7e-7)])
def test_identification_recovers_a_known_all_pole_plant(coefficients: tuple[float, ...]
                                                         ) -> None:
    plant = AllPolePlant(DT, coefficients)
    u, y = identification_record(plant, seconds=20.0)
    identified = identify_all_pole(u, y, DT, order=len(coefficients) - 1)
    np.testing.assert_allclose(identified, coefficients, rtol=1e-3)


def test_the_defaults_are_the_identified_nominal_benchmark_plant() -> None:
    u, y = identification_record(BenchmarkPlant(DT))
    identified = identify_all_pole(u, y, DT, order=3, cutoff=20.0)
    np.testing.assert_allclose(identified, NOMINAL_MODEL, rtol=1e-6)
    spec = {p.name: p.default for p in compensator_spec('model_based').parameters}
    assert tuple(spec[f'c{i}'] for i in range(4)) == NOMINAL_MODEL
    assert spec['order'] == 3


def test_identification_refuses_bad_records() -> None:
    with pytest.raises(RthsError, match='same length'):
        identify_all_pole(np.zeros(100), np.zeros(99), DT)
    with pytest.raises(RthsError, match='order'):
        identify_all_pole(np.zeros(100), np.zeros(100), DT, order=5)


def _drive_gain_delay(compensator: AdaptiveTimeSeries, plant: GainDelayPlant,
                      t: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Run the ATS on the plant; the measured displacement and the coefficients per sample."""
    y = np.empty(t.size)
    history = np.empty((t.size, 3))
    for k, x in enumerate(target):
        y[k] = plant.output()
        plant.advance(compensator.command(float(x), y[k]))
        history[k] = compensator.coefficients
    return y, history


def test_ats_on_a_gain_and_delay_converges_to_the_closed_form_within_its_bounds() -> None:
    amplitude, samples = 0.9, 90                  # τ = 90/4096 ≈ 22 ms
    tau = samples * DT
    freqs = (1.0, 2.5)                            # a window of 2 s: 2 and 5 periods
    t = np.arange(int(16.0 / DT)) * DT
    target = 1e-3 * (np.sin(2 * np.pi * freqs[0] * t) + 0.5 * np.sin(2 * np.pi * freqs[1] * t))
    bounds = ((0.5, 2.0), (0.0, 0.1), (0.0, 2e-3))
    # a poor start (amplitude 1, delay 10 ms) the adaptation has to correct
    compensator = AdaptiveTimeSeries(DT, amplitude=1.0, delay=0.010, window=2.0,
                                     update_interval=0.05, cutoff=10.0, bounds=bounds)
    y, history = _drive_gain_delay(compensator, GainDelayPlant(DT, amplitude, samples), t,
                                   target)
    for i, (low, high) in enumerate(bounds):
        assert np.all(history[:, i] >= low) and np.all(history[:, i] <= high)
    assert compensator.updates > 100
    # The closed form: least squares of u = a0 y + a1 ẏ + a2 ÿ over the window, in steady
    # state the sum over the two tones of |Y_i F_i|² |a0 − a2 ω² + j a1 ω − e^{jωτ}/A|².
    last = t > t[-1] - 2.0
    sos = signal.butter(2, 10.0, fs=1.0 / DT, output='sos')
    rows, rhs = [], []
    for f in freqs:
        w = 2 * np.pi * f
        basis = np.column_stack([np.sin(w * t[last]), np.cos(w * t[last])])
        coefficients, *_ = np.linalg.lstsq(basis, y[last], rcond=None)
        _w, response = signal.sosfreqz(sos, worN=[f], fs=1.0 / DT)
        weight = float(np.hypot(*coefficients) * abs(response[0]))
        inverse = np.exp(1j * w * tau) / amplitude
        rows += [weight * np.array([1.0, 0.0, -w * w]), weight * np.array([0.0, w, 0.0])]
        rhs += [weight * inverse.real, weight * inverse.imag]
    closed_form, *_ = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)
    np.testing.assert_allclose(compensator.coefficients, closed_form, rtol=1e-2)
    # … which inverts the plant's amplitude and delay at both tones (up to the truncation of
    # e^{jωτ} at second order, ≈ (ωτ)²/6 of the delay)
    a0, a1, a2 = compensator.coefficients
    for f in freqs:
        w = 2 * np.pi * f
        response = a0 - a2 * w * w + 1j * a1 * w
        assert 1.0 / abs(response) == pytest.approx(amplitude, rel=0.02)
        assert np.angle(response) / w == pytest.approx(tau, rel=0.02)
    assert 1.0 / a0 == pytest.approx(amplitude, rel=0.05)
    # and the plant follows the target: the error is a small fraction of the motion
    assert np.std((y - target)[last]) < 0.02 * np.std(target[last])


def test_ats_never_leaves_a_tight_bound() -> None:
    amplitude, samples = 0.9, 90
    t = np.arange(int(6.0 / DT)) * DT
    target = 1e-3 * (np.sin(2 * np.pi * 2.0 * t) + 0.5 * np.sin(2 * np.pi * 5.0 * t))
    bounds = ((0.5, 2.0), (0.0, 0.02), (0.0, 2e-3))   # a1 would like ≈ 0.024
    compensator = AdaptiveTimeSeries(DT, amplitude=1.0, delay=0.010, window=1.0,
                                     cutoff=10.0, bounds=bounds)
    _y, history = _drive_gain_delay(compensator, GainDelayPlant(DT, amplitude, samples), t,
                                    target)
    assert np.max(history[:, 1]) == pytest.approx(0.02)
    assert np.all(history[:, 1] <= 0.02)
    assert compensator.coefficients[1] == pytest.approx(0.02)


def test_ats_starts_from_the_amplitude_and_delay_and_waits_for_excitation() -> None:
    compensator = make_compensator('adaptive', DT, {'amplitude': 0.8, 'delay': 0.02})
    assert isinstance(compensator, AdaptiveTimeSeries)
    assert compensator.coefficients == pytest.approx(initial_coefficients(0.8, 0.02))
    assert initial_coefficients(0.8, 0.02) == pytest.approx((1.25, 0.025, 0.0))
    for _ in range(int(3.0 / DT)):                  # at rest: nothing to estimate from
        compensator.command(0.0, 1e-6)
    assert compensator.updates == 0
    assert compensator.coefficients == pytest.approx(initial_coefficients(0.8, 0.02))


@pytest.mark.parametrize(('name', 'parameters', 'match'), [
    ('polynomial', {'order': 4}, 'compensator polynomial: parameter order'),
    ('polynomial', {'order': 2.0}, 'compensator polynomial: parameter order must be int'),
    ('polynomial', {'delay': -0.01}, 'compensator polynomial: parameter delay'),
    ('polynomial', {'amplitude': 0.0}, 'compensator polynomial: parameter amplitude'),
    ('polynomial', {'kp': 'high'}, 'compensator polynomial: parameter kp must be float'),
    ('polynomial', {'lead': 1.0}, "compensator polynomial: unknown parameter 'lead'"),
    ('model_based', {'order': 5}, 'compensator model_based: parameter order'),
    ('model_based', {'c0': -1.0}, 'compensator model_based: parameter c0'),
    ('model_based', {'ki': -1.0}, 'compensator model_based: parameter ki'),
    ('model_based', {'feedback_cutoff': 3000.0},
     'compensator model_based: parameter feedback_cutoff'),
    ('model_based', {'c5': 1.0}, "compensator model_based: unknown parameter 'c5'"),
    ('model_based', {'kp': True}, 'compensator model_based: parameter kp must be float'),
    ('adaptive', {'window': 0.001}, 'compensator adaptive: parameter window'),
    ('adaptive', {'update_interval': 0.0}, 'compensator adaptive: parameter update_interval'),
    ('adaptive', {'cutoff': 0.0}, 'compensator adaptive: parameter cutoff'),
    ('adaptive', {'a0_min': 1.5}, 'compensator adaptive: parameter a0_min/a0_max'),
    ('adaptive', {'a1_min': 0.2}, 'compensator adaptive: parameter a1_min/a1_max'),
    ('adaptive', {'amplitude': -1.0}, 'compensator adaptive: parameter amplitude'),
    ('adaptive', {'window': '2 s'}, 'compensator adaptive: parameter window must be float'),
    ('adaptive', {'gain': 1.0}, "compensator adaptive: unknown parameter 'gain'"),
])
def test_bad_parameters_are_one_line_rths_errors(name: str, parameters: dict[str, object],
                                                 match: str) -> None:
    with pytest.raises(RthsError, match=match) as info:
        make_compensator(name, DT, parameters)
    assert '\n' not in str(info.value)


def test_defaults_build_and_run() -> None:
    for name in ('polynomial', 'model_based', 'adaptive'):
        compensator = make_compensator(name, DT)
        u = [compensator.command(1e-3 * math.sin(k * 0.01), 0.0) for k in range(10)]
        assert all(math.isfinite(v) for v in u)
        compensator.reset()
