"""The vRTHS benchmark's PI-P controller: Tustin coefficients and the difference equations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from pd_common.errors import RthsError
from pd_common.rths import compensator_names, make_compensator
from pd_common.rths.compensation.pi_p import PiPController, tustin_first_order

DT = 1.0 / 4096.0


def test_tustin_coefficients_equal_the_hand_derivation() -> None:
    # s = (2/T)(z − 1)/(z + 1) in (b1 s + b0)/(s + a0):
    # ((2 b1/T + b0) z + (b0 − 2 b1/T)) / ((2/T + a0) z + (a0 − 2/T)).
    b1, b0, a0 = 50.8316, 8570.40, 8570.40
    w = 2.0 / DT
    (n0, n1), (one, d1) = tustin_first_order((b1, b0), (1.0, a0), DT)
    assert one == 1.0
    assert n0 == pytest.approx((w * b1 + b0) / (w + a0), rel=1e-14)
    assert n1 == pytest.approx((b0 - w * b1) / (w + a0), rel=1e-14)
    assert d1 == pytest.approx((a0 - w) / (w + a0), rel=1e-14)
    # PI: (kp s + ki)/s → ((kp + ki T/2) z + (ki T/2 − kp)) / (z − 1).
    (c0, c1), (_one, cd1) = tustin_first_order((2.0, 95.0), (1.0, 0.0), DT)
    assert c0 == pytest.approx(2.0 + 95.0 * DT / 2, rel=1e-14)
    assert c1 == pytest.approx(95.0 * DT / 2 - 2.0, rel=1e-14)
    assert cd1 == pytest.approx(-1.0, rel=1e-14)


def _independent_pi_p(x_d: np.ndarray, x_m: np.ndarray) -> np.ndarray:
    """u by scipy's lfilter of the hand-derived Tustin filters (x_m given, open loop)."""
    w = 2.0 / DT
    b1, b0, a0 = 50.8316, 8570.40, 8570.40
    y_p = signal.lfilter([w * b1 + b0, b0 - w * b1], [w + a0, a0 - w], x_d)
    error = y_p - x_m
    return np.asarray(signal.lfilter([2.0 + 95.0 / w, 95.0 / w - 2.0], [1.0, -1.0], error))


def test_command_sequence_equals_the_filters() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(3000) * DT
    x_d = 0.01 * np.sin(2 * np.pi * 3.6 * t)
    x_m = 0.01 * np.sin(2 * np.pi * 3.6 * (t - 0.02)) + 1e-5 * rng.standard_normal(t.size)
    controller = make_compensator('pi_p', DT)
    u = np.array([controller.command(a, b) for a, b in zip(x_d, x_m, strict=True)])
    np.testing.assert_allclose(u, _independent_pi_p(x_d, x_m), rtol=0, atol=1e-15)
    controller.reset()
    assert controller.command(float(x_d[0]), float(x_m[0])) == pytest.approx(u[0], abs=1e-18)


def test_frequency_response_of_the_feed_forward_is_the_continuous_one_at_low_frequency() -> None:
    f = np.array([0.5, 1.0, 5.0, 20.0])
    (n0, n1), (_one, d1) = tustin_first_order((50.8316, 8570.40), (1.0, 8570.40), DT)
    _w, h = signal.freqz([n0, n1], [1.0, d1], worN=2 * np.pi * f * DT)
    s = 2j * np.pi * f
    continuous = (50.8316 * s + 8570.40) / (s + 8570.40)
    # Tustin warps frequency by O((ωT)²): tiny below 20 Hz at 4096 Hz.
    np.testing.assert_allclose(h, continuous, rtol=1e-4)
    # the filter leads: about 49.8/8570 s ≈ 5.8 ms of phase lead at low frequency
    lead = np.angle(continuous[1]) / (2 * np.pi)
    assert lead == pytest.approx(49.8316 / 8570.40, rel=1e-3)


def test_registered_with_named_parameters_and_checked() -> None:
    assert 'pi_p' in compensator_names()
    controller = make_compensator('pi_p', DT, {'kp': 1.0, 'ki': 0.0, 'ff_num1': 1.0,
                                               'ff_num0': 1.0, 'ff_den0': 1.0})
    assert isinstance(controller, PiPController)
    # G_T = 1 and C = 1: u = x_d − x_m
    assert controller.command(0.3, 0.1) == pytest.approx(0.2, rel=1e-12)
    with pytest.raises(RthsError, match='ff_den0'):
        make_compensator('pi_p', DT, {'ff_den0': 0.0})
    with pytest.raises(RthsError, match='quantum'):
        make_compensator('pi_p', DT, {'quantum': -1.0})
    with pytest.raises(RthsError, match='unknown parameter'):
        make_compensator('pi_p', DT, {'gain': 1.0})


def test_quantum_quantises_target_filter_output_and_error() -> None:
    q = 2.0 ** -18
    controller = make_compensator('pi_p', DT, {'kp': 1.0, 'ki': 0.0, 'ff_num1': 1.0,
                                               'ff_num0': 1.0, 'ff_den0': 1.0,
                                               'quantum': q})
    u = controller.command(10.4 * q, 0.3 * q)  # G_T = 1: round(round(10.4) − 0.3) = 10
    assert u == pytest.approx(10 * q, abs=1e-18)
