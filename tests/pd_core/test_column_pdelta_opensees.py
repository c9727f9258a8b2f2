"""The column under a constant axial load against OpenSees (openseespy): P-Δ, El Centro.

Our side: the test file ``config/column_axial.yaml``'s column (m = 2543.4 kg, L = 2.0 m,
k_a = 3.402e7 N/m, P = 24,950 N held by a force-controlled vertical actuator, 5 % damping of
the unloaded k, El Centro 1940 NS, Newmark explicit, Δt = 0.01 s), run without ROS through
its ``column`` setup and the simulated ``column`` specimen (lateral force ``r_lat(u) +
k_a v u / L``).

OpenSees (an independent implementation, in a child process): a 2-D column (``ndf 3``) fixed
at the base, its top at ``(0, L)`` with the rotation restrained (so the lateral DOF is the
only dynamic one: a guided cantilever of lateral stiffness ``12 E I / L³``), an
``elasticBeamColumn`` of axial stiffness ``E A / L = k_a`` with a ``PDelta`` ``geomTransf``
(its geometric stiffness ``N / L``), the load ``P`` applied as a nodal load in a static
gravity step and held with ``loadConst``; mass ``m`` at the top (both translations: the
vertical one stays at rest at ``v = −P/k_a``), mass-proportional damping ``a0 = 2 ζ ω``
(``ω = sqrt(k/m)``, the same ``c = 2 ζ m ω`` as ours), ``UniformExcitation`` with the same
resampled record, ``integrator NewmarkExplicit 0.5`` (``algorithm Linear``): our
``newmark_explicit`` recursion. A nonlinear lateral law is a ``zeroLength`` spring at the top
(``ElasticPP`` or ``Steel01``, the same bounding-line laws as our ``epp`` and ``bilinear``)
beside a beam of negligible bending stiffness (``12 E I / L³ = 1e-10 k``).

Tolerances (max |difference| of the lateral displacement history over the peak):

* linear actuator geometry, elastic or ElasticPP lateral law: 1e-8 (measured 3.4e-12 elastic,
  5.5e-10 ElasticPP: the same recursion, round-off and yield-point round-off only; the
  bilinear/Steel01 law with the linear geometry measures 5.4e-10 too);
* the example's exact (nonlinear) actuator geometry with the thesis's bilinear law (b = 0.01,
  Steel01): 1e-4 — the tilted vertical actuator holds ``P`` along its own line, so the
  vertical basic force is ``P cos θ`` (θ ≈ u / L_v, up to 0.025 here) and the tilted
  horizontal actuator adds ``(v / L_h) f_h`` to it; measured 6.3e-5. That holds at El Centro
  ×1 only: at ×2 the axial force falls 0.34 % below P and the difference is 2.0e-3
  (``test_exact_geometry_at_large_drift_is_not_a_constant_axial_load``).

``python -m pytest -q -s tests/pd_core/test_column_pdelta_opensees.py`` prints them.

Skipped only if openseespy cannot be imported (see tests/support/opensees_material.py).
"""

from __future__ import annotations

import copy
import csv
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pd_common.config import load_yaml
from pd_core.run.runner import run_offline
from pd_core.run.test_file import from_dict
from support.opensees_material import opensees_available
from support.opensees_script import opensees_script, run_opensees

CONFIG = (Path(__file__).resolve().parents[2] / 'src' / 'pd_integrator' / 'config'
          / 'column_axial.yaml')
M = 2543.4
K = 312559.0
FY = 10000.0
L = 2.0
K_A = 3.402e7
P = 24950.0
ZETA = 0.05
E = 2.1e9  # Pa: only E·A and E·I matter

pytestmark = pytest.mark.skipif(not opensees_available(),
                                reason='openseespy cannot be imported')

OPENSEES_SCRIPT = opensees_script(r'''
L, E = spec['L'], spec['E']
ops.wipe()
ops.model('basic', '-ndm', 2, '-ndf', 3)
ops.node(1, 0.0, 0.0)
ops.fix(1, 1, 1, 1)
ops.node(2, 0.0, L)
ops.fix(2, 0, 0, 1)                      # top rotation restrained: a guided cantilever
ops.mass(2, spec['m'], spec['m'], 0.0)
ops.geomTransf('PDelta', 1)
area = spec['k_a'] * L / E
inertia = spec['k_bending'] * L ** 3 / (12.0 * E)
ops.element('elasticBeamColumn', 1, 1, 2, area, E, inertia, 1)
if spec['material']:
    ops.node(3, 0.0, L)
    ops.fix(3, 1, 1, 1)
    ops.uniaxialMaterial(*spec['material'])
    ops.element('zeroLength', 2, 3, 2, '-mat', spec['material'][1], '-dir', 1)
gravity_step([[2, 0.0, -spec['P'], 0.0]])  # P as a nodal load, one static step, then held
v0 = ops.nodeDisp(2, 2)
ops.wipeAnalysis()
ops.timeSeries('Path', 2, '-dt', spec['dt'], '-values', *spec['record'], '-factor', 1.0)
ops.pattern('UniformExcitation', 2, 1, '-accel', 2)
transient_setup('explicit', [spec['a0'], 0.0, 0.0, 0.0])
history = [ops.nodeDisp(2, 1)]
for _ in range(spec['steps']):
    if ops.analyze(1, spec['dt']) != 0:
        sys.exit('analysis failed')
    history.append(ops.nodeDisp(2, 1))
print(json.dumps({'u': history, 'v0': v0}))
''')


def our_run(tmp_path: Path, lateral: dict[str, Any], geometry: str):
    """The example's column, with ``lateral`` and the setup's ``geometry``, run without ROS."""
    raw = load_yaml(CONFIG.read_text(encoding='utf-8'))
    element = raw['structure']['elements'][0]
    element['setup']['geometry'] = geometry
    raw['sites']['lab']['specimen']['column']['lateral'] = lateral
    definition = from_dict(copy.deepcopy(raw), source=CONFIG.name, base_dir=CONFIG.parent)
    name = f'{lateral["model"]}-{geometry}'
    return definition, run_offline(definition, tmp_path / name, figures=False)


def opensees_run(definition, material: list[Any] | None) -> dict[str, Any]:
    """OpenSees's lateral displacement history of the same column (module docstring)."""
    omega = float(np.sqrt(K / M))
    spec = {'L': L, 'E': E, 'm': M, 'k_a': K_A, 'P': P,
            'k_bending': 1e-10 * K if material else K, 'material': material,
            'dt': definition.dt, 'record': np.asarray(definition.ground_acceleration).tolist(),
            'a0': 2.0 * ZETA * omega, 'steps': definition.n_steps}
    reference: dict[str, Any] = run_opensees(OPENSEES_SCRIPT, spec)
    return reference


@pytest.mark.parametrize(('lateral', 'material', 'geometry', 'tolerance'), [
    ({'model': 'elastic', 'stiffness': K}, None, 'linear', 1e-8),
    ({'model': 'epp', 'stiffness': K, 'yield_force': FY},
     ['ElasticPP', 1, K, FY / K], 'linear', 1e-8),
    ({'model': 'bilinear', 'stiffness': K, 'yield_force': FY, 'hardening_ratio': 0.01},
     ['Steel01', 1, FY, K, 0.01], 'nonlinear', 1e-4),
], ids=['elastic', 'epp', 'example-bilinear-exact-geometry'])
def test_column_pdelta_matches_opensees(tmp_path: Path, lateral: dict[str, Any],
                                        material: list[Any] | None, geometry: str,
                                        tolerance: float) -> None:
    definition, result = our_run(tmp_path, lateral, geometry)
    reference = opensees_run(definition, material)
    assert reference['v0'] == pytest.approx(-P / K_A, rel=1e-12)
    theirs = np.array(reference['u'])
    history = result.session.history
    ours = history.displacement[:history.n_committed, 0]
    assert ours.shape == theirs.shape
    peak = float(np.max(np.abs(theirs)))
    assert peak > 0.02
    error = float(np.max(np.abs(ours - theirs))) / peak
    print(f'{lateral["model"]}/{geometry}: max |ours - OpenSees| / peak = {error:.3g} '
          f'(peak {peak * 1e3:.3f} mm)')
    assert error < tolerance
    if material:  # the column yields
        assert np.max(np.abs(theirs)) > 1.5 * FY / K


def test_exact_geometry_at_large_drift_is_not_a_constant_axial_load(tmp_path: Path) -> None:
    """The 6.3e-5 above holds at El Centro ×1 only. The example's vertical actuator holds P
    along its own, tilting line: the column's axial (basic vertical) force is
    ``−P (L_v − v)/|d_v| + f_h v/|d_h|`` (d: each actuator's pin-to-top vector), which at
    El Centro ×2 (drift 0.16 m) falls 0.34 % below P, and the lateral history leaves OpenSees's
    constant-P column by 2.0e-3 of the peak."""
    raw = load_yaml(CONFIG.read_text(encoding='utf-8'))
    setup = raw['structure']['elements'][0]['setup']
    assert setup.get('geometry', 'nonlinear') == 'nonlinear'
    raw['sites']['lab']['specimen']['column']['lateral'] = {
        'model': 'bilinear', 'stiffness': K, 'yield_force': FY, 'hardening_ratio': 0.01}
    raw['sites']['lab'].pop('bridge', None)  # the bridge's limits are not the question here
    raw['ground_motion']['scale'] = 2.0 * float(raw['ground_motion'].get('scale', 1.0))
    definition = from_dict(copy.deepcopy(raw), source=CONFIG.name, base_dir=CONFIG.parent)
    result = run_offline(definition, tmp_path / 'x2', figures=False)
    with (tmp_path / 'x2' / 'actuators.csv').open(encoding='utf-8') as handle:
        rows = list(csv.DictReader(handle))
    u, v, axial, f_h = (np.array([float(row[key]) for row in rows]) for key in (
        'column.u', 'column.v', 'column.v_force', 'force_horizontal'))
    l_v, l_h = float(setup['vertical_length']), float(setup['horizontal_length'])
    expected = -P * (l_v - v) / np.hypot(u, l_v - v) + f_h * v / np.hypot(u + l_h, v)
    np.testing.assert_allclose(axial, expected, rtol=0, atol=1e-9 * P)
    drop = 1.0 - float(np.min(np.abs(axial))) / P
    peak_drift = float(np.max(np.abs(u)))
    assert peak_drift > 0.15
    assert drop == pytest.approx(1.0 - math.cos(math.atan(peak_drift / l_v)), rel=0.1)
    assert drop > 0.003
    reference = np.array(opensees_run(definition, ['Steel01', 1, FY, K, 0.01])['u'])
    history = result.session.history
    ours = history.displacement[:history.n_committed, 0]
    error = float(np.max(np.abs(ours - reference))) / float(np.max(np.abs(reference)))
    print(f'x2 exact geometry: axial force {drop * 100:.2f} % below P at drift '
          f'{peak_drift * 1e3:.1f} mm; max |ours - OpenSees| / peak = {error:.3g}')
    assert 1e-3 < error < 5e-3
