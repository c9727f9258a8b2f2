"""The ROS-free runner: run folder, bag replay, linear verification, figures, bad input."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.signal
import yaml
from rosbags.highlevel import AnyReader

from pd_common.protocol import Command, Feedback
from pd_common.protocol import TestState as State
from pd_core.errors import BagError, ConfigError, StabilityError
from pd_core.run.record.bag import (
    TOPIC_COMMAND,
    TOPIC_DEFINITION,
    TOPIC_FEEDBACK,
    BagRecorder,
    read_bag,
    typestore,
)
from pd_core.run.runner import rebuild_outputs, replay_bag, run_offline
from pd_core.run.test_file import from_dict, from_json, load_test_file
from support.paths import DEFAULT_TEST, REPO

ELCENTRO = Path('/work/main/src/pd_integrator/data/ground_motions/elcentro_1940_ns_chopra.csv')
if not ELCENTRO.is_file():  # a checkout somewhere else
    ELCENTRO = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / ELCENTRO.name

M = 2543.4
K = 312559.0
ZETA = 0.05
COLUMNS = ['time', 'step', 'x_top', 'v_top', 'a_top', 'fs_top', 'xm_top', 'ag']
FIGURES = ('displacement.png', 'velocity.png', 'acceleration.png', 'force_deformation.png')


def read_csv(path: Path) -> tuple[list[str], list[list[str]]]:
    with path.open(encoding='utf-8', newline='') as stream:
        rows = list(csv.reader(stream))
    return rows[0], rows[1:]


def folder_snapshot(directory: Path) -> dict[str, bytes]:
    return {str(path.relative_to(directory)): path.read_bytes()
            for path in sorted(directory.rglob('*')) if path.is_file()}


# -- a shortened default test -----------------------------------------------------------------
@pytest.fixture(scope='module')
def short_run(tmp_path_factory: pytest.TempPathFactory) -> Any:
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': 3.0})
    directory = tmp_path_factory.mktemp('offline') / 'run'
    return run_offline(definition, directory, figures=False)


def test_run_folder_contents(short_run: Any) -> None:
    directory = short_run.directory
    assert (directory / 'bag').is_dir()
    for name in ('response.csv', 'summary.json', 'test_definition.json'):
        assert (directory / name).is_file()
        assert (directory / name).stat().st_size > 0
    for name in FIGURES:
        assert not (directory / name).exists()
    assert short_run.bag_path == directory / 'bag'


def test_response_csv(short_run: Any) -> None:
    header, rows = read_csv(short_run.directory / 'response.csv')
    assert header == COLUMNS
    assert len(rows) == 301
    data = np.array([[float(value) for value in row] for row in rows])
    assert data[:, 1].tolist() == list(range(301))
    np.testing.assert_allclose(data[:, 0], np.arange(301) * 0.01, rtol=0.0, atol=1e-12)
    # Step 0 at rest; the ideal simulated actuator measures the commanded displacement.
    assert data[0, 2] == 0.0
    assert data[0, 3] == 0.0
    assert np.array_equal(data[:, 6], data[:, 2])
    # The ground acceleration column is El Centro in m/s2 (even steps: the record).
    record_g = np.loadtxt(ELCENTRO, delimiter=',', comments='#')[:, 1]
    assert np.array_equal(data[0::2, 7], record_g[:151] * 9.81)
    # The exact floats (17 significant digits) are the session's history.
    history = short_run.session.history
    assert np.array_equal(data[:, 2], history.displacement[:, 0])
    assert np.array_equal(data[:, 5], history.restoring_force[:, 0])
    # A response that moved, elastic (k_ini) until the first yield at d_y = F_y/k_ini, then
    # bounded by the bilinear backbone (F_y = 10 kN, b = 0.01).
    x, fs = data[:, 2], data[:, 5]
    d_y = 10000.0 / K
    assert np.max(np.abs(x)) > d_y
    first_yield = int(np.argmax(np.abs(x) > d_y))
    assert first_yield > 10
    np.testing.assert_allclose(fs[:first_yield], K * x[:first_yield], rtol=1e-12, atol=1e-9)
    # On the first excursion past yield the force follows the backbone's hardening branch.
    last = first_yield
    while abs(x[last + 1]) > abs(x[last]):
        last += 1
    assert last > first_yield
    branch = slice(first_yield, last + 1)
    backbone = np.sign(x[branch]) * (10000.0 + 0.01 * K * (np.abs(x[branch]) - d_y))
    np.testing.assert_allclose(fs[branch], backbone, rtol=1e-9)


def test_summary_json(short_run: Any) -> None:
    summary = json.loads((short_run.directory / 'summary.json').read_text(encoding='utf-8'))
    assert summary['steps'] == 300
    assert summary['state'] == 'finished'
    assert summary['total_steps'] == 300
    assert summary['dt'] == 0.01
    assert summary['duration'] == pytest.approx(3.0, abs=1e-12)
    assert summary['mode'] == 'offline'
    assert summary['retries'] == 0
    assert summary['ignored_messages'] == 0
    assert summary['omega_max_dt'] == pytest.approx(math.sqrt(K / M) * 0.01, rel=1e-12)
    x = short_run.session.history.displacement[:, 0]
    peak = summary['dofs']['top']['peaks']['displacement']
    index = int(np.argmax(np.abs(x)))
    assert peak['abs'] == abs(x[index])
    assert peak['time'] == pytest.approx(index * 0.01, abs=1e-12)
    assert summary['dofs']['top']['residual_displacement'] == x[-1]


def test_definition_json_is_the_resolved_definition(short_run: Any) -> None:
    text = (short_run.directory / 'test_definition.json').read_text(encoding='utf-8')
    stored = from_json(text)
    original = short_run.session.definition
    assert stored.n_steps == 300
    assert stored.ground_acceleration.tobytes() == original.ground_acceleration.tobytes()
    assert stored.damping.tobytes() == original.damping.tobytes()


# -- replay -----------------------------------------------------------------------------------
def test_replay_reproduces_response_csv_exactly(short_run: Any, tmp_path: Path) -> None:
    replay = rebuild_outputs(short_run.bag_path, tmp_path / 'replay', figures=False)
    original = (short_run.directory / 'response.csv').read_bytes()
    assert (tmp_path / 'replay' / 'response.csv').read_bytes() == original
    summary = json.loads((tmp_path / 'replay' / 'summary.json').read_text(encoding='utf-8'))
    assert summary['steps'] == 300
    assert summary['state'] == 'finished'
    assert summary['mode'] == 'replay'
    assert replay.session.state is State.FINISHED


def test_bag_contents_read_with_anyreader(short_run: Any) -> None:
    counts: dict[str, int] = {}
    definition_text = None
    with AnyReader([short_run.bag_path], default_typestore=typestore()) as reader:
        for connection, _, raw in reader.messages():
            counts[connection.topic] = counts.get(connection.topic, 0) + 1
            if connection.topic == TOPIC_DEFINITION:
                definition_text = reader.deserialize(raw, connection.msgtype).data
            if connection.topic == TOPIC_COMMAND:
                message = reader.deserialize(raw, connection.msgtype)
                assert message.test_id == 'thesis-5.1-elcentro'
    assert counts[TOPIC_COMMAND] == 301
    assert counts[TOPIC_FEEDBACK] == 301
    assert counts[TOPIC_DEFINITION] == 1
    stored = (short_run.directory / 'test_definition.json').read_text(encoding='utf-8')
    assert definition_text == stored


def test_probe_run_replays_exactly(tmp_path: Path) -> None:
    definition = load_test_file(DEFAULT_TEST,
                                overrides={'duration': 1.0, 'initial_stiffness': 'probe'})
    run = run_offline(definition, tmp_path / 'run', figures=False)
    assert run.summary['state'] == 'finished'
    assert run.summary['initial_stiffness_probed'] is True
    assert run.summary['initial_stiffness'][0][0] == pytest.approx(K, rel=1e-9)
    header, rows = read_csv(run.directory / 'response.csv')
    assert header == COLUMNS
    assert len(rows) == 101  # the probe is not part of the response
    replay = rebuild_outputs(run.bag_path, tmp_path / 'replay', figures=False)
    assert ((tmp_path / 'replay' / 'response.csv').read_bytes()
            == (run.directory / 'response.csv').read_bytes())
    assert replay.session.probe_stiffness is not None
    recorded = read_bag(run.bag_path)
    assert [c.test_id for c in recorded.commands[:4]] == ['thesis-5.1-elcentro:probe'] * 3 + [
        'thesis-5.1-elcentro']


# -- a bag written by hand --------------------------------------------------------------------
def hand_definition() -> Any:
    """SDOF with an elastic specimen and a non-zero first ground acceleration sample."""
    raw = {
        'test': {'id': 'hand', 'dt': 0.01},
        'structure': {'dof_names': ['top'], 'mass': M, 'damping': {'coefficient': 2000.0},
                      'initial_stiffness': K},
        'ground_motion': {'inline': {'dt': 0.02, 'acceleration': [0.5, -0.25, 0.125]},
                          'units': 'm/s2'},
        'specimen': {'elements': [{'model': 'elastic', 'stiffness': K}]},
    }
    return from_dict(raw, source='hand.yaml')


def write_hand_bag(path: Path, target_1: float) -> None:
    definition = hand_definition()
    dt = 0.01
    with BagRecorder(path) as bag:
        bag.write_definition(definition.to_json(), 1)
        bag.write_command(Command('hand', 0, 0.0, ('top',), (0.0,)), 2)
        bag.write_feedback(Feedback('hand', 0, (0.0,), (0.0,)), 3)
        bag.write_command(Command('hand', 1, dt, ('top',), (target_1,)), 4)
        bag.write_feedback(Feedback('hand', 1, (target_1,), (K * target_1,)), 5)


def first_target() -> float:
    """x1 of thesis eq. 3.21 from rest: a0 = (p0 - c v0 - r0)/m, x1 = x0 + dt v0 + a0 dt² / 2."""
    dt = 0.01
    p0 = -M * 0.5
    a0 = (p0 - 2000.0 * 0.0 - 0.0) / M
    return 0.0 + dt * 0.0 + a0 * dt * dt * 0.5


def test_hand_written_bag_replays(tmp_path: Path) -> None:
    x1 = first_target()
    assert x1 == pytest.approx(-0.5 * 0.01**2 / 2.0, rel=1e-15)
    write_hand_bag(tmp_path / 'bag', x1)
    session = replay_bag(tmp_path / 'bag')
    assert session.history.n_committed == 2
    assert session.history.displacement[1, 0] == x1
    assert session.history.restoring_force[1, 0] == K * x1


def test_tampered_bag_is_rejected(tmp_path: Path) -> None:
    write_hand_bag(tmp_path / 'bag', first_target() + 1.0e-6)
    with pytest.raises(BagError, match=r'step 1\b') as info:
        replay_bag(tmp_path / 'bag')
    assert "'hand'" in str(info.value)
    with pytest.raises(BagError, match=r'step 1\b'):
        rebuild_outputs(tmp_path / 'bag', tmp_path / 'replay', figures=False)


def test_bag_without_definition_is_rejected(tmp_path: Path) -> None:
    with BagRecorder(tmp_path / 'bag') as bag:
        bag.write_command(Command('hand', 0, 0.0, ('top',), (0.0,)), 1)
    with pytest.raises(BagError, match='/pd/test_definition'):
        read_bag(tmp_path / 'bag')


def test_recorder_refuses_an_existing_bag(tmp_path: Path) -> None:
    write_hand_bag(tmp_path / 'bag', first_target())
    before = folder_snapshot(tmp_path / 'bag')
    with pytest.raises(BagError, match='exists'):
        BagRecorder(tmp_path / 'bag').open()
    assert folder_snapshot(tmp_path / 'bag') == before


# -- linear verification against the exact solution -------------------------------------------
def linear_test_file(tmp_path: Path) -> Path:
    raw = {
        'test': {'id': 'linear', 'dt': 0.01, 'duration': 10.0},
        'structure': {'dof_names': ['top'], 'mass': M, 'damping': {'ratio': ZETA},
                      'initial_stiffness': K},
        'ground_motion': {'file': str(ELCENTRO), 'units': 'g', 'g': 9.81},
        'specimen': {'elements': [{'model': 'elastic', 'stiffness': K}]},
    }
    path = tmp_path / 'linear.yaml'
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    return path


def exact_displacement(ag: np.ndarray, dt: float) -> np.ndarray:
    """Exact response to the piecewise-linear excitation −a_g (state space, lsim interp)."""
    omega = math.sqrt(K / M)
    a = [[0.0, 1.0], [-omega * omega, -2.0 * ZETA * omega]]
    b = [[0.0], [1.0]]
    c = [[1.0, 0.0]]
    d = [[0.0]]
    t = np.arange(ag.size) * dt
    _, y, _ = scipy.signal.lsim((a, b, c, d), -ag, t, interp=True)
    return np.asarray(y).reshape(-1)


def test_linear_response_converges_to_the_exact_solution(tmp_path: Path) -> None:
    path = linear_test_file(tmp_path)
    record_g = np.loadtxt(ELCENTRO, delimiter=',', comments='#')[:, 1]
    # The excitation on the 0.01 s grid, built here: record samples and midpoints.
    ag = np.empty(1001)
    ag[0::2] = record_g[:501] * 9.81
    ag[1::2] = np.interp(np.arange(1, 1001, 2) * 0.01, np.arange(501) * 0.02, ag[0::2])
    exact = exact_displacement(ag, 0.01)
    peak = np.max(np.abs(exact))
    assert 0.05 < peak < 0.08  # the elastic demand is about 65 mm

    errors = {}
    for dt in (0.01, 0.005):
        definition = load_test_file(path, overrides={'dt': dt})
        assert definition.n_steps == round(10.0 / dt)
        run = run_offline(definition, tmp_path / f'run-{dt}', figures=False)
        assert run.summary['state'] == 'finished'
        x = run.session.history.displacement[:, 0]
        x_on_grid = x[::round(0.01 / dt)]
        assert x_on_grid.size == 1001
        errors[dt] = np.max(np.abs(x_on_grid - exact)) / peak
    assert errors[0.01] < 0.01
    ratio = errors[0.01] / errors[0.005]
    assert 3.5 < ratio < 4.5, (errors, ratio)


# -- figures ----------------------------------------------------------------------------------
def test_figures(tmp_path: Path) -> None:
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': 1.0})
    run = run_offline(definition, tmp_path / 'run', figures=True)
    for name in FIGURES:
        path = run.directory / name
        assert path.is_file(), name
        data = path.read_bytes()
        assert len(data) > 1000
        assert data[:8] == b'\x89PNG\r\n\x1a\n'


# -- bad input --------------------------------------------------------------------------------
def test_no_specimen_section(tmp_path: Path) -> None:
    raw = yaml.safe_load(DEFAULT_TEST.read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(ELCENTRO)
    del raw['specimen']
    path = tmp_path / 'nospec.yaml'
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    definition = load_test_file(path)
    assert definition.specimen is None
    with pytest.raises(ConfigError, match=r'^nospec\.yaml: specimen: '):
        run_offline(definition, tmp_path / 'run', figures=False)
    assert not (tmp_path / 'run').exists()


def test_output_folder_with_a_bag_is_refused(tmp_path: Path) -> None:
    directory = tmp_path / 'run'
    (directory / 'bag').mkdir(parents=True)
    (directory / 'bag' / 'metadata.yaml').write_text('earlier run\n', encoding='utf-8')
    (directory / 'response.csv').write_text('time,step\n0,0\n', encoding='utf-8')
    (directory / 'summary.json').write_text('{"state": "finished"}\n', encoding='utf-8')
    before = folder_snapshot(directory)
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': 0.5})
    with pytest.raises(ConfigError, match='already holds a run') as info:
        run_offline(definition, directory, figures=False)
    assert str(directory) in str(info.value)
    assert folder_snapshot(directory) == before


def test_unstable_definition_writes_nothing(tmp_path: Path) -> None:
    definition = load_test_file(DEFAULT_TEST, overrides={'dt': 0.2})
    with pytest.raises(StabilityError, match='dt'):
        run_offline(definition, tmp_path / 'run', figures=False)
    assert not (tmp_path / 'run').exists()
