"""The column specimen (a cantilever with P-Δ in basic coordinates u, v) and its config.

References are closed forms (R(u, v) = [r_lat(u) + k_a v u / L, k_a v], the lateral stiffness
k − P/L) and independent constructions (the column setup's actuators built from their pins
and attachment points here, not from the setup's code).
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from pd_common.errors import SpecimenConfigError, SpecimenError
from pd_common.experimental import ColumnSetup
from pd_common.specimen import (
    BilinearKinematic,
    BoucWen,
    ColumnSpecimen,
    Elastic,
    SpecimenServer,
    load_site_server,
    model_from_config,
    specimen_from_config,
)
from support.sections import INLINE_GROUND_MOTION, ONE_DOF_STRUCTURE

K = 1.0e6          # lateral stiffness [N/m]
KA = 1.0e9         # axial stiffness [N/m]
L = 3.0            # cantilever height [m]
LH, LV = 1.5, 2.0  # the column setup's horizontal and vertical actuator lengths [m]
FORCE, DISPLACEMENT = 1, 0
LOADS = (0.0, 24950.0, 1.0e5, 2.9e6, 4.0e6)   # the last one beyond k L (negative stiffness)


def column(lateral: Any = None, axial: float = KA) -> ColumnSpecimen:
    return ColumnSpecimen(Elastic(K) if lateral is None else lateral, L, axial)


# -- the model ---------------------------------------------------------------------------------
def test_restoring_force_is_the_closed_form_and_trials_do_not_commit() -> None:
    specimen = column(BilinearKinematic(K, 3.0e4, 0.02))
    u, v = 0.01, -2.5e-5
    force = specimen.restoring_force([u, v])
    assert force[0] == pytest.approx(K * u + KA * v * u / L, rel=1e-14)
    assert force[1] == pytest.approx(KA * v, rel=1e-14)
    assert specimen.axial_force() == pytest.approx(-25000.0, rel=1e-12)
    np.testing.assert_array_equal(specimen.committed_restoring_force(), [0.0, 0.0])
    specimen.revert_to_last_commit()
    assert specimen.axial_force() == 0.0
    specimen.restoring_force([0.05, v])       # past yield (0.03 m): 3e4 + 0.02 K 0.02 = 30400
    specimen.commit()
    expected = 3.0e4 + 0.02 * K * 0.02 + KA * v * 0.05 / L
    assert specimen.committed_restoring_force()[0] == pytest.approx(expected, rel=1e-12)
    assert specimen.committed_displacement() == (0.05, v)
    # the lateral model keeps its history: unloading by 0.01 is elastic from the committed state
    assert specimen.restoring_force([0.04, 0.0])[0] == pytest.approx(30400.0 - K * 0.01)
    specimen.reset()
    np.testing.assert_array_equal(specimen.committed_restoring_force(), [0.0, 0.0])
    np.testing.assert_array_equal(specimen.initial_stiffness_matrix(), np.diag([K, KA]))


@pytest.mark.parametrize('lateral', [
    Elastic(K),
    BilinearKinematic(K, 3.0e4, -0.05),
    BoucWen(stiffness=K, post_yield_ratio=0.05, exponent=1.0, beta=25.0, gamma=25.0),
], ids=['elastic', 'bilinear_softening', 'bouc_wen'])
def test_tangent_is_the_derivative_of_the_trial_force(lateral: Any) -> None:
    specimen = column(lateral)
    u, v = 0.012, -3.0e-5
    tangent = specimen.tangent([u, v])
    h = 1.0e-7
    for j in range(2):
        ahead = np.array([u, v])
        behind = np.array([u, v])
        ahead[j] += h
        behind[j] -= h
        column_j = (specimen.restoring_force(ahead) - specimen.restoring_force(behind)) / (2 * h)
        np.testing.assert_allclose(tangent[:, j], column_j, rtol=1e-5, atol=1e-3 * K)
    # the tangent left the trial at (u, v)
    assert specimen.lateral.trial_displacement == u
    assert tangent[1, 0] == 0.0 and tangent[1, 1] == KA


def test_bad_construction_is_one_line() -> None:
    with pytest.raises(SpecimenError, match=r'^column: height must be a positive'):
        ColumnSpecimen(Elastic(K), 0.0, KA)
    with pytest.raises(SpecimenError, match=r'^column: lateral must be a HysteresisModel'):
        ColumnSpecimen('elastic', L, KA)  # type: ignore[arg-type]
    with pytest.raises(SpecimenError, match=r'^column: displacement must have shape'):
        column().restoring_force([0.1])


# -- P-Δ through the server: k − P/L -----------------------------------------------------------
@pytest.mark.parametrize('load', LOADS)
def test_one_to_one_lateral_stiffness_is_k_minus_p_over_l(load: float) -> None:
    """The vertical DOF holds −P (compression, v up), the lateral one goes to u."""
    server = SpecimenServer(column())
    for step, u in enumerate((0.002, -0.004, 0.001), start=1):
        answer = server.handle('t', step, (u, 0.0), control_mode=(DISPLACEMENT, FORCE),
                               target_force=(0.0, -load))
        assert answer is not None and answer.status.name == 'OK', answer
        assert answer.measured_displacement[0] == u
        assert answer.restoring_force[0] == pytest.approx((K - load / L) * u, rel=1e-11)
        assert answer.restoring_force[1] == pytest.approx(-load, rel=1e-10, abs=1e-6)
        # the vertical stroke the specimen takes under P: v = −P / k_a
        assert answer.measured_displacement[1] == pytest.approx(-load / KA, rel=1e-10,
                                                                abs=1e-18)


def _unit(vector: np.ndarray) -> np.ndarray:
    return vector / math.hypot(*vector)


@pytest.mark.parametrize('load', LOADS[:4])
def test_column_setup_lateral_stiffness_and_the_vertical_actuators_component(load: float
                                                                             ) -> None:
    """Horizontal actuator in displacement control, vertical one holding +P (pushing down)."""
    server = SpecimenServer(column(), setup=ColumnSetup(LH, LV))
    stroke = 1.0e-4
    answer = server.handle('t', 1, (stroke, 0.0), control_mode=(DISPLACEMENT, FORCE),
                           target_force=(0.0, load))
    assert answer is not None and answer.status.name == 'OK', answer
    u, v = server.basic
    top = np.array([u, v])
    pin_h, pin_v = np.array([-LH, 0.0]), np.array([0.0, LV])
    # strokes from the points: the horizontal one at its target, the vertical one geometric
    assert math.hypot(*(top - pin_h)) - LH == pytest.approx(stroke, rel=1e-12)
    assert answer.measured_displacement[0] == pytest.approx(stroke, rel=1e-12)
    assert answer.measured_displacement[1] == pytest.approx(math.hypot(*(top - pin_v)) - LV,
                                                            rel=1e-9, abs=1e-16)
    f_h, f_v = answer.restoring_force
    assert f_v == pytest.approx(load, rel=1e-10, abs=1e-6)
    # the column's axial compression is P up to the actuators' tilt: v ≈ −P / k_a
    assert v == pytest.approx(-load / KA, rel=1e-6, abs=1e-15)
    # basic forces: each actuator pushes the top along its pin-to-top direction
    basic = f_h * _unit(top - pin_h) + f_v * _unit(top - pin_v)
    # P-Δ with the column's axial force N (the actuators' vertical components): k + N / L
    assert basic[1] == pytest.approx(KA * v, rel=1e-9, abs=1e-6)
    assert basic[0] / u == pytest.approx(K + basic[1] / L, rel=1e-9)
    # N is −P up to the tilts: the vertical actuator's (P u² / 2ℓ_v²) and the horizontal one's
    # (|f_h| |v| / ℓ_h, the top moved down by v): k − P/L within that, ~1e-9 for small loads
    tilt = load * u ** 2 / (2 * LV ** 2) + abs(f_h) * abs(v) / LH
    assert abs(basic[0] / u - (K - load / L)) <= 1.01 * tilt / L + 1e-9 * K
    if load <= 1.0e5:
        assert basic[0] / u == pytest.approx(K - load / L, rel=3e-9)
    # the horizontal actuator's own force misses the vertical actuator's horizontal
    # component P u / ℓ_v (ℓ_v its length now), up to its own tilt f_h (1 − cos) ≈ f_h v²/2ℓ_h²
    assert basic[0] - f_h == pytest.approx(load * u / math.hypot(*(top - pin_v)), rel=1e-9,
                                           abs=abs(f_h) * v ** 2 / LH ** 2 + 1e-12)
    if 0.0 < load <= 1.0e5:  # ℓ_v ≈ L_v while the top moves down by much less than L_v
        assert basic[0] - f_h == pytest.approx(load * u / LV, rel=1e-4)


def test_softening_column_loses_its_lateral_capacity_earlier_under_axial_load() -> None:
    """Bilinear lateral model with a negative post-yield slope α k, pushed monotonically.

    Closed forms: the lateral force is r_lat(u) − P u / L; it peaks at the yield
    displacement u_y (the kink), at F_y − P u_y / L, then falls with the slope α k − P / L and
    reaches zero (no lateral capacity left: instability) at u_0 = F_y (1 − α) / (P / L − α k),
    earlier than without P, F_y (1 − α) / (−α k).
    """
    fy, alpha, load = 3.0e4, -0.05, 2.0e5
    u_y = fy / K

    def push(p: float) -> tuple[list[float], list[float]]:
        server = SpecimenServer(column(BilinearKinematic(K, fy, alpha)))
        us = [0.0005 * i for i in range(1, 1400)]
        forces = []
        for step, u in enumerate(us, start=1):
            answer = server.handle('t', step, (u, 0.0), control_mode=(DISPLACEMENT, FORCE),
                                   target_force=(0.0, -p))
            assert answer is not None and answer.status.name == 'OK', answer
            forces.append(answer.restoring_force[0])
        return us, forces

    def first_zero(us: list[float], forces: list[float]) -> float:
        for i in range(1, len(us)):
            if forces[i] <= 0.0 < forces[i - 1]:  # linear between the points: exact here
                return us[i - 1] + forces[i - 1] * (us[i] - us[i - 1]) / (forces[i - 1]
                                                                          - forces[i])
        return math.inf

    us, bare = push(0.0)
    _, loaded = push(load)
    for force in (bare, loaded):
        peak = int(np.argmax(force))
        assert us[peak] == pytest.approx(u_y)   # the tangent changes sign at the yield point
        assert all(b < a for a, b in zip(force[peak:], force[peak + 1:]))
    assert max(loaded) == pytest.approx(fy - load * u_y / L, rel=1e-9)
    slope = (loaded[-100] - loaded[-200]) / (us[-100] - us[-200])
    assert slope == pytest.approx(alpha * K - load / L, rel=1e-6)
    zero_bare = first_zero(us, bare)
    zero_loaded = first_zero(us, loaded)
    assert zero_loaded == pytest.approx(fy * (1 - alpha) / (load / L - alpha * K), rel=1e-9)
    assert zero_bare == pytest.approx(fy * (1 - alpha) / (-alpha * K), rel=1e-9)
    assert zero_loaded < 0.5 * zero_bare


def test_axial_load_turns_a_hardening_column_unstable() -> None:
    """A positive post-yield slope α k below P / L: the lateral force falls after the yield
    point under P (tangent α k − P / L < 0), never without it."""
    fy, alpha, load = 3.0e4, 0.02, 1.5e5   # P / L = 5e4 > α k = 2e4
    for p, falls in ((0.0, False), (load, True)):
        server = SpecimenServer(column(BilinearKinematic(K, fy, alpha)))
        forces = []
        for step in range(1, 200):
            answer = server.handle('t', step, (0.0005 * step, 0.0),
                                   control_mode=(DISPLACEMENT, FORCE), target_force=(0.0, -p))
            assert answer is not None
            forces.append(answer.restoring_force[0])
        tangents = np.diff(forces) / 0.0005
        assert tangents[0] == pytest.approx(K - p / L, rel=1e-9)
        assert bool(tangents[-1] < 0.0) is falls
        assert tangents[-1] == pytest.approx(alpha * K - p / L, rel=1e-6)


# -- config ------------------------------------------------------------------------------------
COLUMN = {'height': L, 'axial_stiffness': KA,
          'lateral': {'model': 'bilinear', 'stiffness': K, 'yield_force': 3.0e4,
                      'hardening_ratio': -0.01}}


def test_column_section_builds_the_model() -> None:
    model = model_from_config({'column': COLUMN}, base_dir=Path('.'), source='t.yaml',
                              dof_names=['u', 'v'])
    assert isinstance(model, ColumnSpecimen)
    assert isinstance(model.lateral, BilinearKinematic)
    assert (model.height, model.axial_stiffness) == (L, KA)
    assert model.lateral.hardening_ratio == -0.01


@pytest.mark.parametrize(('section', 'message'), [
    ({'column': {**COLUMN, 'height': -1.0}},
     't.yaml: specimen.column.height: must be a positive finite number, got -1'),
    ({'column': {**COLUMN, 'axial_stiffness': '1e9'}},
     't.yaml: specimen.column.axial_stiffness: must be a positive finite number'),
    ({'column': {**COLUMN, 'width': 1.0}}, "t.yaml: specimen.column: unknown key 'width'"),
    ({'column': {k: v for k, v in COLUMN.items() if k != 'lateral'}},
     "t.yaml: specimen.column: missing key 'lateral'"),
    ({'column': {**COLUMN, 'lateral': {'model': 'plastic'}}},
     't.yaml: specimen.column.lateral.model: must be one of'),
    ({'column': {**COLUMN, 'lateral': {'model': 'elastic'}}},
     "t.yaml: specimen.column.lateral: missing key 'stiffness'"),
    ({'column': COLUMN, 'elements': []},
     't.yaml: specimen: give either elements or column, not both'),
    ({'column': COLUMN, 'topology': 'independent'}, "t.yaml: specimen: unknown key 'topology'"),
    ({'column': 3.0}, 't.yaml: specimen.column: must be a mapping'),
])
def test_bad_column_section_is_one_line_naming_the_key(section: dict[str, Any], message: str
                                                       ) -> None:
    with pytest.raises(SpecimenConfigError) as error:
        model_from_config(section, base_dir=Path('.'), source='t.yaml', dof_names=['u', 'v'])
    assert str(error.value).startswith(message)
    assert '\n' not in str(error.value)


def test_specimen_from_config_sends_a_column_to_the_server() -> None:
    with pytest.raises(SpecimenConfigError, match=re.escape(
            't.yaml: specimen.column: a column specimen is simulated by the specimen server')):
        specimen_from_config({'column': COLUMN}, base_dir=Path('.'), source='t.yaml',
                             dof_names=['u', 'v'])


def test_a_sites_column_error_names_the_site(tmp_path: Path) -> None:
    path = tmp_path / 'column.yaml'
    path.write_text(yaml.safe_dump({
        'test': {'dt': 0.01}, 'structure': ONE_DOF_STRUCTURE,
        'ground_motion': INLINE_GROUND_MOTION, 'sites': {'lab': {'specimen': {
            'column': {**COLUMN, 'height': 0.0}}}}}), encoding='utf-8')
    with pytest.raises(SpecimenError) as error:
        load_site_server(path, 'lab')
    assert str(error.value).startswith('column.yaml: sites.lab.specimen.column.height: must be')
