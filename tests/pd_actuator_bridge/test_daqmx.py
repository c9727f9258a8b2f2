"""Tests of the ``daqmx`` actuator driver against a fake NI-DAQmx task (no hardware here)."""

from __future__ import annotations

import importlib.abc
import math
import sys
import types
from collections.abc import Callable
from enum import Enum
from pathlib import Path
from typing import Any

import pytest

import pd_actuator_bridge.core as core
from pd_actuator_bridge.core import ActuatorBridge, BridgeConfigError, DriverError, SafetyLimits
from pd_actuator_bridge.core.drivers.daqmx import DaqmxDriver
from pd_actuator_bridge.core.drivers.daqmx_config import DaqmxChannelConfig, DaqmxConfig
from pd_common.protocol import FeedbackStatus
from support.paths import REPO

EXAMPLE = REPO / 'src' / 'pd_actuator_bridge' / 'config' / 'daqmx_example.yaml'

N_SAMPLES = 4
SETTLE = 0.25

# ---------------------------------------------------------------------- fakes


class FakeAOChannels:
    """``task.ao_channels`` recording every channel creation."""

    def __init__(self, task: FakeTask) -> None:
        self._task = task

    def add_ao_voltage_chan(self, physical_channel: str, **kwargs: Any) -> None:
        self._task.record('add_ao_voltage_chan', (physical_channel,), kwargs)


class FakeAIChannels:
    """``task.ai_channels`` recording every channel creation."""

    def __init__(self, task: FakeTask) -> None:
        self._task = task

    def add_ai_voltage_chan(self, physical_channel: str, **kwargs: Any) -> None:
        self._task.record('add_ai_voltage_chan', (physical_channel,), kwargs)


class FakeTiming:
    """``task.timing`` recording the sample clock configuration."""

    def __init__(self, task: FakeTask) -> None:
        self._task = task

    def cfg_samp_clk_timing(self, rate: float, **kwargs: Any) -> None:
        self._task.record('cfg_samp_clk_timing', (rate,), kwargs)


class FakeTask:
    """A stand-in for ``nidaqmx.Task`` that records every call it receives."""

    def __init__(self, rig: FakeRig, role: str) -> None:
        self.rig = rig
        self.role = role
        self.calls: list[tuple[str, tuple[Any, ...], dict[str, Any]]] = []
        self.ao_channels = FakeAOChannels(self)
        self.ai_channels = FakeAIChannels(self)
        self.timing = FakeTiming(self)

    def record(self, name: str, args: tuple[Any, ...], kwargs: dict[str, Any]) -> None:
        self.calls.append((name, args, kwargs))
        self.rig.events.append((self.role, name))
        failure = self.rig.fail_on.get((self.role, name))
        if failure is not None:
            raise failure

    def write(self, data: Any, **kwargs: Any) -> int:
        self.record('write', (data,), kwargs)
        return 1

    def read(self, **kwargs: Any) -> Any:
        self.record('read', (), kwargs)
        return self.rig.feedback(self.rig, kwargs['number_of_samples_per_channel'])

    def close(self) -> None:
        self.record('close', (), {})

    def named(self, name: str) -> list[tuple[tuple[Any, ...], dict[str, Any]]]:
        return [(args, kwargs) for call, args, kwargs in self.calls if call == name]

    @property
    def writes(self) -> list[Any]:
        return [args[0] for args, _ in self.named('write')]

    @property
    def close_count(self) -> int:
        return len(self.named('close'))


def constant_feedback(volts: list[float]) -> Callable[[FakeRig, int], list[list[float]]]:
    """Every input channel reads a constant voltage (one value per channel)."""

    def feedback(rig: FakeRig, n: int) -> list[list[float]]:
        return [[v] * n for v in volts]

    return feedback


class FakeRig:
    """The injectable task factory; it also plays the controller behind the DAQ."""

    def __init__(
        self,
        feedback: Callable[[FakeRig, int], Any] | None = None,
        fail_on: dict[tuple[str, str], Exception] | None = None,
    ) -> None:
        self.tasks: list[FakeTask] = []
        self.events: list[tuple[str, Any]] = []
        self.fail_on = dict(fail_on or {})
        self.feedback = feedback or constant_feedback([0.0, 0.0])

    def __call__(self, role: str) -> FakeTask:
        self.events.append(('factory', role))
        failure = self.fail_on.get(('factory', role))
        if failure is not None:
            raise failure
        task = FakeTask(self, role)
        self.tasks.append(task)
        return task

    def task(self, role: str) -> FakeTask:
        matches = [t for t in self.tasks if t.role == role]
        assert len(matches) == 1, f'{len(matches)} {role} tasks'
        return matches[0]

    def sleep(self, seconds: float) -> None:
        self.events.append(('sleep', seconds))


def channel(index: int = 0, **overrides: Any) -> dict[str, Any]:
    """A channel mapping: 0.01 m/V command (+1 mm offset, +-5 V), 0.02 m/V, 25 kN/V."""
    mapping: dict[str, Any] = {
        'name': f'dof{index}',
        'command_channel': f'Dev1/ao{index}',
        'command_scale': 0.01,
        'command_offset': 0.001,
        'command_min_voltage': -5.0,
        'command_max_voltage': 5.0,
        'displacement_channel': f'Dev1/ai{2 * index}',
        'displacement_scale': 0.02,
        'displacement_offset': -0.001,
        'force_channel': f'Dev1/ai{2 * index + 1}',
        'force_scale': 25000.0,
        'force_offset': 100.0,
    }
    mapping.update(overrides)
    return mapping


def config_mapping(n_dof: int = 1, **overrides: Any) -> dict[str, Any]:
    mapping: dict[str, Any] = {
        'sample_rate': 1000.0,
        'samples_per_read': N_SAMPLES,
        'terminal_configuration': 'diff',
        'settle_time': SETTLE,
        'timeout': 2.0,
        'channels': [channel(i) for i in range(n_dof)],
    }
    mapping.update(overrides)
    return mapping


def make_driver(
    n_dof: int = 1, rig: FakeRig | None = None, **overrides: Any
) -> tuple[DaqmxDriver, FakeRig]:
    rig = rig or FakeRig(feedback=constant_feedback([0.0] * (2 * n_dof)))
    config = DaqmxConfig.from_mapping(config_mapping(n_dof, **overrides), source='test.yaml')
    return DaqmxDriver(config, task_factory=rig, sleep=rig.sleep), rig


def opened(n_dof: int = 1, rig: FakeRig | None = None, **overrides: Any):
    driver, rig = make_driver(n_dof, rig, **overrides)
    driver.open()
    return driver, rig


# ---------------------------------------------------------------------- open / channels


def test_open_creates_channels_with_physical_channels_ranges_and_timing() -> None:
    driver, rig = opened(n_dof=2)
    command = rig.task('command')
    feedback = rig.task('feedback')
    assert command.named('add_ao_voltage_chan') == [
        (('Dev1/ao0',), {'min_val': -5.0, 'max_val': 5.0}),
        (('Dev1/ao1',), {'min_val': -5.0, 'max_val': 5.0}),
    ]
    # Displacement then force per DOF, every input with its explicit +-10 V range.
    ai = {'terminal_config': 'DIFF', 'min_val': -10.0, 'max_val': 10.0}
    assert feedback.named('add_ai_voltage_chan') == [
        (('Dev1/ai0',), ai), (('Dev1/ai1',), ai), (('Dev1/ai2',), ai), (('Dev1/ai3',), ai),
    ]
    assert feedback.named('cfg_samp_clk_timing') == [
        ((1000.0,), {'sample_mode': 'FINITE', 'samps_per_chan': N_SAMPLES})
    ]
    # open() measures the initial state but writes nothing.
    assert command.writes == []
    assert feedback.named('read') == [
        ((), {'number_of_samples_per_channel': N_SAMPLES, 'timeout': 2.0})
    ]
    assert driver.is_open


def test_open_measures_initial_position_and_force() -> None:
    rig = FakeRig(feedback=constant_feedback([0.5, 0.2]))
    driver, _ = make_driver(rig=rig)
    with pytest.raises(DriverError, match='open'):
        driver.position()
    driver.open()
    assert driver.position() == pytest.approx([0.02 * 0.5 - 0.001])
    assert driver.last_force == pytest.approx([25000.0 * 0.2 + 100.0])


# ---------------------------------------------------------------------- command


def test_command_converts_metres_to_volts_and_writes_a_scalar_for_one_dof() -> None:
    driver, rig = opened()
    driver.command(1, [0.021])  # (0.021 - 0.001) / 0.01 = 2 V
    (data,) = rig.task('command').writes
    assert data == pytest.approx(2.0)
    assert isinstance(data, float)
    (_, kwargs), = rig.task('command').named('write')
    assert kwargs == {'auto_start': True, 'timeout': 2.0}
    assert driver.last_voltage == pytest.approx((2.0,))


def test_command_writes_one_value_per_channel_for_several_dof() -> None:
    driver, rig = opened(n_dof=2)
    driver.command(1, [0.021, -0.019])
    (data,) = rig.task('command').writes
    assert data == pytest.approx([2.0, -2.0])


def test_command_settles_then_reads_averages_and_converts_feedback() -> None:
    samples = [[1.0, 1.2, 0.8, 1.0], [0.1, 0.3, 0.2, 0.2]]
    rig = FakeRig(feedback=lambda rig, n: [list(s) for s in samples])
    driver, _ = opened(rig=rig)
    received: list[tuple[int, list[float], list[float]]] = []
    driver.set_measurement_callback(
        lambda m: received.append((m.step, list(m.displacement), list(m.force))))
    rig.events.clear()
    driver.command(7, [0.011])
    assert rig.events == [('command', 'write'), ('sleep', SETTLE), ('feedback', 'read')]
    assert len(received) == 1
    step, displacement, force = received[0]
    assert step == 7
    assert displacement == pytest.approx([0.02 * 1.0 - 0.001])
    assert force == pytest.approx([25000.0 * 0.2 + 100.0])
    assert driver.position() == pytest.approx(displacement)


def test_zero_settle_time_does_not_sleep() -> None:
    driver, rig = opened(settle_time=0.0)
    driver.command(1, [0.001])
    assert ('sleep', 0.0) not in rig.events
    assert not [e for e in rig.events if e[0] == 'sleep']


@pytest.mark.parametrize(
    'target',
    [
        [0.06],            # (0.06 - 0.001) / 0.01 = 5.9 V > 5 V
        [-0.05],           # -5.1 V < -5 V
        [0.0510001],       # just beyond +5 V
    ],
)
def test_out_of_range_voltage_raises_and_writes_nothing(target: list[float]) -> None:
    driver, rig = opened()
    reads_before = len(rig.task('feedback').named('read'))
    with pytest.raises(DriverError, match='outside the command range') as info:
        driver.command(1, target)
    assert 'nothing written' in str(info.value)
    assert '\n' not in str(info.value)
    assert rig.task('command').writes == []
    assert len(rig.task('feedback').named('read')) == reads_before
    assert driver.last_voltage is None


def test_voltage_exactly_at_the_limit_is_written() -> None:
    driver, rig = opened(channels=[channel(command_offset=0.0)])
    driver.command(1, [0.05])  # exactly 5 V
    assert rig.task('command').writes == [pytest.approx(5.0)]


def test_one_bad_dof_blocks_the_whole_command() -> None:
    driver, rig = opened(n_dof=2)
    with pytest.raises(DriverError, match=r'DOF 1 \(dof1\)'):
        driver.command(1, [0.011, 0.2])
    assert rig.task('command').writes == []


@pytest.mark.parametrize('bad', [math.nan, math.inf, -math.inf])
def test_non_finite_target_rejected(bad: float) -> None:
    driver, rig = opened()
    with pytest.raises(DriverError, match='non-finite'):
        driver.command(1, [bad])
    assert rig.task('command').writes == []


def test_wrong_target_length_rejected() -> None:
    driver, rig = opened()
    with pytest.raises(DriverError, match='expected 1'):
        driver.command(1, [0.0, 0.0])
    assert rig.task('command').writes == []


def test_command_while_closed_raises() -> None:
    driver, rig = make_driver()
    with pytest.raises(DriverError, match='closed'):
        driver.command(1, [0.0])
    assert rig.tasks == []


def test_write_failure_is_a_driver_error_and_nothing_is_read() -> None:
    rig = FakeRig(fail_on={('command', 'write'): RuntimeError('device gone\nmore text')})
    driver, _ = opened(rig=rig)
    reads_before = len(rig.task('feedback').named('read'))
    with pytest.raises(DriverError, match='writing the command failed: RuntimeError: device gone'):
        driver.command(1, [0.011])
    assert len(rig.task('feedback').named('read')) == reads_before


# ---------------------------------------------------------------------- feedback faults


def test_clipped_feedback_sample_is_a_driver_error() -> None:
    rig = FakeRig(feedback=lambda rig, n: [[0.0] * n, [9.0] * (n - 1) + [10.5]])
    driver, _ = make_driver(rig=rig)
    with pytest.raises(DriverError, match=r'force sample 10.5 V on Dev1/ai1 .*clipped'):
        driver.open()


def test_non_finite_feedback_sample_is_a_driver_error() -> None:
    driver, rig = opened()
    rig.feedback = lambda rig, n: [[0.0] * (n - 1) + [math.nan], [0.0] * n]
    with pytest.raises(DriverError, match='non-finite displacement sample on Dev1/ai0'):
        driver.command(1, [0.001])


def test_feedback_of_the_wrong_shape_is_a_driver_error() -> None:
    driver, rig = opened()
    rig.feedback = lambda rig, n: [[0.0] * (n - 1), [0.0] * (n - 1)]
    with pytest.raises(DriverError, match=r'shape \(2, 3\), expected \(2, 4\)'):
        driver.command(1, [0.001])


# ---------------------------------------------------------------------- hold


def test_hold_rewrites_the_last_voltage() -> None:
    driver, rig = opened()
    driver.command(1, [0.021])
    driver.command(2, [0.031])
    driver.hold()
    assert rig.task('command').writes == [pytest.approx(2.0), pytest.approx(3.0),
                                          pytest.approx(3.0)]
    assert driver.hold_count == 1


def test_hold_before_any_command_writes_nothing() -> None:
    driver, rig = opened()
    driver.hold()
    assert rig.task('command').writes == []


def test_hold_after_a_refused_command_rewrites_the_previous_voltage() -> None:
    driver, rig = opened()
    driver.command(1, [0.021])
    with pytest.raises(DriverError):
        driver.command(2, [0.5])
    driver.hold()
    assert rig.task('command').writes == [pytest.approx(2.0), pytest.approx(2.0)]


def test_hold_while_closed_raises() -> None:
    driver, _ = make_driver()
    with pytest.raises(DriverError, match='closed'):
        driver.hold()


# ---------------------------------------------------------------------- close / rollback


def test_close_closes_all_tasks_and_is_idempotent() -> None:
    driver, rig = opened()
    driver.close()
    assert rig.task('command').close_count == 1
    assert rig.task('feedback').close_count == 1
    assert not driver.is_open
    driver.close()
    assert rig.task('command').close_count == 1
    assert rig.task('feedback').close_count == 1
    with pytest.raises(DriverError, match='closed'):
        driver.command(1, [0.0])


def test_close_failure_still_closes_the_other_task() -> None:
    rig = FakeRig(fail_on={('feedback', 'close'): RuntimeError('stuck')})
    driver, _ = opened(rig=rig)
    with pytest.raises(DriverError, match=r'close.*stuck'):
        driver.close()
    assert rig.task('command').close_count == 1
    assert not driver.is_open
    driver.close()  # nothing left to close
    assert rig.task('command').close_count == 1


@pytest.mark.parametrize(
    ('failure', 'expected_closed'),
    [
        (('command', 'add_ao_voltage_chan'), ['command']),
        (('factory', 'feedback'), ['command']),
        (('feedback', 'add_ai_voltage_chan'), ['command', 'feedback']),
        (('feedback', 'cfg_samp_clk_timing'), ['command', 'feedback']),
        (('feedback', 'read'), ['command', 'feedback']),
    ],
)
def test_open_failure_midway_closes_the_tasks_already_created(
    failure: tuple[str, str], expected_closed: list[str]
) -> None:
    rig = FakeRig(fail_on={failure: RuntimeError('DAQmx error -200220')})
    driver, _ = make_driver(rig=rig)
    with pytest.raises(DriverError, match=r'open.*-200220') as info:
        driver.open()
    assert '\n' not in str(info.value)
    assert sorted(t.role for t in rig.tasks) == expected_closed
    for task in rig.tasks:
        assert task.close_count == 1, task.role
        assert task.writes == []
    assert not driver.is_open
    driver.close()  # nothing left to close
    for task in rig.tasks:
        assert task.close_count == 1


def test_open_twice_creates_the_tasks_once() -> None:
    driver, rig = opened()
    driver.open()
    assert len(rig.tasks) == 2


# ---------------------------------------------------------------------- real nidaqmx path


class _BlockNidaqmx(importlib.abc.MetaPathFinder):
    """Import hook making ``import nidaqmx`` fail as if the package were not installed."""

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> None:
        if fullname == 'nidaqmx' or fullname.startswith('nidaqmx.'):
            raise ModuleNotFoundError(f'No module named {fullname!r}', name=fullname)
        return


def _forget_nidaqmx(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in list(sys.modules):
        if name == 'nidaqmx' or name.startswith('nidaqmx.'):
            monkeypatch.delitem(sys.modules, name)


def test_missing_nidaqmx_gives_a_clear_one_line_error(monkeypatch: pytest.MonkeyPatch) -> None:
    _forget_nidaqmx(monkeypatch)
    monkeypatch.setattr(sys, 'meta_path', [_BlockNidaqmx(), *sys.meta_path])
    config = DaqmxConfig.from_mapping(config_mapping())
    driver = DaqmxDriver(config)  # constructing never imports nidaqmx
    with pytest.raises(DriverError, match='install nidaqmx') as info:
        driver.open()
    assert '\n' not in str(info.value)
    assert not driver.is_open


def _install_fake_nidaqmx(
    monkeypatch: pytest.MonkeyPatch, rig: FakeRig, terminal_members: dict[str, int]
) -> types.ModuleType:
    _forget_nidaqmx(monkeypatch)
    module = types.ModuleType('nidaqmx')
    constants = types.ModuleType('nidaqmx.constants')
    constants.TerminalConfiguration = Enum('TerminalConfiguration', terminal_members)
    constants.AcquisitionType = Enum('AcquisitionType', {'FINITE': 10178, 'CONTINUOUS': 10123})
    module.constants = constants
    module.Task = lambda new_task_name='': rig('command' if not rig.tasks else 'feedback')
    monkeypatch.setitem(sys.modules, 'nidaqmx', module)
    monkeypatch.setitem(sys.modules, 'nidaqmx.constants', constants)
    return constants


def test_default_factory_uses_nidaqmx_task_and_constants(monkeypatch: pytest.MonkeyPatch) -> None:
    rig = FakeRig()
    constants = _install_fake_nidaqmx(
        monkeypatch, rig,
        {'DEFAULT': -1, 'RSE': 10083, 'NRSE': 10078, 'DIFF': 10106, 'PSEUDO_DIFF': 12529},
    )
    driver = DaqmxDriver(DaqmxConfig.from_mapping(config_mapping()), sleep=rig.sleep)
    driver.open()
    assert [t.role for t in rig.tasks] == ['command', 'feedback']
    (_, kwargs), _ = rig.task('feedback').named('add_ai_voltage_chan')
    assert kwargs['terminal_config'] is constants.TerminalConfiguration.DIFF
    (_, timing), = rig.task('feedback').named('cfg_samp_clk_timing')
    assert timing['sample_mode'] is constants.AcquisitionType.FINITE


def test_older_nidaqmx_terminal_names_are_accepted(monkeypatch: pytest.MonkeyPatch) -> None:
    rig = FakeRig()
    constants = _install_fake_nidaqmx(
        monkeypatch, rig,
        {'DEFAULT': -1, 'RSE': 10083, 'NRSE': 10078, 'DIFFERENTIAL': 10106,
         'PSEUDODIFFERENTIAL': 12529},
    )
    mapping = config_mapping(terminal_configuration='pseudo_diff')
    driver = DaqmxDriver(DaqmxConfig.from_mapping(mapping), sleep=rig.sleep)
    driver.open()
    (_, kwargs), _ = rig.task('feedback').named('add_ai_voltage_chan')
    assert kwargs['terminal_config'] is constants.TerminalConfiguration.PSEUDODIFFERENTIAL


# ---------------------------------------------------------------------- configuration


def _with_channel(**overrides: Any) -> dict[str, Any]:
    return config_mapping(channels=[channel(**overrides)])


def _without_channel_key(key: str) -> dict[str, Any]:
    mapping = channel()
    del mapping[key]
    return config_mapping(channels=[mapping])


@pytest.mark.parametrize(
    ('mapping', 'message'),
    [
        (_without_channel_key('command_channel'),
         'test.yaml: daqmx.channels.0.command_channel: is required'),
        (_with_channel(comand_scale=0.01),
         'test.yaml: daqmx.channels.0.comand_scale: unknown key'),
        (_with_channel(command_scale=0.0), ('test.yaml: daqmx.channels.0.command_scale: must not '
                                            'be 0, got 0.0')),
        (_with_channel(force_scale=True), ('test.yaml: daqmx.channels.0.force_scale: must be a '
                                           'number, got true')),
        (_with_channel(displacement_scale='0.01'), ('daqmx.channels.0.displacement_scale: must be '
                                                    "a number, got '0.01'")),
        (_with_channel(force_offset=math.nan), ('daqmx.channels.0.force_offset: must be a finite '
                                                'number, got nan')),
        (_with_channel(command_max_voltage=12.0), ('daqmx.channels.0.command_max_voltage: must be '
                                                   '<= 10, got 12.0')),
        (_with_channel(command_min_voltage=5.0), ('daqmx.channels.0.command_min_voltage: must be '
                                                  'below command_max_voltage')),
        (_with_channel(command_channel='Dev1/ao0:1'), ('daqmx.channels.0.command_channel: must be '
                                                       'one physical channel such as Dev1/ao0 (no '
                                                       "list or range), got 'Dev1/ao0:1'")),
        (_with_channel(command_channel=''), ('daqmx.channels.0.command_channel: must be one '
                                             'physical channel')),
        (_with_channel(force_channel='Dev1/ai0'), ('daqmx.channels.0.force_channel: same physical '
                                                   'channel as displacement_channel (Dev1/ai0)')),
        (_with_channel(name=3), 'daqmx.channels.0.name: must be a string, got 3'),
        (config_mapping(channels=[channel(0), channel(1, command_channel='dev1/ao0')]),
         ('daqmx.channels.1.command_channel: physical channel dev1/ao0 is already used by '
          'channels.0.command_channel')),
        (config_mapping(channels=[channel(0), channel(1, name='dof0')]),
         "daqmx.channels.1.name: duplicate DOF name 'dof0' (channels.0.name)"),
        (config_mapping(channels=[]), ('test.yaml: daqmx.channels: must have at least 1 item(s), '
                                       'got []')),
        (config_mapping(channels={'a': 1}), 'test.yaml: daqmx.channels: must be a list'),
        (config_mapping(channels=['Dev1/ao0']), ('test.yaml: daqmx.channels.0: must be a mapping, '
                                                 "got 'Dev1/ao0'")),
        (config_mapping(samples_per_read=0),
         'test.yaml: daqmx.samples_per_read: must be >= 1, got 0'),
        (config_mapping(samples_per_read=10.0), ('test.yaml: daqmx.samples_per_read: must be an '
                                                 'integer, got 10.0')),
        (config_mapping(sample_rate=-1.0), 'test.yaml: daqmx.sample_rate: must be > 0, got -1.0'),
        (config_mapping(terminal_configuration='differential'),
         ("test.yaml: daqmx.terminal_configuration: must be one of 'default', 'rse', 'nrse', "
          "'diff', 'pseudo_diff', got 'differential'")),
        (config_mapping(settle_time=-0.1), 'test.yaml: daqmx.settle_time: must be >= 0, got -0.1'),
        (config_mapping(timeout=0.004), 'test.yaml: daqmx.timeout: 0.004 s does not exceed'),
        (config_mapping(sample_rte=1000.0), 'test.yaml: daqmx.sample_rte: unknown key'),
        ({'sample_rate': 1000.0}, 'test.yaml: daqmx.channels: is required'),
        (['channels'], 'test.yaml: daqmx: must be a mapping'),
    ],
)
def test_config_errors_are_one_line_and_name_the_key(mapping: Any, message: str) -> None:
    with pytest.raises(BridgeConfigError) as info:
        DaqmxConfig.from_mapping(mapping, source='test.yaml', path='daqmx')
    text = str(info.value)
    assert message in text
    assert '\n' not in text


def test_config_defaults_and_direct_construction() -> None:
    config = DaqmxConfig.from_mapping(
        {'channels': [{'command_channel': 'Dev1/ao0', 'command_scale': 0.01,
                       'displacement_channel': 'Dev1/ai0', 'displacement_scale': 0.01,
                       'force_channel': 'Dev1/ai1', 'force_scale': 1000}]}
    )
    (only,) = config.channels
    assert (only.command_min_voltage, only.command_max_voltage) == (-10.0, 10.0)
    assert only.force_scale == 1000.0 and isinstance(only.force_scale, float)
    assert (config.sample_rate, config.samples_per_read, config.terminal_configuration,
            config.settle_time, config.timeout) == (1000.0, 100, 'diff', 0.5, 10.0)
    with pytest.raises(BridgeConfigError, match=r'^DaqmxChannelConfig: command_scale: must not'):
        DaqmxChannelConfig('Dev1/ao0', 0, 'Dev1/ai0', 0.01, 'Dev1/ai1', 1000.0)
    with pytest.raises(BridgeConfigError, match=r'^DaqmxConfig: channels: must have at least 1'):
        DaqmxConfig(channels=())


def test_example_yaml_loads_and_drives_a_fake_task() -> None:
    config = DaqmxConfig.from_yaml(EXAMPLE)
    assert config.n_dof == 1
    (dof,) = config.channels
    assert (dof.command_channel, dof.displacement_channel, dof.force_channel) == (
        'Dev1/ao0', 'Dev1/ai0', 'Dev1/ai1')
    rig = FakeRig()
    driver = DaqmxDriver(config, task_factory=rig, sleep=rig.sleep)
    driver.open()
    driver.command(0, [0.01])
    assert rig.task('command').writes == [pytest.approx(0.01 / dof.command_scale)]


def test_from_yaml_errors_name_the_file(tmp_path: Path) -> None:
    path = tmp_path / 'rig.yaml'
    path.write_text('bridge: {}\n', encoding='utf-8')  # (a section no driver reads: refused)
    with pytest.raises(BridgeConfigError, match=r'^rig.yaml: bridge: unknown key$'):
        DaqmxConfig.from_yaml(path)
    path.write_text('emulator: {}\n', encoding='utf-8')
    with pytest.raises(BridgeConfigError, match=r'^rig.yaml: daqmx: is required'):
        DaqmxConfig.from_yaml(path)
    path.write_text('daqmx:\n  channels: [\n', encoding='utf-8')
    with pytest.raises(BridgeConfigError, match=r'rig.yaml: '):
        DaqmxConfig.from_yaml(path)
    path.write_text('daqmx:\n  channels: []\n', encoding='utf-8')
    message = r'^rig.yaml: daqmx.channels: must have at least 1 item\(s\), got \[\]$'
    with pytest.raises(BridgeConfigError, match=message):
        DaqmxConfig.from_yaml(path)


# ---------------------------------------------------------------------- under the bridge


def spring_rig(config: DaqmxConfig, stiffness: float) -> FakeRig:
    """A controller that reaches every command exactly, on a linear specimen."""

    def feedback(rig: FakeRig, n: int) -> list[list[float]]:
        writes = next(t for t in rig.tasks if t.role == 'command').writes
        last = writes[-1] if writes else [0.0] * config.n_dof
        volts = [last] if isinstance(last, float) else list(last)
        rows = []
        for v, ch in zip(volts, config.channels):
            x = ch.command_scale * v + ch.command_offset
            rows.append([(x - ch.displacement_offset) / ch.displacement_scale] * n)
            rows.append([(stiffness * x - ch.force_offset) / ch.force_scale] * n)
        return rows

    return FakeRig(feedback=feedback)


BRIDGE_CHANNEL = {
    'command_channel': 'Dev1/ao0', 'command_scale': 0.01,
    'displacement_channel': 'Dev1/ai0', 'displacement_scale': 0.01,
    'force_channel': 'Dev1/ai1', 'force_scale': 1000.0,
}


def bridge_setup(limits: SafetyLimits, **channel_overrides: Any):
    config = DaqmxConfig.from_mapping(
        {'channels': [{**BRIDGE_CHANNEL, **channel_overrides}], 'samples_per_read': 2,
         'settle_time': 0.0}
    )
    rig = spring_rig(config, stiffness=50000.0)
    driver = DaqmxDriver(config, task_factory=rig, sleep=rig.sleep)
    driver.open()
    bridge = ActuatorBridge(driver, limits, ['top'])
    return bridge, driver, rig


def test_driver_under_the_bridge_completes_steps() -> None:
    limits = SafetyLimits(max_displacement=0.05, max_increment=0.02, max_force=5000.0)
    bridge, _, rig = bridge_setup(limits)
    reply0 = bridge.handle_command('t', 0, [0.0])
    reply1 = bridge.handle_command('t', 1, [0.01])
    assert reply0 is not None and reply0.status is FeedbackStatus.OK
    assert reply1 is not None and reply1.status is FeedbackStatus.OK
    assert reply1.measured_displacement == pytest.approx((0.01,))
    assert reply1.restoring_force == pytest.approx((500.0,))
    assert rig.task('command').writes == [pytest.approx(0.0), pytest.approx(1.0)]


def test_bridge_limit_keeps_a_command_from_reaching_the_task() -> None:
    # 0.04 m is 4 V, well inside the DAQ's +-10 V: only the bridge can stop it.
    limits = SafetyLimits(max_displacement=0.035, max_increment=0.05, max_force=5000.0)
    bridge, driver, rig = bridge_setup(limits)
    assert bridge.handle_command('t', 0, [0.01]).status is FeedbackStatus.OK
    reply = bridge.handle_command('t', 1, [0.04])
    assert reply is not None and reply.status is FeedbackStatus.LIMIT
    assert bridge.state == 'holding'
    writes = rig.task('command').writes
    assert pytest.approx(4.0) not in writes
    # The only write after the refusal is the hold re-writing the last voltage.
    assert writes == [pytest.approx(1.0), pytest.approx(1.0)]
    assert driver.hold_count == 1


def test_driver_voltage_limit_backs_up_a_wide_bridge_limit() -> None:
    # The bridge allows 0.2 m but the command channel stops at 3 V = 0.03 m.
    limits = SafetyLimits(max_displacement=0.2, max_increment=0.2, max_force=1.0e6)
    bridge, _, rig = bridge_setup(limits, command_max_voltage=3.0)
    reply = bridge.handle_command('t', 0, [0.05])
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert 'nothing written' in reply.message
    assert rig.task('command').writes == []  # and hold had nothing to re-write


def test_public_names_are_exported_from_the_core() -> None:
    for name in ('DaqmxChannelConfig', 'DaqmxConfig', 'DaqmxDriver'):
        assert name in core.__all__
        assert getattr(core, name) is globals()[name]
