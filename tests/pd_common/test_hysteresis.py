"""Tests of pd_specimen_sim.core.hysteresis against hand-computed loops and the thesis MATLAB."""

from __future__ import annotations

import copy
import math
from collections.abc import Callable

import numpy as np
import pytest
from tests.support.hysteresis import drive

from pd_common.specimen import (
    Backbone,
    BilinearKinematic,
    Elastic,
    ElasticPerfectlyPlastic,
    HysteresisError,
    HysteresisModel,
    PushoverHysteresis,
    bilinear_backbone,
)

K = 1.0e5      # N/m
FY = 2.0e3     # N, so d_y = 0.02 m
B = 0.05       # hardening ratio: post-yield slope 5000 N/m


def pushover(max_displacement: float = 1.0, **kwargs: object) -> PushoverHysteresis:
    return PushoverHysteresis(bilinear_backbone(K, FY, B, max_displacement), **kwargs)


# --- Elastic, EPP, bilinear kinematic ---------------------------------------------------------

def test_elastic() -> None:
    model = Elastic(2.0e5)
    assert drive(model, [0.01, -0.003]) == pytest.approx([2000.0, -600.0])
    assert model.committed_displacement == -0.003
    assert model.committed_force == pytest.approx(-600.0)
    assert model.initial_stiffness == 2.0e5


def test_epp_loop() -> None:
    model = ElasticPerfectlyPlastic(K, FY)
    path = [0.01, 0.03, 0.05, 0.04, 0.03, 0.015, -0.01, 0.0]
    expected = [
        1000.0,     # elastic
        2000.0,     # yield at 0.02, x_p = 0.01
        2000.0,     # plastic flow, x_p = 0.03
        1000.0,     # unloading at k from (0.05, 2000)
        0.0,        # residual displacement 0.03
        -1500.0,    # still elastic: 1e5 * (0.015 - 0.03)
        -2000.0,    # reverse yield at 0.03 - 0.02 = 0.01, x_p = 0.01
        -1000.0,    # reload at k: 1e5 * (0 - 0.01)
    ]
    assert drive(model, path) == pytest.approx(expected)


def test_bilinear_kinematic_loop() -> None:
    model = BilinearKinematic(K, FY, 0.1)   # post-yield slope b k = 1e4 N/m
    path = [0.05, 0.04, 0.015, 0.01, 0.0, 0.03]
    expected = [
        2300.0,     # 2000 + 1e4 * (0.05 - 0.02)
        1300.0,     # unloading at k
        -1200.0,    # elastic range 2 F_y: 2300 - 1e5 * 0.035
        -1700.0,    # reverse yield at f_max - 2 F_y = 2300 - 4000 (Bauschinger)
        -1800.0,    # post-yield slope b k in reverse: -1700 - 1e4 * 0.01
        1200.0,     # elastic reload: -1800 + 1e5 * 0.03 (< -1800 + 4000)
    ]
    assert drive(model, path) == pytest.approx(expected)


def test_bilinear_kinematic_large_steps_are_exact() -> None:
    model = BilinearKinematic(K, FY, 0.1)
    assert drive(model, [0.05, 0.0]) == pytest.approx([2300.0, -1800.0])


def test_bilinear_kinematic_without_hardening_is_epp() -> None:
    path = [0.01, 0.03, 0.05, 0.04, 0.015, -0.01, 0.0, 0.04, -0.06]
    assert drive(BilinearKinematic(K, FY, 0.0), path) == pytest.approx(
        drive(ElasticPerfectlyPlastic(K, FY), path))


@pytest.mark.parametrize('factory', [
    lambda: Elastic(0.0),
    lambda: Elastic(float('nan')),
    lambda: ElasticPerfectlyPlastic(K, -1.0),
    lambda: BilinearKinematic(K, FY, 1.0),
    lambda: BilinearKinematic(-K, FY, 0.1),
    lambda: PushoverHysteresis(bilinear_backbone(K, FY), beyond='clamp'),
    lambda: PushoverHysteresis(bilinear_backbone(K, FY), unloading_stiffness=-1.0),
    lambda: PushoverHysteresis(Backbone(np.array([0.0, 1.0]), np.array([0.0, -1.0]))),
])
def test_constructor_validation(factory: Callable[[], HysteresisModel]) -> None:
    with pytest.raises(HysteresisError):
        factory()


# --- PushoverHysteresis: hand-computed loop with a bilinear backbone ---------------------------

def test_pushover_full_cycle_has_no_hardening_memory() -> None:
    model = pushover()
    path = [0.03, 0.06, 0.05, 0.03, 0.018, 0.0, 0.01, 0.0409, 0.05]
    expected = [
        2050.0,     # positive backbone: 2000 + 5000 * 0.01
        2200.0,     # x_max = 0.06, f_max = 2200
        1200.0,     # unloading at k_ini: 2200 - 1e5 * 0.01
        -800.0,     # past x_pivot = 0.06 - 2200 / 1e5 = 0.038: -B(0.008)
        -2000.0,    # negative yield at x_pivot - d_y = 0.018: -F_y, no memory of 2200
        -2090.0,    # -(2000 + 5000 * (0.038 - 0.02))
        -1090.0,    # reloading at k_ini from (0, -2090)
        2000.0,     # new pivot 0 + 2090 / 1e5 = 0.0209; yield at 0.0209 + 0.02
        2045.5,     # 2000 + 5000 * (0.05 - 0.0409)
    ]
    assert drive(model, path) == pytest.approx(expected)
    assert model.pivots[0] == pytest.approx(0.0209)


def test_pushover_zero_crossing_at_xpivot() -> None:
    model = pushover()
    drive(model, [0.06])
    assert model.set_trial_displacement(0.038) == pytest.approx(0.0, abs=1e-9)
    assert model.set_trial_displacement(0.0381) == pytest.approx(10.0)
    assert model.set_trial_displacement(0.0379) == pytest.approx(-10.0)


def test_pushover_partial_unload_reload_rejoins_backbone_at_xmax() -> None:
    model = pushover()
    # On the line through (0.06, 2200): moving up again (MATLAB state 5) keeps the same line;
    # past x_max = 0.06 the model is back on the positive backbone with pivot 0.
    assert drive(model, [0.06, 0.05, 0.055, 0.058, 0.052, 0.07]) == pytest.approx(
        [2200.0, 1200.0, 1700.0, 2000.0, 1400.0, 2250.0])


def test_pushover_partial_reload_then_through_the_pivot() -> None:
    model = pushover()
    # Line through (0.06, 2200) down past x_pivot = 0.038: -B(0.038 - 0.01) = -2040.
    assert drive(model, [0.06, 0.05, 0.055, 0.01]) == pytest.approx(
        [2200.0, 1200.0, 1700.0, -2040.0])


def test_pushover_partial_reload_on_negative_side() -> None:
    model = pushover()
    # From (0, -2090) reload (state 4), unload again (state 6) on the same line and go
    # past x_min = 0 back onto the negative backbone with pivot 0.038: -B(0.048) = -2140.
    forces = drive(model, [0.06, 0.0, 0.01, 0.005, 0.008, -0.01])
    assert forces == pytest.approx([2200.0, -2090.0, -1090.0, -1590.0, -1290.0, -2140.0])


def test_pushover_single_step_across_the_whole_line() -> None:
    model = pushover()
    drive(model, [0.06])
    assert model.set_trial_displacement(0.0) == pytest.approx(-2090.0)
    model.commit()
    # From (0, -2090) straight to the positive backbone with pivot 0.0209.
    assert model.set_trial_displacement(0.05) == pytest.approx(2045.5)


def test_pushover_virgin_negative_and_symmetry() -> None:
    path = [0.01, 0.045, 0.02, -0.03, -0.005, -0.07, 0.031, 0.012, 0.09, -0.11]
    positive = drive(pushover(), path)
    negative = drive(pushover(), [-x for x in path])
    assert negative == pytest.approx([-f for f in positive])
    assert drive(pushover(), [-0.03]) == pytest.approx([-2050.0])


def test_pushover_trial_and_revert() -> None:
    model = pushover()
    drive(model, [0.06])
    assert model.set_trial_displacement(0.05) == pytest.approx(1200.0)
    assert model.set_trial_displacement(0.07) == pytest.approx(2250.0)
    assert model.set_trial_displacement(0.0) == pytest.approx(-2090.0)
    assert model.set_trial_displacement(0.05) == pytest.approx(1200.0)
    assert model.trial_displacement == 0.05
    model.revert_to_last_commit()
    assert model.trial_displacement == 0.06
    assert model.trial_force == pytest.approx(2200.0)
    assert model.committed_force == pytest.approx(2200.0)
    # The reverted trials left no trace: the reversal point is still (0.06, 2200).
    assert model.set_trial_displacement(0.05) == pytest.approx(1200.0)
    model.commit()
    assert model.committed_displacement == 0.05
    assert model.set_trial_displacement(0.0) == pytest.approx(-2090.0)


def test_pushover_reset_and_copy() -> None:
    model = pushover()
    drive(model, [0.06, 0.0])
    twin = model.copy()
    deep = copy.deepcopy(model)
    assert twin.set_trial_displacement(0.05) == pytest.approx(2045.5)
    assert deep.set_trial_displacement(0.05) == pytest.approx(2045.5)
    twin.commit()
    assert model.set_trial_displacement(-0.01) == pytest.approx(-2140.0)
    model.reset()
    assert model.committed_displacement == 0.0 and model.committed_force == 0.0
    assert model.set_trial_displacement(0.01) == pytest.approx(1000.0)
    assert twin.committed_force == pytest.approx(2045.5)


def test_pushover_custom_unloading_stiffness() -> None:
    model = pushover(unloading_stiffness=2.0e5)
    # Line of slope 2e5 through (0.06, 2200): z = 0.06 - 0.011 = 0.049.
    assert drive(model, [0.06, 0.055, 0.045]) == pytest.approx([2200.0, 1200.0, -400.0])
    assert model.unloading_stiffness == 2.0e5
    assert model.initial_stiffness == pytest.approx(K)


def test_pushover_beyond_last_point() -> None:
    # Backbone ends at 0.1 m with 2000 + 5000 * 0.08 = 2400 N.
    assert drive(pushover(0.1), [0.12]) == pytest.approx([2500.0])
    assert drive(pushover(0.1), [-0.12]) == pytest.approx([-2500.0])
    # Unloading from (0.12, 2500): pivot 0.12 - 0.025 = 0.095, -B(0.095 + 0.12) is past the
    # end too: -(2400 + 5000 * 0.115).
    assert drive(pushover(0.1), [0.12, -0.12]) == pytest.approx([2500.0, -2975.0])
    assert drive(pushover(0.1, beyond='plateau'), [0.12]) == pytest.approx([2400.0])
    model = pushover(0.1, beyond='error')
    drive(model, [0.09])
    with pytest.raises(HysteresisError, match='beyond the last backbone point'):
        model.set_trial_displacement(0.12)
    assert model.trial_displacement == 0.09
    with pytest.raises(HysteresisError, match='beyond the last backbone point'):
        model.set_trial_displacement(-0.2)


@pytest.mark.parametrize('bad', [float('nan'), float('inf'), 'abc', None])
def test_non_finite_trial_is_rejected(bad: object) -> None:
    model = pushover()
    drive(model, [0.01])
    with pytest.raises(HysteresisError, match='finite'):
        model.set_trial_displacement(bad)  # type: ignore[arg-type]
    assert model.trial_displacement == 0.01


def test_pushover_matches_epp_without_hardening() -> None:
    # With b = 0 the backbone rule and EPP coincide: first excursion, unloading through the
    # pivot, reverse yield at pivot - d_y, reload, partial cycles.
    t = np.linspace(0.0, 6.0, 1201)
    path = 0.015 * (1.0 + t) * np.sin(2.0 * np.pi * t) + 0.01 * np.sin(9.0 * t)
    epp = drive(ElasticPerfectlyPlastic(K, FY), path)
    rule = drive(PushoverHysteresis(bilinear_backbone(K, FY, 0.0, 1.0)), path)
    np.testing.assert_allclose(rule, epp, rtol=0.0, atol=1e-6)
    assert max(epp) == pytest.approx(FY) and min(epp) == pytest.approx(-FY)


# --- Cross-check against Appendix A's MATLAB state machine ------------------------------------

def matlab_force(d_curve: np.ndarray, r_curve: np.ndarray, disp: float) -> float:
    """MATLAB ``force(D, R, disp)``: linear interpolation, the last matching segment wins."""
    r = None
    for j in range(len(r_curve) - 1):
        if d_curve[j] <= disp <= d_curve[j + 1]:
            r = r_curve[j] + (disp - d_curve[j]) / (d_curve[j + 1] - d_curve[j]) * (
                r_curve[j + 1] - r_curve[j])
    assert r is not None, f'MATLAB force() has no value at {disp}'
    return r


def matlab_states(d_curve: np.ndarray, r_curve: np.ndarray, x: np.ndarray, v: np.ndarray
                  ) -> tuple[np.ndarray, set[int]]:
    """Appendix A's ``loop`` 1..6 state machine, fed the sampled displacement and velocity.

    The Newmark update is replaced by the given samples; the force logic is line by line.
    """
    kini = (r_curve[1] - r_curve[0]) / (d_curve[1] - d_curve[0])

    def force(disp: float) -> float:
        return matlab_force(d_curve, r_curve, disp)

    loop, xpivot1 = 1, 0.0
    xmax = fmax = xpivot = xmin = fmin = xp = fp = xp1 = fp1 = math.nan
    fs = [kini * x[0]]
    visited = {1}
    for i in range(len(x) - 1):
        xi, vi = x[i + 1], v[i + 1]
        if loop == 1:
            f = force(xi - xpivot1)
            if vi <= 0:
                loop, xmax, fmax = 2, xi, f
                xpivot = xmax - fmax / kini
        elif loop == 2:
            f = fmax - kini * (xmax - xi)
            if xi <= xpivot and vi >= 0:
                loop = 4
                f = -force(xpivot - xi)
                xmin, fmin = xi, f
                xpivot1 = xmin - fmin / kini
            elif xi <= xpivot:
                loop = 3
                f = -force(xpivot - xi)
            elif vi >= 0:
                loop, xp, fp = 5, xi, f
        elif loop == 3:
            f = -force(xpivot - xi)
            if vi >= 0:
                loop, xmin, fmin = 4, xi, f
                xpivot1 = xmin - fmin / kini
        elif loop == 4:
            f = fmin + kini * (xi - xmin)
            if xi >= xpivot1 and vi <= 0:
                loop = 2
                f = force(xi - xpivot1)
                xmax, fmax = xi, f
                xpivot = xmax - fmax / kini
            elif xi >= xpivot1:
                loop = 1
                f = force(xi - xpivot1)
            elif vi <= 0:
                loop, xp1, fp1 = 6, xi, f
        elif loop == 5:
            f = fp + kini * (xi - xp)
            if xi >= xmax and vi <= 0:
                loop = 2
                f = force(xi - xpivot1)
                xmax, fmax = xi, f
                xpivot = xmax - fmax / kini
            elif xi >= xmax:
                loop = 1
                f = force(xi - xpivot1)
            elif vi <= 0:
                loop = 2
        else:
            f = fp1 - kini * (xp1 - xi)
            if xi <= xmin and vi >= 0:
                loop = 4
                f = -force(xpivot - xi)
                xmin, fmin = xi, f
                xpivot1 = xmin - fmin / kini
            elif xi <= xmin:
                loop = 3
                f = -force(xpivot - xi)
            elif vi >= 0:
                loop = 4
                xpivot1 = xmin - fmin / kini
        fs.append(f)
        visited.add(loop)
    return np.array(fs), visited


# Pushover with hardening then P-delta softening, roughly the thesis's column (k_ini 312.5 kN/m).
PUSH_D = np.array([0.0, 0.0384, 0.15, 0.4, 1.2])
PUSH_R = np.array([0.0, 12000.0, 13500.0, 12500.0, 9000.0])


def assert_signs_agree(x: np.ndarray, v: np.ndarray) -> None:
    """Precondition: the velocity sign at sample i is the sign of x[i+1] - x[i] (i >= 1)."""
    increment = np.diff(x)[1:]
    assert np.all(v[1:] != 0.0)
    assert np.array_equal(v[1:-1] > 0.0, increment > 0.0)


def compare_with_matlab(x: np.ndarray, v: np.ndarray) -> set[int]:
    assert_signs_agree(x, v)
    expected, visited = matlab_states(PUSH_D, PUSH_R, x, v)
    model = PushoverHysteresis(Backbone(PUSH_D, PUSH_R))
    got = [0.0, *drive(model, x[1:])]
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-8)
    return visited


def test_matches_matlab_on_growing_sinusoid() -> None:
    # x = A(t) sin(w t), A = a0 exp(g t): every turning point satisfies tan(w t) = -w/g, i.e.
    # lies delta = atan(g/w)/w after the quarter periods. The grid puts each turning point
    # 0.75 dt after a sample, where the velocity and the next increment have the same sign.
    w, n_per, cycles = 2.0 * np.pi, 40, 6
    dt = 1.0 / n_per
    g = math.log(0.25 / 0.01) / cycles
    delta = math.atan(g / w) / w
    t = np.concatenate([[0.0], (np.arange(1, cycles * n_per) - 0.75) * dt + delta])
    amplitude = 0.01 * np.exp(g * t)
    x = amplitude * np.sin(w * t)
    v = amplitude * (g * np.sin(w * t) + w * np.cos(w * t))
    x[0] = v[0] = 0.0
    visited = compare_with_matlab(x, v)
    assert visited == {1, 2, 3, 4}
    assert x.max() > 0.15 and x.min() < -0.2


def test_matches_matlab_with_partial_reversals() -> None:
    # Half-cosine sweeps between turning points (a smooth, C1 history) whose durations are
    # whole steps; samples sit at (j + 0.25) dt so each turning point is 0.75 dt after one.
    # Small reversals on the elastic lines exercise MATLAB states 5 and 6.
    turns = [0.0, 0.03, -0.02, 0.06, 0.045, 0.08, 0.05, 0.065, -0.09, -0.07, -0.12, -0.1,
             -0.11, 0.04, 0.02, 0.16, -0.2]
    dt = 0.01
    xs, vs = [0.0], [0.0]
    start, j = 0, 0
    for a, b in zip(turns[:-1], turns[1:]):
        steps = round(40 * math.sqrt(abs(b - a) / 0.1))
        while j + 0.25 < start + steps:
            s = (j + 0.25 - start) / steps
            xs.append(a + (b - a) * (1.0 - math.cos(math.pi * s)) / 2.0)
            vs.append((b - a) * math.pi / (2.0 * steps * dt) * math.sin(math.pi * s))
            j += 1
        start += steps
    visited = compare_with_matlab(np.array(xs), np.array(vs))
    assert visited == {1, 2, 3, 4, 5, 6}
