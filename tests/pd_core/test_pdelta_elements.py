"""P-Δ of the integrator's numerical elements (issue 16, item 3): beam-columns and springs.

* ``beam_column`` with ``geometry: pdelta`` (the chord's geometric stiffness, OpenSees's
  ``geomTransf PDelta``) or ``pdelta_consistent`` and a constant ``axial_load``;
* ``spring`` / ``story`` / ``nonlinear_spring`` with ``pdelta: {axial_load: P, height: L}``:
  force ``f(d) − P d / L``.

References, independent of the implementation:

* closed forms: the chord P-Δ cantilever ``3EI/L³ − P/L``; the guided cantilever
  ``12EI/L³ − P/L``; the exact lateral stiffness of a compressed cantilever
  ``P / (tan(αL)/α − L)``, ``α = sqrt(P/EI)`` (stability functions), which a mesh of
  consistent elements approaches; the period ``2π sqrt(m / (k − P/L))``;
* OpenSees (openseespy, in a child process): ``elasticBeamColumn`` with ``geomTransf
  PDelta``, the axial load a nodal load of a static gravity step held with ``loadConst``;
  statics, and El Centro 1940 NS (the shipped record, 5 s) with the same Newmark scheme
  (``NewmarkExplicit 0.5`` ↔ ``newmark_explicit``, ``Newmark 0.5 0.25`` with Newton ↔
  ``average_acceleration``). Tolerances are stated at each test;
  ``python -m pytest -q -s tests/pd_core/test_pdelta_elements.py`` prints the measured
  agreement.

The OpenSees tests are skipped only if openseespy cannot be imported.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pd_common.specimen.column import hysteresis_tangent
from pd_common.specimen.hysteresis import ElasticPerfectlyPlastic
from pd_core.dynamics.structure import modal_analysis
from pd_core.errors import ConfigError
from pd_core.model.elements import (
    PDeltaHysteresis,
    beam_column_2d_geometric_stiffness,
    beam_column_2d_stiffness,
    static_condensation,
)
from pd_core.run.loop import session as session_module
from pd_core.run.runner import run_offline
from pd_core.run.test_file import from_dict
from support.opensees_material import opensees_available
from support.opensees_script import opensees_script, run_opensees
from support.paths import REPO

RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / 'elcentro_1940_ns_chopra.csv'

E = 2.0e11          # Pa
A = 1.0e-2          # m²
I_SECTION = 1.0e-4  # m⁴
L = 3.0             # m
EI = E * I_SECTION

needs_opensees = pytest.mark.skipif(not opensees_available(),
                                    reason='openseespy cannot be imported')


def definition_of(elements: list[dict[str, Any]], *, dof_names: list[str], mass: list[float],
                  scheme: str = 'newmark_explicit', dt: float = 0.01, duration: float = 5.0,
                  damping: dict[str, Any] | None = None) -> Any:
    """A test file's definition around ``structure.elements`` (El Centro, units g)."""
    raw = {
        'test': {'id': 'pdelta', 'scheme': scheme, 'dt': dt, 'duration': duration},
        'structure': {'dof_names': dof_names, 'mass': mass,
                      'damping': damping if damping is not None else {'ratio': 0.0},
                      'elements': elements},
        'ground_motion': {'file': str(RECORD), 'units': 'g'},
    }
    return from_dict(copy.deepcopy(raw), source='pdelta.yaml', base_dir=REPO)


def cantilever(geometry: str | None, axial_load: float | None = None) -> dict[str, Any]:
    """A vertical cantilever of height L: fixed base, free top (u, v, r)."""
    element: dict[str, Any] = {'type': 'beam_column', 'name': 'column',
                               'dofs': [None, None, None, 'u', 'v', 'r'],
                               'coordinates': [[0.0, 0.0], [0.0, L]],
                               'E': E, 'A': A, 'I': I_SECTION}
    if geometry is not None:
        element['geometry'] = geometry
    if axial_load is not None:
        element['axial_load'] = axial_load
    return element


# --------------------------------------------------------------------------- beam-column


def test_linear_geometry_is_todays_element_bit_for_bit() -> None:
    xi, xj = (0.3, -0.2), (2.1, 2.7)
    default = beam_column_2d_stiffness(xi, xj, E, A, I_SECTION)
    explicit = beam_column_2d_stiffness(xi, xj, E, A, I_SECTION, geometry='linear')
    assert np.array_equal(default, explicit)
    # An independent construction of the classical matrix (Przemieniecki), then rotated.
    length = math.hypot(1.8, 2.9)
    c, s = 1.8 / length, 2.9 / length
    ea, k1, k2, k3, k4 = (E * A / length, 12 * EI / length**3, 6 * EI / length**2,
                          4 * EI / length, 2 * EI / length)
    local = np.array([[ea, 0, 0, -ea, 0, 0], [0, k1, k2, 0, -k1, k2], [0, k2, k3, 0, -k2, k4],
                      [-ea, 0, 0, ea, 0, 0], [0, -k1, -k2, 0, k1, -k2], [0, k2, k4, 0, -k2, k3]])
    r = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    t = np.block([[r, np.zeros((3, 3))], [np.zeros((3, 3)), r]])
    assert np.allclose(default, t.T @ local @ t, rtol=1e-13, atol=1e-6)
    # Through a test file: no geometry key and geometry: linear give the same model.
    plain = definition_of([cantilever(None)], dof_names=['u', 'v', 'r'], mass=[1e3, 1e3, 0.0])
    linear = definition_of([cantilever('linear')], dof_names=['u', 'v', 'r'],
                           mass=[1e3, 1e3, 0.0])
    assert np.array_equal(plain.initial_stiffness, linear.initial_stiffness)


@pytest.mark.parametrize('angle', [0.0, 0.4, math.pi / 2, 2.5, -1.1])
def test_chord_geometric_stiffness_in_global_axes(angle: float) -> None:
    """``K_g = (N/L) [[1, −1], [−1, 1]] ⊗ n nᵀ`` with ``n`` the unit normal of the chord."""
    p = 3.0e5
    xi = (1.0, 2.0)
    xj = (1.0 + L * math.cos(angle), 2.0 + L * math.sin(angle))
    normal = np.array([-math.sin(angle), math.cos(angle), 0.0])
    block = np.outer(normal, normal)
    expected = (-p / L) * np.block([[block, -block], [-block, block]])
    kg = beam_column_2d_geometric_stiffness(xi, xj, p)
    assert np.allclose(kg, expected, rtol=0.0, atol=1e-9 * p / L)
    total = beam_column_2d_stiffness(xi, xj, E, A, I_SECTION, geometry='pdelta', axial_load=p)
    elastic = beam_column_2d_stiffness(xi, xj, E, A, I_SECTION)
    assert np.allclose(total - elastic, expected, rtol=0.0, atol=1e-9 * E * A / L)
    # A rigid-body translation carries no force; a rigid rotation does (the chord's P-Δ).
    assert np.allclose(kg @ np.array([1.0, 1.0, 0.0, 1.0, 1.0, 0.0]), 0.0, atol=1e-9)


def test_cantilever_lateral_stiffness_chord_closed_form() -> None:
    """Fixed base, free top: ``3EI/L³ − P/L`` (the rotation condensed, v uncoupled)."""
    for p in (0.0, 1.0e5, 1.0e6, 5.0e6):
        definition = definition_of([cantilever('pdelta', p)], dof_names=['u', 'v', 'r'],
                                   mass=[1e3, 1e3, 0.0])
        k = definition.initial_stiffness
        assert k[0, 1] == pytest.approx(0.0, abs=1e-9 * k[0, 0])
        assert k[0, 0] == pytest.approx(3 * EI / L**3 - p / L, rel=1e-12)
        assert k[1, 1] == pytest.approx(E * A / L, rel=1e-12)


def test_consistent_geometric_stiffness_approaches_the_exact_cantilever() -> None:
    """One consistent element against its own closed form; a mesh against the exact
    compressed-cantilever stiffness ``P / (tan(αL)/α − L)``; the chord mesh too (slower)."""
    p = 0.6 * (math.pi**2 * EI / (4 * L**2))  # 60 % of the Euler load of the cantilever
    alpha = math.sqrt(p / EI)
    exact = p / (math.tan(alpha * L) / alpha - L)

    # One element, top DOFs (v, θ): K = EI/L³ [[12, −6L], [−6L, 4L²]] − P/L [[6/5, −L/10],
    # [−L/10, 2L²/15]] in the local frame of a column along +y (v = −ux).
    k11 = 12 * EI / L**3 - 6 * p / (5 * L)
    k12 = -6 * EI / L**2 + p / 10
    k22 = 4 * EI / L - 2 * p * L / 15
    one = definition_of([cantilever('pdelta_consistent', p)], dof_names=['u', 'v', 'r'],
                        mass=[1e3, 1e3, 0.0])
    assert one.initial_stiffness[0, 0] == pytest.approx(k11 - k12**2 / k22, rel=1e-12)

    def mesh(geometry: str, n: int) -> float:
        size = 3 * (n + 1)
        k = np.zeros((size, size))
        for e in range(n):
            y0, y1 = e * L / n, (e + 1) * L / n
            ke = beam_column_2d_stiffness((0.0, y0), (0.0, y1), E, A, I_SECTION,
                                          geometry=geometry, axial_load=p)
            k[3 * e:3 * e + 6, 3 * e:3 * e + 6] += ke
        free = list(range(3, size))
        kf = k[np.ix_(free, free)]
        top = len(free) - 3
        condensed = static_condensation(kf, [i for i in range(len(free)) if i != top])
        return float(condensed.stiffness[0, 0])

    consistent = [abs(mesh('pdelta_consistent', n) / exact - 1) for n in (1, 2, 8)]
    chord = [abs(mesh('pdelta', n) / exact - 1) for n in (1, 2, 8)]
    print(f'consistent vs exact: {consistent}; chord vs exact: {chord}')
    assert consistent[2] < 1e-5
    assert consistent[0] > consistent[1] > consistent[2]
    assert chord[2] < 5e-3
    assert chord[0] > chord[1] > chord[2]
    assert consistent[0] < chord[0]


# --------------------------------------------------------------------------- springs


def test_spring_pdelta_force_tangent_and_period() -> None:
    k, p, h, m = 3.0e7, 2.4e6, 3.0, 2.0e4
    for kind in ('spring', 'story'):
        definition = definition_of(
            [{'type': kind, 'name': 's', 'dofs': ['u'], 'stiffness': k,
              'pdelta': {'axial_load': p, 'height': h}}], dof_names=['u'], mass=[m])
        model = definition.model
        for d in (1e-3, -2.5e-2, 0.07):
            assert model.numerical_force(np.array([d]))[0] == pytest.approx(
                k * d - p * d / h, rel=1e-14)
        assert definition.initial_stiffness[0, 0] == pytest.approx(k - p / h, rel=1e-14)
        omegas, _ = modal_analysis(definition.mass, definition.initial_stiffness)
        assert 2 * math.pi / omegas[0] == pytest.approx(2 * math.pi * math.sqrt(m / (k - p / h)),
                                                        rel=1e-13)
    # Between two DOFs: the drift x_j − x_i.
    definition = definition_of(
        [{'type': 'story', 'dofs': ['u1'], 'stiffness': k},
         {'type': 'story', 'dofs': ['u1', 'u2'], 'stiffness': k,
          'pdelta': {'axial_load': p, 'height': h}}], dof_names=['u1', 'u2'], mass=[m, m])
    kt = k - p / h
    assert np.allclose(definition.initial_stiffness, [[k + kt, -kt], [-kt, kt]], rtol=1e-14)


def test_nonlinear_spring_pdelta_force_and_tangent() -> None:
    k, fy, p, h = 3.0e7, 2.0e5, 2.4e6, 3.0
    wrapped = PDeltaHysteresis(ElasticPerfectlyPlastic(k, fy), p, h)
    reference = ElasticPerfectlyPlastic(k, fy)
    assert wrapped.initial_stiffness == k - p / h
    history = [0.002, 0.005, 0.012, 0.009, -0.004, -0.02, -0.015, 0.0]
    for d in history:
        force = wrapped.set_trial_displacement(d)
        assert force == reference.set_trial_displacement(d) - p / h * d  # exactly
        tangent = hysteresis_tangent(wrapped, d)
        expected = hysteresis_tangent(reference, d) - p / h
        assert tangent == pytest.approx(expected, rel=1e-6, abs=1e-6 * k)
        wrapped.commit()
        reference.commit()
    # yielding: the tangent is −P/L (negative: the storey softens under its load)
    wrapped.set_trial_displacement(0.03)
    assert hysteresis_tangent(wrapped, 0.03) == pytest.approx(-p / h, rel=1e-6)
    wrapped.revert_to_last_commit()
    assert wrapped.trial_force == wrapped.committed_force

    # Through a test file: numerical force, initial stiffness and period.
    m = 2.0e4
    definition = definition_of(
        [{'type': 'nonlinear_spring', 'name': 'ns', 'dofs': ['u'],
          'model': {'model': 'epp', 'stiffness': k, 'yield_force': fy},
          'pdelta': {'axial_load': p, 'height': h}}], dof_names=['u'], mass=[m])
    model = definition.model
    assert model.numerical_force(np.array([0.004]))[0] == k * 0.004 - p / h * 0.004
    assert model.numerical_force(np.array([0.05]))[0] == fy - p / h * 0.05
    assert definition.initial_stiffness[0, 0] == pytest.approx(k - p / h, rel=1e-15)
    omegas, _ = modal_analysis(definition.mass, definition.initial_stiffness)
    assert 2 * math.pi / omegas[0] == pytest.approx(2 * math.pi * math.sqrt(m / (k - p / h)),
                                                    rel=1e-13)


def test_stability_check_uses_the_reduced_stiffness() -> None:
    """ω·Δt of Newmark explicit (limit 2) from k − P/L: Δt = 2.05/ω_e is stable with P-Δ."""
    k, m, h = 3.0e7, 2.0e4, 3.0
    p = 0.2 * k * h  # k − P/L = 0.8 k: ω drops by sqrt(0.8)
    dt = 2.05 / math.sqrt(k / m)
    elements = [{'type': 'story', 'dofs': ['u'], 'stiffness': k}]
    with pytest.raises(Exception, match=r'(?i)stab|limit'):
        session_module.TestSession(definition_of(elements, dof_names=['u'], mass=[m], dt=dt,
                                                 duration=0.5))
    elements[0]['pdelta'] = {'axial_load': p, 'height': h}
    session = session_module.TestSession(definition_of(elements, dof_names=['u'], mass=[m],
                                                       dt=dt, duration=0.5))
    assert session.stability.omega_max == pytest.approx(math.sqrt((k - p / h) / m), rel=1e-12)
    assert session.stability.stable


@pytest.mark.parametrize('element', [
    {'type': 'story', 'dofs': ['u'], 'stiffness': 1.0e6,
     'pdelta': {'axial_load': 3.3e6, 'height': 3.0}},
    {'type': 'nonlinear_spring', 'dofs': ['u'],
     'model': {'model': 'epp', 'stiffness': 1.0e6, 'yield_force': 1.0e4},
     'pdelta': {'axial_load': 3.0e6, 'height': 3.0}},  # exactly P/L = k: neutral, unstable
], ids=['story', 'nonlinear_spring'])
def test_unstable_under_its_axial_load_is_one_line(element: dict[str, Any]) -> None:
    with pytest.raises(ConfigError) as info:
        definition_of([element], dof_names=['u'], mass=[1e4])
    message = str(info.value)
    print(message)
    assert '\n' not in message
    assert message.startswith('pdelta.yaml: structure.elements: the structure is unstable '
                              'under its axial loads')
    assert 'DOF u' in message


def test_unstable_cantilever_beam_column_is_one_line() -> None:
    p = 1.01 * 3 * EI / L**2  # the chord P-Δ buckling load of the cantilever: 3EI/L²
    with pytest.raises(ConfigError) as info:
        definition_of([cantilever('pdelta', p)], dof_names=['u', 'v', 'r'],
                      mass=[1e3, 1e3, 0.0])
    message = str(info.value)
    assert '\n' not in message
    assert 'unstable under its axial loads' in message
    assert 'mostly DOF u' in message
    # just below it: stable, and nearly without lateral stiffness
    definition = definition_of([cantilever('pdelta', 0.99 * 3 * EI / L**2)],
                               dof_names=['u', 'v', 'r'], mass=[1e3, 1e3, 0.0])
    assert definition.initial_stiffness[0, 0] == pytest.approx(0.01 * 3 * EI / L**3, rel=1e-9)


def test_a_massless_dof_that_buckles_is_unstable_too() -> None:
    """A massless (condensed) DOF left without stiffness (P/L = k), or with a negative one
    (the condensed stiffness alone would hide it): the same one-line message."""
    k, h = 1.0e6, 3.0
    for p, other in ((k * h, 1.0e6), (1.5 * k * h, 2.0e6)):
        elements = [{'type': 'story', 'dofs': ['u1'], 'stiffness': k,
                     'pdelta': {'axial_load': p, 'height': h}},
                    {'type': 'story', 'dofs': ['u2'], 'stiffness': other}]
        with pytest.raises(ConfigError) as info:
            definition_of(elements, dof_names=['u1', 'u2'], mass=[0.0, 1e4])
        message = str(info.value)
        assert '\n' not in message
        assert 'unstable under its axial loads' in message
        assert 'mostly DOF u1' in message


@pytest.mark.parametrize(('change', 'expected'), [
    ({'pdelta': {'axial_load': -1.0, 'height': 3.0}},
     'structure.elements.0.pdelta.axial_load: must be > 0, got -1.0'),
    ({'pdelta': {'axial_load': 1.0e5, 'height': 0}},
     'structure.elements.0.pdelta.height: must be > 0, got 0'),
    ({'pdelta': {'axial_load': 1.0e5}}, 'structure.elements.0.pdelta.height: is required'),
    ({'pdelta': {'axial_load': 1.0e5, 'height': 3.0, 'lenght': 3.0}},
     'structure.elements.0.pdelta.lenght: unknown key'),
    ({'pdelta': [1.0e5, 3.0]}, 'structure.elements.0.pdelta: must be a mapping'),
    ({'pdelta': {'axial_load': True, 'height': 3.0}},
     'structure.elements.0.pdelta.axial_load: must be a number, got true'),
])
@pytest.mark.parametrize('kind', ['story', 'nonlinear_spring'])
def test_bad_spring_pdelta_is_one_line(kind: str, change: dict[str, Any], expected: str) -> None:
    element: dict[str, Any] = {'type': kind, 'name': 's', 'dofs': ['u']}
    if kind == 'story':
        element['stiffness'] = 1.0e7
    else:
        element['model'] = {'model': 'elastic', 'stiffness': 1.0e7}
    element.update(change)
    with pytest.raises(ConfigError) as info:
        definition_of([element], dof_names=['u'], mass=[1e4])
    assert str(info.value).startswith(f'pdelta.yaml: {expected}')
    assert '\n' not in str(info.value)


@pytest.mark.parametrize(('geometry', 'axial_load', 'expected'), [
    ('pdelta', None, '.axial_load: is required with geometry pdelta'),
    ('corotational', 1.0e5,
     ".geometry: must be one of 'linear', 'pdelta', 'pdelta_consistent', got 'corotational'"),
    ('linear', 1.0e5, '.axial_load: needs geometry pdelta or pdelta_consistent'),
    (None, 1.0e5, '.axial_load: needs geometry pdelta or pdelta_consistent'),
    ('pdelta', 'heavy', ".axial_load: must be a number, got 'heavy'"),
])
def test_bad_beam_column_geometry_is_one_line(geometry: str | None, axial_load: Any,
                                              expected: str) -> None:
    with pytest.raises(ConfigError) as info:
        definition_of([cantilever(geometry, axial_load)], dof_names=['u', 'v', 'r'],
                      mass=[1e3, 1e3, 0.0])
    assert str(info.value).startswith(f'pdelta.yaml: structure.elements.0{expected}')
    assert '\n' not in str(info.value)


def test_resolved_definition_keeps_the_pdelta_terms() -> None:
    definition = definition_of(
        [cantilever('pdelta', 2.0e5),
         {'type': 'story', 'dofs': ['v'], 'stiffness': 1e6,
          'pdelta': {'axial_load': 1e5, 'height': 2.0}}],
        dof_names=['u', 'v', 'r'], mass=[1e3, 1e3, 0.0])
    again = from_dict(definition.to_resolved_dict(), source='resolved.json', base_dir=REPO)
    assert np.array_equal(again.initial_stiffness, definition.initial_stiffness)


# --------------------------------------------------------------------------- OpenSees

OPENSEES_SCRIPT = opensees_script(r'''
ops.wipe()
ops.model('basic', '-ndm', 2, '-ndf', 3)
for tag, x, y in spec['nodes']:
    ops.node(tag, x, y)
for tag, *fixity in spec['fix']:
    ops.fix(tag, *fixity)
for tag, *mass in spec['mass']:
    ops.mass(tag, *mass)
ops.geomTransf('PDelta', 1)
for material in spec['materials']:
    ops.uniaxialMaterial(*material)
for element in spec['elements']:
    if element[0] == 'elasticBeamColumn':
        ops.element('elasticBeamColumn', *element[1:], 1)
    else:
        ops.element('zeroLength', *element[1:4], '-mat', element[4], '-dir', 1,
                    '-doRayleigh', 1)
gravity_step(spec['gravity'])  # the axial loads: nodal loads of one static step, then held
out = {'axial': [ops.eleResponse(e[1], 'localForce')[0] for e in spec['elements']
                 if e[0] == 'elasticBeamColumn']}
if spec['mode'] == 'static':
    ops.timeSeries('Linear', 2)
    ops.pattern('Plain', 2, 2)
    for tag, *load in spec['lateral']:
        ops.load(tag, *load)
    if ops.analyze(1) != 0:
        sys.exit('lateral analysis failed')
    out['disp'] = [ops.nodeDisp(tag, dof) for tag, dof in spec['record_dofs']]
else:
    ops.wipeAnalysis()
    ops.timeSeries('Path', 2, '-dt', spec['dt'], '-values', *spec['record'], '-factor', 1.0)
    ops.pattern('UniformExcitation', 2, 1, '-accel', 2)
    transient_setup(spec['integrator'], [spec['a0'], spec['a1'], 0.0, 0.0])
    history = [[ops.nodeDisp(tag, dof) for tag, dof in spec['record_dofs']]]
    for _ in range(spec['steps']):
        if ops.analyze(1, spec['dt']) != 0:
            sys.exit('analysis failed')
        history.append([ops.nodeDisp(tag, dof) for tag, dof in spec['record_dofs']])
    out['disp'] = history
print(json.dumps(out))
''')


def opensees(spec: dict[str, Any]) -> dict[str, Any]:
    """Run :data:`OPENSEES_SCRIPT` on ``spec`` in a child process."""
    spec = {'materials': [], 'mass': [], **spec}
    out: dict[str, Any] = run_opensees(OPENSEES_SCRIPT, spec)
    return out


@needs_opensees
@pytest.mark.parametrize('p', [1.0e6, 5.0e6])
def test_cantilever_static_matches_opensees_pdelta(p: float) -> None:
    """Tolerance 1e-9 relative (measured about 1e-15 .. 1e-13: the same linear algebra)."""
    h = 1.0e3  # N, lateral at the top
    definition = definition_of([cantilever('pdelta', p)], dof_names=['u', 'v', 'r'],
                               mass=[1e3, 1e3, 0.0])
    k = definition.initial_stiffness
    ours = np.linalg.solve(k, np.array([h, 0.0]))[0]
    # Rotation of the top (condensed): the recovery of the massless DOF.
    closed = h / (3 * EI / L**3 - p / L)
    reference = opensees({
        'mode': 'static', 'nodes': [[1, 0.0, 0.0], [2, 0.0, L]], 'fix': [[1, 1, 1, 1]],
        'elements': [['elasticBeamColumn', 1, 1, 2, A, E, I_SECTION]],
        'gravity': [[2, 0.0, -p, 0.0]], 'lateral': [[2, h, 0.0, 0.0]],
        'record_dofs': [[2, 1], [2, 3]]})
    assert reference['axial'][0] == pytest.approx(p, rel=1e-12)  # compression at node i
    theirs = reference['disp'][0]
    error = abs(ours / theirs - 1)
    print(f'cantilever P = {p:.3g} N: |u_ours / u_OpenSees - 1| = {error:.3g}, '
          f'closed form {abs(ours / closed - 1):.3g}; P-Δ softens by '
          f'displacement x {closed / (h * L**3 / (3 * EI)):.4f} of the elastic one')
    assert ours == pytest.approx(closed, rel=1e-12)
    assert error < 1e-9
    # the top rotation agrees as well (chord P-Δ: θ from the elastic condensation)
    theta_ours = -1.5 * ours / L  # θ = −3u/(2L) for a tip-loaded cantilever (ccw positive)
    assert reference['disp'][1] == pytest.approx(theta_ours, rel=1e-9)


def stacked_columns(guided: bool) -> tuple[list[dict[str, Any]], list[str], list[float]]:
    """A two-storey column line (nodes at L, 2L): our elements, DOF names and masses."""
    # N: the lower column carries both floors' loads; about 40 % (guided) and 35 % (free) of
    # the buckling loads of the chord model
    p1, p2 = (1.2e7, 6.0e6) if guided else (6.0e5, 3.0e5)
    if guided:  # floors' rotations restrained (a shear building of columns)
        names = ['u1', 'u2']
        dofs1 = [None, None, None, 'u1', None, None]
        dofs2 = ['u1', None, None, 'u2', None, None]
        mass = [2.0e4, 1.5e4]
    else:  # free rotations, massless: condensed out
        names = ['u1', 'r1', 'u2', 'r2']
        dofs1 = [None, None, None, 'u1', None, 'r1']
        dofs2 = ['u1', None, 'r1', 'u2', None, 'r2']
        mass = [2.0e4, 0.0, 1.5e4, 0.0]
    elements = [
        {'type': 'beam_column', 'name': 'c1', 'dofs': dofs1,
         'coordinates': [[0.0, 0.0], [0.0, L]], 'E': E, 'A': A, 'I': I_SECTION,
         'geometry': 'pdelta', 'axial_load': p1},
        {'type': 'beam_column', 'name': 'c2', 'dofs': dofs2,
         'coordinates': [[0.0, L], [0.0, 2 * L]], 'E': E, 'A': A, 'I': I_SECTION,
         'geometry': 'pdelta', 'axial_load': p2},
    ]
    return elements, names, mass


@needs_opensees
@pytest.mark.parametrize(('guided', 'scheme', 'integrator', 'tolerance'), [
    (True, 'newmark_explicit', 'explicit', 1e-9),
    (False, 'average_acceleration', 'implicit', 1e-9),
], ids=['guided-newmark-explicit-rayleigh', 'cantilever-average-acceleration'])
def test_two_storey_columns_under_el_centro_match_opensees(
        tmp_path: Path, guided: bool, scheme: str, integrator: str, tolerance: float) -> None:
    """El Centro 5 s, Δt = 0.01 s; max |ours − OpenSees| over the peak below ``tolerance``.

    Guided floors: Rayleigh 5 % at modes 1-2 of the stiffness with P-Δ (OpenSees's ``betaK``
    on the current tangent, which includes the PDelta term of the held axial forces). Free
    rotations (massless, condensed here, in OpenSees's Newton matrix there): no damping, as
    stiffness-proportional damping on massless DOFs is not the condensed one.
    """
    elements, names, mass = stacked_columns(guided)
    damping = {'rayleigh': {'modes': [1, 2], 'ratios': [0.05, 0.05]}} if guided else None
    definition = definition_of(elements, dof_names=names, mass=mass, scheme=scheme,
                               damping=damping)
    result = run_offline(definition, tmp_path / 'ours', figures=False)
    history = result.session.history
    ours = history.displacement[:history.n_committed]
    a0 = a1 = 0.0
    if guided:  # C = a0 M + a1 K of ours, fitted back
        m_mat, k_mat, c_mat = definition.mass, definition.initial_stiffness, definition.damping
        coefficients, *_ = np.linalg.lstsq(np.column_stack([m_mat.ravel(), k_mat.ravel()]),
                                           c_mat.ravel(), rcond=None)
        a0, a1 = (float(c) for c in coefficients)
        assert np.allclose(a0 * m_mat + a1 * k_mat, c_mat, rtol=1e-12, atol=1e-9)
    fix_top = [0, 0, 1] if guided else [0, 0, 0]
    m1, m2 = mass[0], mass[names.index('u2')]
    masses = [[2, m1, m1, 0.0], [3, m2, m2, 0.0]]
    spec = {
        'mode': 'transient', 'nodes': [[1, 0.0, 0.0], [2, 0.0, L], [3, 0.0, 2 * L]],
        'fix': [[1, 1, 1, 1], [2, *fix_top], [3, *fix_top]], 'mass': masses,
        'elements': [['elasticBeamColumn', 1, 1, 2, A, E, I_SECTION],
                     ['elasticBeamColumn', 2, 2, 3, A, E, I_SECTION]],
        'gravity': [[2, 0.0, -(elements[0]['axial_load'] - elements[1]['axial_load']), 0.0],
                    [3, 0.0, -elements[1]['axial_load'], 0.0]],
        'record_dofs': [[2, 1], [3, 1]], 'dt': definition.dt,
        'record': np.asarray(definition.ground_acceleration).tolist(),
        'a0': a0, 'a1': a1, 'integrator': integrator, 'steps': definition.n_steps}
    reference = opensees(spec)
    assert reference['axial'] == pytest.approx([elements[0]['axial_load'],
                                                elements[1]['axial_load']], rel=1e-12)
    theirs = np.array(reference['disp'])
    lateral = [definition.dof_names.index('u1'), definition.dof_names.index('u2')]
    ours_lateral = ours[:, lateral]
    assert ours_lateral.shape == theirs.shape
    peak = float(np.max(np.abs(theirs)))
    error = float(np.max(np.abs(ours_lateral - theirs))) / peak
    # Without P-Δ the history is clearly different (the test can fail).
    plain = copy.deepcopy(elements)
    for element in plain:
        element.pop('geometry')
        element.pop('axial_load')
    linear = run_offline(definition_of(plain, dof_names=names, mass=mass, scheme=scheme,
                                       damping=damping), tmp_path / 'linear', figures=False)
    linear_history = linear.session.history.displacement[:linear.session.history.n_committed]
    effect = float(np.max(np.abs(linear_history[:, lateral] - theirs))) / peak
    print(f'{"guided" if guided else "cantilever"} {scheme}: max |ours - OpenSees| / peak = '
          f'{error:.3g} (peak {peak * 1e3:.2f} mm); without P-Δ {effect:.3g}')
    assert peak > 5e-3
    assert effect > 0.05
    assert error < tolerance


@needs_opensees
def test_nonlinear_spring_pdelta_under_el_centro_matches_opensees(tmp_path: Path) -> None:
    """An epp storey with ``pdelta`` against OpenSees's ``ElasticPP`` zeroLength beside a
    leaning column (``elasticBeamColumn`` with ``PDelta``, bending stiffness ``12EI/L³ =
    1e-10 k``, top rotation restrained) carrying ``P``. Newmark explicit, 5 % of the reduced
    stiffness as mass-proportional damping (``c = 2 ζ m ω``). Tolerance 1e-8 of the peak (the
    same recursion; yield-point round-off and the 1e-10 k of the beam)."""
    m, k, fy, h = 2543.4, 312559.0, 10000.0, 2.0
    p = 0.15 * k * h  # P/L = 15 % of k
    element = {'type': 'nonlinear_spring', 'name': 'storey', 'dofs': ['u'],
               'model': {'model': 'epp', 'stiffness': k, 'yield_force': fy},
               'pdelta': {'axial_load': p, 'height': h}}
    definition = definition_of([element], dof_names=['u'], mass=[m],
                               damping={'ratio': 0.05})
    omega = math.sqrt((k - p / h) / m)
    assert definition.damping[0, 0] == pytest.approx(2 * 0.05 * m * omega, rel=1e-12)
    result = run_offline(definition, tmp_path / 'ours', figures=False)
    history = result.session.history
    ours = history.displacement[:history.n_committed, 0]
    k_bending = 1e-10 * k
    area = 3.402e7 * h / E
    inertia = k_bending * h**3 / (12 * E)
    reference = opensees({
        'mode': 'transient', 'nodes': [[1, 0.0, 0.0], [2, 0.0, h], [3, 0.0, h]],
        'fix': [[1, 1, 1, 1], [2, 0, 0, 1], [3, 1, 1, 1]], 'mass': [[2, m, m, 0.0]],
        'materials': [['ElasticPP', 1, k, fy / k]],
        'elements': [['elasticBeamColumn', 1, 1, 2, area, E, inertia],
                     ['zeroLength', 2, 3, 2, 1]],
        'gravity': [[2, 0.0, -p, 0.0]], 'record_dofs': [[2, 1]], 'dt': definition.dt,
        'record': np.asarray(definition.ground_acceleration).tolist(),
        'a0': float(definition.damping[0, 0]) / m, 'a1': 0.0, 'integrator': 'explicit',
        'steps': definition.n_steps})
    theirs = np.array(reference['disp'])[:, 0]
    peak = float(np.max(np.abs(theirs)))
    error = float(np.max(np.abs(ours - theirs))) / peak
    print(f'nonlinear_spring epp + pdelta: max |ours - OpenSees| / peak = {error:.3g} '
          f'(peak {peak * 1e3:.2f} mm, yield at {fy / k * 1e3:.2f} mm)')
    assert peak > 1.5 * fy / k  # it yields
    assert error < 1e-8
