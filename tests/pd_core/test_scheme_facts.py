"""The per-scheme facts live on the scheme's class, and they are true.

``accuracy_order`` is checked against the observed convergence of an undamped linear SDOF
started with a velocity (no initial acceleration: the definition of the model-based schemes'
order, see ``schemes/model_based.py``), against the exact ``x = v0/ω sin ωt``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pd_core.dynamics.stability import check_stability, period_distortion
from pd_core.schemes import SCHEMES, Integrator, make_integrator, numerical_schemes
from pd_core.schemes.base import SOFTENING_EXPLICIT

M, K = 1.0, 4.0 * math.pi**2
OMEGA = math.sqrt(K / M)
V0, DURATION = 1.0e-2, 2.3


def largest_error(name: str, dt: float) -> float:
    """The largest displacement error over ``DURATION``."""
    integrator = make_integrator(name, mass=M, damping=0.0, dt=dt, initial_stiffness=K)
    integrator.initialize(0.0, V0, 0.0, 0.0)
    error = 0.0
    for i in range(round(DURATION / dt)):
        while True:
            x = float(np.asarray(integrator.predict()).reshape(-1)[0])
            integrator.correct(K * x, 0.0)
            if integrator.phase == 'corrected':
                break
        integrator.commit()
        exact = V0 / OMEGA * math.sin(OMEGA * (i + 1) * dt)
        error = max(error, abs(float(np.asarray(integrator.x).reshape(-1)[0]) - exact))
    return error


@pytest.mark.parametrize('name', numerical_schemes())
def test_the_declared_order_of_accuracy_is_observed(name: str) -> None:
    coarse, fine = largest_error(name, 0.002), largest_error(name, 0.001)
    observed = math.log2(coarse / fine)
    assert observed == pytest.approx(SCHEMES[name].accuracy_order, abs=0.15)


@pytest.mark.parametrize('name', numerical_schemes())
def test_every_scheme_states_its_facts(name: str) -> None:
    cls = SCHEMES[name]
    assert issubclass(cls, Integrator) and cls.name == name
    assert cls.accuracy_order in (1, 2)
    assert cls.softening_note
    assert cls.stability_limit > 0.0
    for parameter in cls.PARAMETERS:
        assert parameter.bounded or parameter.boolean


def test_the_stability_check_reads_the_facts_from_the_scheme() -> None:
    report = check_stability('modified_newmark', M, K, 0.01, softening=True)
    assert report.limit == SCHEMES['modified_newmark'].stability_limit
    assert report.message.endswith(f'; softening: {SOFTENING_EXPLICIT}')
    # Newmark explicit's closed form (eq. 3.19) is a method of the scheme.
    omega_dt = 1.2
    closed = SCHEMES['newmark_explicit'].numerical_frequency(omega_dt)
    assert closed is not None
    assert period_distortion(omega_dt) == omega_dt / closed - 1.0
    assert SCHEMES['alpha_os'].numerical_frequency(omega_dt) is None
    assert math.isnan(period_distortion(omega_dt, 'no_such_scheme'))
