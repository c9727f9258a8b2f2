"""Softening specimens: bilinear with a negative post-yield slope and a strength floor, and the
pushover rule with kinematic memory (hand-computed points, envelope bounds, OpenSees Steel01)."""

from __future__ import annotations

import numpy as np
import pytest
from tests.support.hysteresis import drive
from tests.support.opensees_material import opensees_available, opensees_forces

from pd_common.specimen import (
    Backbone,
    BilinearKinematic,
    HysteresisError,
    PushoverHysteresis,
    bilinear_backbone,
)

K = 1.0e5     # N/m
FY = 2.0e3    # N: d_y = 0.02 m
B = -0.05     # post-yield slope -5000 N/m
FR = 400.0    # N: the descending line reaches the floor at 0.02 + 1600/5000 = 0.34 m


def test_softening_bilinear_with_floor_hand_computed() -> None:
    model = BilinearKinematic(K, FY, B, FR)
    path = [0.01, 0.02, 0.1, 0.3, 0.34, 0.5, 0.45, 0.3, 0.0, -0.1, -0.5, 0.0, 0.5, 0.8]
    expected = [
        1000.0,             # elastic
        2000.0,             # yield
        1600.0,             # descending line 2000 - 5000 (0.1 - 0.02)
        600.0,              # 2000 - 5000 * 0.28
        400.0,              # reaches the floor
        400.0,              # on the floor: x_p = 0.5 - 0.004 = 0.496
        -4350.0,            # trial -4600 beyond the lower line -2000 - 5000 (0.45 + 0.02)
        -3600.0,            # on the lower line: -2000 - 5000 * 0.32
        -2100.0,            # -2000 - 5000 * 0.02
        -1600.0,            # -2000 + 5000 * 0.08
        -400.0,             # lower line floor at -400
        2100.0,             # trial 1e5 (0 + 0.496 ...) beyond the upper line 2000 + 5000 * 0.02
        400.0,              # upper line under the floor again
        400.0,
    ]
    assert drive(model, path) == pytest.approx(expected, abs=1e-9)


def test_softening_bilinear_without_floor_crosses_zero_at_closed_form() -> None:
    model = BilinearKinematic(K, FY, B)
    zero = FY / K + FY / (-B * K)            # 0.42 m
    forces = drive(model, [0.1, zero, zero + 0.1])
    assert forces == pytest.approx([1600.0, 0.0, -500.0], abs=1e-9)
    # a reversal there (x_p = 0.525) meets the lower line -2000 - 5000 (0.42 + 0.02)
    assert model.set_trial_displacement(zero) == pytest.approx(-4200.0, abs=1e-9)


def test_bilinear_floor_under_a_strength_floor_is_elastic() -> None:
    model = BilinearKinematic(K, FY, B, FR)
    drive(model, [0.5])                                 # on the floor, x_p = 0.496
    # within the floor the spring unloads and reloads elastically, up to the floor again
    assert drive(model, [0.499, 0.4995, 0.52]) == pytest.approx(
        [300.0, 350.0, 400.0], abs=1e-9)


@pytest.mark.parametrize(('args', 'message'), [
    ((K, FY, -1.0), r'hardening_ratio must be in \(-1, 1\)'),
    ((K, FY, 0.02, 100.0), 'residual_force needs a negative hardening_ratio'),
    ((K, FY, -0.02, 2500.0), r'residual_force must be in \[0, yield_force=2000\]'),
    ((K, FY, -0.02, -1.0), 'residual_force must be in'),
])
def test_softening_bilinear_validation(args: tuple[float, ...], message: str) -> None:
    with pytest.raises(HysteresisError, match=message):
        BilinearKinematic(*args)


@pytest.mark.skipif(not opensees_available(), reason='openseespy cannot be imported')
@pytest.mark.parametrize('b', [0.02, -0.02, -0.0100557, -0.08])
def test_bilinear_equals_opensees_steel01(b: float) -> None:
    """Steel01 (no isotropic hardening) is the same bounding-line model, softening included."""
    t = np.linspace(0.0, 6.0, 1201)
    history = 0.08 * (t / 6.0 + 0.2) * np.sin(2.0 * np.pi * t)
    reference = opensees_forces(['Steel01', 1, FY, K, b], history)
    ours = np.array(drive(BilinearKinematic(K, FY, b), history))
    assert np.max(np.abs(ours - reference)) <= 1e-9 * np.max(np.abs(reference))
    assert np.max(np.abs(reference)) > FY * 1.05 or b < 0.0     # it did yield and cycle


# --- backbone ------------------------------------------------------------------------------

def test_trilinear_backbone_points() -> None:
    backbone = bilinear_backbone(K, FY, B, 1.0, residual_force=FR)
    np.testing.assert_allclose(backbone.displacement, [0.0, 0.02, 0.34, 1.0])
    np.testing.assert_allclose(backbone.force, [0.0, FY, FR, FR])
    # a floor beyond d_max: the curve ends on the descent
    short = bilinear_backbone(K, FY, B, 0.2, residual_force=FR)
    np.testing.assert_allclose(short.force, [0.0, FY, FY + B * K * 0.18])
    # the thesis's column: k_ini 312.559 kN/m, negative post-yield ratio from its P-delta fit
    column = bilinear_backbone(312559.0, 3772.0, -0.0100557, 0.5)
    assert column.force[-1] < column.force[1]


# --- pushover rule with kinematic memory ----------------------------------------------------

def softening_pushover(memory: str) -> PushoverHysteresis:
    return PushoverHysteresis(bilinear_backbone(K, FY, B, 1.0, residual_force=FR), memory=memory)


@pytest.mark.parametrize('memory', ['none', 'kinematic'])
def test_pushover_memory_hand_computed(memory: str) -> None:
    model = softening_pushover(memory)
    # 0.1 on the backbone: 2000 - 5000 * 0.08 = 1600; reversal: z = 0.1 - 0.016 = 0.084
    # and (d- = 0 for both rules) P- = 0.084: at 0.05, -B(0.034) = -1930; at -0.1, -B(0.184)
    forces = drive(model, [0.1, 0.05, -0.1])
    assert forces == pytest.approx([1600.0, -1930.0, -1180.0], abs=1e-9)
    # reversal at (-0.1, -1180): z = -0.0882
    f0 = model.set_trial_displacement(0.0)
    if memory == 'none':
        # the thesis's rule restarts the positive backbone at P+ = z: B(0.0882) = 1659 N,
        # more than the 1600 N the positive direction had left
        assert f0 == pytest.approx(2000.0 - 5000.0 * (0.0882 - 0.02), abs=1e-9)
    else:
        # kinematic memory: d+ = 0.1, exit x_hi = z + B(0.1)/k = -0.0722, P+ = -0.1722:
        # B(0.1722) = 1239 N, further down the same descent
        assert f0 == pytest.approx(2000.0 - 5000.0 * (0.1722 - 0.02), abs=1e-9)
        model.commit()
        assert model.excursions == pytest.approx((0.1, 0.184))
        assert model.pivots == pytest.approx((-0.1722, 0.084))


def strength_left(backbone: Backbone, d: float) -> float:
    """The largest force the backbone has at ``d`` or further along it."""
    further = backbone.force[backbone.displacement > d]
    return max(backbone.force_at(d, 'plateau'), float(further.max()) if further.size else -np.inf)


def test_pushover_kinematic_memory_keeps_cycles_on_the_envelope() -> None:
    """Growing cycles on a hardening-then-softening curve: no cycle climbs the peak again."""
    backbone = Backbone(np.array([0.0, 0.01, 0.03, 0.08, 0.2]),
                        np.array([0.0, 3000.0, 3772.0, 2500.0, 1500.0]), source='p-delta fit')
    peak = 3772.0
    t = np.linspace(0.0, 8.0, 4001)
    history = 0.12 * (t / 8.0) * np.sin(2.0 * np.pi * t)
    late = t > 6.0
    for memory in ('none', 'kinematic'):
        model = PushoverHysteresis(backbone, beyond='plateau', memory=memory)
        forces = []
        for x in history:
            forces.append(model.set_trial_displacement(x))
            model.commit()
            if memory == 'kinematic':
                d_pos, d_neg = model.excursions
                assert -strength_left(backbone, d_neg) - 1e-9 <= forces[-1]
                assert forces[-1] <= strength_left(backbone, d_pos) + 1e-9
        magnitude = np.abs(np.array(forces))
        assert magnitude.max() <= peak + 1e-9
        if memory == 'kinematic':
            assert magnitude[late].max() < 0.75 * peak      # the descent is kept
        else:
            assert magnitude[late].max() > 0.99 * peak      # the thesis's rule climbs it again


def test_pushover_memory_none_is_the_default_and_unknown_is_refused() -> None:
    assert PushoverHysteresis(bilinear_backbone(K, FY, 0.01)).memory == 'none'
    with pytest.raises(HysteresisError, match='memory must be one of none, kinematic'):
        PushoverHysteresis(bilinear_backbone(K, FY, 0.01), memory='isotropic')


def test_pushover_kinematic_random_histories_stay_within_envelope() -> None:
    backbone = bilinear_backbone(K, FY, B, 1.0, residual_force=FR)
    rng = np.random.default_rng(7)
    for _ in range(20):
        model = PushoverHysteresis(backbone, memory='kinematic')
        for x in np.cumsum(rng.normal(0.0, 0.02, 300)):
            f = model.set_trial_displacement(x)
            model.commit()
            d_pos, d_neg = model.excursions
            low, high = -strength_left(backbone, d_neg), strength_left(backbone, d_pos)
            assert low - 1e-9 <= f <= high + 1e-9
