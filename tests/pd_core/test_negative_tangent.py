"""Schemes on a negative tangent stiffness: they follow the physical divergence, no more.

A linear SDOF whose specimen has ``k_t < 0`` while the schemes use ``K_I > 0`` (a column past
its peak): the exact response from ``x_0`` at rest is ``A e^{λ1 t} + B e^{λ2 t}`` with
``m λ² + c λ + k_t = 0``. Every scheme must track that growth (a spurious numerical growth
or a damped-out divergence would both fail), which is what the stability report states.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pd_core.dynamics.stability import check_stability
from pd_core.schemes import SCHEMES, make_integrator, numerical_schemes

M, K_I, DT, T_END = 1.0, 39.478, 0.02, 3.0
C = 2.0 * 0.05 * math.sqrt(K_I * M)
X0 = 1.0e-3


def exact(kt: float, t: float) -> float:
    root = math.sqrt(C * C - 4.0 * M * kt)
    l1, l2 = (-C + root) / (2.0 * M), (-C - root) / (2.0 * M)
    a = X0 * (-l2) / (l1 - l2)
    return a * math.exp(l1 * t) + (X0 - a) * math.exp(l2 * t)


def simulate(name: str, kt: float) -> float:
    parameters = {'rho_b': 0.9} if name == 'explicit_generalized_alpha' else {}
    integrator = make_integrator(name, mass=M, damping=C, dt=DT, initial_stiffness=K_I,
                                 **parameters)
    integrator.initialize(X0, 0.0, 0.0, kt * X0)
    for _ in range(round(T_END / DT)):
        while True:
            x = float(np.asarray(integrator.predict()).reshape(-1)[0])
            integrator.correct(kt * x, 0.0)
            if integrator.phase == 'corrected':
                break
        integrator.commit()
    return float(np.asarray(integrator.x).reshape(-1)[0])


@pytest.mark.parametrize('ratio', [-0.02, -0.2])
@pytest.mark.parametrize('name', sorted(numerical_schemes()))
def test_schemes_follow_the_physical_divergence(name: str, ratio: float) -> None:
    kt = ratio * K_I
    growth = exact(kt, T_END) / X0
    assert growth > 1.3 if ratio == -0.2 else growth > 1.0   # it does diverge
    assert simulate(name, kt) / exact(kt, T_END) == pytest.approx(1.0, abs=0.03)


def test_every_scheme_states_its_tangent_assumption() -> None:
    assert all(cls.softening_note for cls in SCHEMES.values())
    report = check_stability('alpha_os', M, K_I, DT, softening=True)
    assert 'softening: its unconditional stability assumes K_t <= K_I' in report.message
    assert 'softening' not in check_stability('alpha_os', M, K_I, DT).message
