"""The console's pure part: decimated histories, gauges, rate/ETA, access, run folders."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from pd_common.experimental import tracking_indicator
from pd_common.protocol import Command, Feedback, FeedbackStatus, Status
from pd_common.protocol import TestState as State
from pd_console.core import (
    ConsoleAccess,
    ConsoleModel,
    ControlRequest,
    DecimatedRows,
    load_run_folder,
    parse_control,
    sites_of_definition,
)
from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file
from support.paths import DEFAULT_TEST, REPO

RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def feed_sine(model: ConsoleModel, steps: int, *, site: str = '', lag: float = 0.0,
              test_id: str = 't') -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(steps) * 0.01
    command = 0.02 * np.sin(2 * np.pi * t)
    measured = 0.02 * np.sin(2 * np.pi * (t - lag))
    force = 3.0e5 * measured
    for k in range(steps):
        model.on_command(site, Command(test_id=test_id, step=k, test_time=float(t[k]),
                                       dof_names=('top',),
                                       target_displacement=(float(command[k]),)))
        model.on_feedback(site, Feedback(test_id=test_id, step=k,
                                         measured_displacement=(float(measured[k]),),
                                         restoring_force=(float(force[k]),)))
    return command, measured, force


def test_decimated_rows_stay_bounded_and_cover_the_whole_history() -> None:
    rows = DecimatedRows(100)
    for i in range(10_000):
        rows.append((float(i), 2.0 * i))
    kept = rows.rows()
    assert len(kept) <= 101
    assert kept[0] == (0.0, 0.0)
    assert kept[-1] == (9999.0, 19998.0)  # the latest row is always there
    steps = np.diff([row[0] for row in kept[:-1]])
    assert np.all(steps == rows.stride)  # evenly spaced
    assert rows.stride & (rows.stride - 1) == 0 and rows.count == 10_000
    with pytest.raises(ValueError, match='capacity'):
        DecimatedRows(1)


def test_short_history_is_kept_whole_and_equals_the_tracking_indicator() -> None:
    model = ConsoleModel(Clock(), max_points=1000)
    command, measured, _ = feed_sine(model, 300, lag=0.01)
    frame = model.frame()
    dof = frame['sites'][0]['dofs'][0]
    assert dof['samples'] == 300 and len(dof['t']) == 300
    expected = tracking_indicator(command, measured)
    np.testing.assert_allclose(dof['indicator'], expected, rtol=1e-5, atol=1e-12)
    np.testing.assert_allclose(dof['error'], measured - command, rtol=1e-5, atol=1e-12)
    json.dumps(frame, allow_nan=False)


def test_a_long_test_is_drawn_with_at_most_max_points_per_series() -> None:
    model = ConsoleModel(Clock(), max_points=200)
    feed_sine(model, 20_000)
    dof = model.frame()['sites'][0]['dofs'][0]
    assert dof['samples'] == 20_000
    for name in ('t', 'command', 'measured', 'force', 'error', 'indicator'):
        assert len(dof[name]) <= 201
    assert dof['t'][-1] == pytest.approx(199.99)


def test_gauges_are_the_fractions_of_the_bridge_limits() -> None:
    model = ConsoleModel(Clock(), default_limits={'max_displacement': 0.1, 'max_force': 1.0e4,
                                                  'max_increment': 0.01,
                                                  'max_velocity': 0.5, 'step_duration': 0.5,
                                                  'tracking_tolerance': 0.0})
    command, measured, force = feed_sine(model, 200, lag=0.005)
    gauges = {g['name']: g for g in model.frame()['sites'][0]['gauges']}
    peak_x = max(np.max(np.abs(command)), np.max(np.abs(measured)))
    assert gauges['max_displacement']['peak_ratio'] == pytest.approx(peak_x / 0.1, rel=1e-5)
    assert gauges['max_force']['peak_ratio'] == pytest.approx(np.max(np.abs(force)) / 1e4,
                                                              rel=1e-5)
    increment = np.max(np.abs(np.diff(command)))
    assert gauges['max_increment']['peak_ratio'] == pytest.approx(increment / 0.01, rel=1e-5)
    assert gauges['max_velocity']['peak_ratio'] == pytest.approx(increment / 0.5 / 0.5,
                                                                 rel=1e-5)
    assert gauges['tracking_tolerance']['off'] and gauges['tracking_tolerance']['ratio'] is None


def test_definition_names_the_sites_and_their_limits() -> None:
    definition = load_test_file(REPO / 'src' / 'pd_integrator' / 'config'
                                / 'three_story_two_sites.yaml')
    assert sites_of_definition(json.loads(definition.to_json())) == {'lab1': 'story1',
                                                                     'lab3': 'story3'}
    model = ConsoleModel(Clock(), default_limits={'max_displacement': 0.25,
                                                  'max_force': 1.0e5})
    model.on_definition(definition.to_json())
    assert list(model.sites) == ['lab1', 'lab3']
    limits = model.sites['lab1'].limits
    assert limits['max_displacement'] == 0.1 and limits['max_force'] == 1.0e6
    assert sites_of_definition({}) == {'': 'specimen'}
    model.on_definition('not json')  # ignored
    assert list(model.sites) == ['lab1', 'lab3']


@pytest.mark.parametrize('text', [
    '{"structure": {"elements": [1]}}', '{"structure": 5}', '{"sites": [1]}',
    '{"sites": {"": {"bridge": [1]}}}', '{"test": [1]}',
    '{"structure": {"elements": [{"type": "experimental", "site": "1 x"}]}}',  # no namespace
    '{"structure": {"elements": [{"type": "experimental", "site": "a\\n"}]}}',
    '{"structure": {"elements": [{"type": "experimental", "site": "a"}]}, "sites": {"a": 3}}'])
def test_a_definition_of_another_shape_is_not_shown_and_breaks_nothing(text: str) -> None:
    """Without a key the console takes anyone's definition: one that is JSON but not a test
    definition's shape raised in the console's ROS thread, which then drew nothing more."""
    model = ConsoleModel(Clock())
    model.on_definition(text)
    assert model.definition == {} and model.sites == {}
    feed_sine(model, 20)  # the default site still draws
    json.dumps(model.frame(), allow_nan=False)  # (what the page is sent)


def test_a_limit_that_is_no_finite_number_is_not_a_gauges_limit() -> None:
    model = ConsoleModel(Clock(), default_limits={'max_force': 1.0e5})
    model.on_definition('{"sites": {"": {"bridge": {"max_force": NaN, '
                        '"max_displacement": 1e999, "max_increment": 0.02, '
                        '"max_velocity": 1' + '0' * 400 + '}}}}')  # (no float)
    assert model.sites[''].limits == {'max_force': 1.0e5, 'max_increment': 0.02}
    feed_sine(model, 20)
    json.dumps(model.frame(), allow_nan=False)  # (raised: NaN is no JSON for the page)


def test_a_command_whose_names_do_not_match_its_targets_is_not_drawn() -> None:
    model = ConsoleModel(Clock())
    model.on_command('', Command(test_id='t', step=0, test_time=0.0, dof_names=('a', 'b'),
                                 target_displacement=(0.01,)))
    model.on_feedback('', Feedback(test_id='t', step=0, measured_displacement=(0.01,),
                                   restoring_force=(1.0,)))  # (raised: zip of 2 and 1)
    assert model.sites[''].commands == 0
    model.on_command('', Command(test_id='t', step=1, test_time=0.0, dof_names=('a',),
                                 target_displacement=(math.nan,)))
    model.on_feedback('', Feedback(test_id='t', step=1, measured_displacement=(0.01,),
                                   restoring_force=(1.0,)))  # (raised in the tracking monitor)
    assert model.sites[''].commands == 0
    feed_sine(model, 20)
    assert model.sites[''].commands == 20


def test_resends_limits_and_faults_are_counted_and_not_drawn_twice() -> None:
    model = ConsoleModel(Clock())
    command = Command(test_id='t', step=1, test_time=0.01, dof_names=('top',),
                      target_displacement=(0.001,))
    model.on_command('lab', command)
    model.on_command('lab', command)  # a re-send
    answer = Feedback(test_id='t', step=1, measured_displacement=(0.001,),
                      restoring_force=(10.0,))
    model.on_feedback('lab', answer)
    model.on_feedback('lab', answer)  # a duplicate
    model.on_feedback('lab', Feedback(test_id='t', step=2, measured_displacement=(0.0,),
                                      restoring_force=(0.0,), status=FeedbackStatus.LIMIT,
                                      message='max_force'))
    site = model.frame()['sites'][0]
    assert site['counts'] == {'commands': 1, 'resends': 1, 'ok': 2, 'limit': 1, 'fault': 0}
    assert site['dofs'][0]['samples'] == 1 and site['message'] == 'max_force'


def test_rate_and_eta_follow_the_running_statuses() -> None:
    clock = Clock()
    model = ConsoleModel(clock)
    assert model.frame()['test']['state_name'] == 'WAITING'
    for second in range(5):
        clock.now = float(second)
        model.on_status(Status(test_id='t', state=State.RUNNING, step=100 * second,
                               total_steps=1000, omega_dt=0.1))
    test = model.frame()['test']
    assert test['rate'] == pytest.approx(100.0) and test['eta'] == pytest.approx(6.0)
    clock.now = 5.0
    model.on_status(Status(test_id='t', state=State.PAUSED, step=400, total_steps=1000,
                           omega_dt=0.1))
    test = model.frame()['test']
    assert test['state_name'] == 'PAUSED' and test['rate'] == 0.0 and test['eta'] is None
    assert test['live_step'] == 400
    feed_sine(model, 600)  # the sites answered up to step 599 since that status
    assert model.frame()['test']['live_step'] == 599


def test_non_finite_values_go_to_the_page_as_null() -> None:
    model = ConsoleModel(Clock())
    model.on_status(Status(test_id='t', state=State.RUNNING, step=0, total_steps=10,
                           omega_dt=math.nan))
    text = json.dumps(model.frame(), allow_nan=False)
    assert '"omega_dt":null' in text.replace(' ', '')


def test_the_login_token_opens_one_session_once() -> None:
    clock = Clock()
    access = ConsoleAccess('secret-token', session_lifetime=10.0, clock=clock)
    assert access.login('wrong') is None and access.failed_logins == 1
    assert not access.allowed(None) and not access.allowed('made-up')
    session = access.login('secret-token')
    assert session and access.allowed(session) and access.token_spent
    assert access.login('secret-token') is None  # spent
    clock.now = 11.0
    assert not access.allowed(session)  # expired
    fresh = ConsoleAccess()
    assert len(fresh.token or '') >= 16
    other = fresh.login(fresh.token or '')
    fresh.logout(other)
    assert not fresh.allowed(other)


def test_only_the_console_controls_are_accepted() -> None:
    assert parse_control({'command': 'Pause'}, ()) == ControlRequest('pause', None,
                                                                     'from the console')
    assert parse_control({'command': 'reset', 'site': 'lab1', 'reason': 'ok'},
                         ('lab1',)) == ControlRequest('reset', 'lab1', 'ok')
    for body, match in (({'command': 'restarted'}, 'not a console control'),
                        ({'command': 'reset', 'site': 'x'}, 'unknown site'),
                        (['pause'], 'JSON object')):
        with pytest.raises(ValueError, match=match):
            parse_control(body, ('lab1',))


@pytest.fixture(scope='module')
def finished_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    raw = yaml.safe_load(DEFAULT_TEST.read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(RECORD)
    raw['test']['duration'] = 2.0
    directory = tmp_path_factory.mktemp('console_run')
    test_file = directory / 'short.yaml'
    test_file.write_text(yaml.safe_dump(raw), encoding='utf-8')
    return run_offline(load_test_file(test_file), directory / 'run', figures=True).directory


def test_a_finished_run_feeds_the_same_model(finished_run: Path) -> None:
    model = ConsoleModel(Clock())
    for path in (finished_run, finished_run / 'bag', finished_run / 'journal.pdj'):
        model = ConsoleModel(Clock())
        assert load_run_folder(path, model) == finished_run
    frame = model.frame()
    assert frame['mode'] == 'run' and frame['test']['state_name'] == 'FINISHED'
    dof = frame['sites'][0]['dofs'][0]
    assert dof['samples'] == 201  # steps 0..200
    response = np.loadtxt(finished_run / 'response.csv', delimiter=',', skiprows=1)
    header = (finished_run / 'response.csv').read_text().splitlines()[0].split(',')
    np.testing.assert_allclose(dof['measured'], response[:, header.index('xm_top')],
                               rtol=1e-5, atol=1e-12)
    assert frame['energy'] is not None and len(frame['energy']['t']) == 201
    assert 'force_deformation.png' in frame['figures']


def test_peaks_survive_the_decimation() -> None:
    rows = DecimatedRows(64, key=1)
    t = np.arange(50_000) * 0.001
    x = np.sin(2 * np.pi * 0.37 * t) * (1.0 + t / t[-1])
    for row in zip(t, x, strict=True):
        rows.append(row)
    kept = np.array(rows.rows())
    assert len(kept) <= 66
    assert np.max(np.abs(kept[:, 1])) == np.max(np.abs(x))  # the largest peak is drawn
    assert np.all(np.diff(kept[:, 0]) > 0)


def test_a_finished_tests_bridge_is_not_shown_running() -> None:
    model = ConsoleModel(Clock())
    active = Status(test_id='t', state=State.RUNNING, step=0, total_steps=0, omega_dt=0.0,
                    message='active (sim_servo): |x| <= 0.25 m')
    model.on_bridge_status('', active)
    model.on_status(Status(test_id='t', state=State.RUNNING, step=5, total_steps=9,
                           omega_dt=0.1))
    assert model.frame()['sites'][0]['bridge']['state_name'] == 'RUNNING'
    for ended in (State.FINISHED, State.ABORTED, State.INTERRUPTED):
        model.on_status(Status(test_id='t', state=ended, step=9, total_steps=9, omega_dt=0.1))
        bridge = model.frame()['sites'][0]['bridge']
        assert bridge['state_name'] == 'IDLE' and 'the test is over' in bridge['message']
    # a bridge that holds (a limit, an emergency stop) still shows it
    model.on_bridge_status('', Status(test_id='t', state=State.HOLDING, step=9, total_steps=0,
                                      omega_dt=0.0, message='EMERGENCY STOP: x'))
    assert model.frame()['sites'][0]['bridge']['state_name'] == 'HOLDING'
