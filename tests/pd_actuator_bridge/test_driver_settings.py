"""A driver's settings file (the bridge's ``driver_config``) is read once, typed, by the schema.

The file goes through ``pd_common.config.read_driver_config`` (the schema's
``DriverConfigFile``); a bad key, a bad number or a boolean for a number is one line naming the
file and the dotted path, through the real factory (``make_driver``); the typed sections reach
the driver. The bridge's parameter dataclasses are checked by the same models (one source of
truth: their fields and defaults are the models').
"""

from __future__ import annotations

from dataclasses import MISSING, fields
from pathlib import Path
from typing import Any

import pytest
import yaml

from pd_actuator_bridge.core.drivers.daqmx import DaqmxDriver
from pd_actuator_bridge.core.drivers.daqmx_config import DaqmxChannelConfig, DaqmxConfig
from pd_actuator_bridge.core.drivers.emulator_driver import EmulatorDriver
from pd_actuator_bridge.core.drivers.emulator_parameters import EmulatorParameters
from pd_actuator_bridge.core.drivers.ramp_hold import RampHoldParameters
from pd_actuator_bridge.core.drivers.registry import DriverContext, make_driver
from pd_actuator_bridge.core.error_models import ErrorModel
from pd_actuator_bridge.core.errors import BridgeConfigError
from pd_common.config.schema_driver import (
    DaqmxChannelSection,
    DaqmxSection,
    EmulatorSection,
    RampHoldSection,
)
from pd_common.config.schema_specimen import ErrorsSection
from support.sections import INLINE_GROUND_MOTION

EXAMPLE = (Path(__file__).resolve().parents[2] / 'src' / 'pd_actuator_bridge' / 'config'
           / 'daqmx_example.yaml')


def _test_file(tmp_path: Path) -> Path:
    path = tmp_path / 'test.yaml'
    path.write_text(yaml.safe_dump({
        'test': {'dt': 0.01}, 'ground_motion': INLINE_GROUND_MOTION,
        'structure': {'dof_names': ['top'], 'mass': 1000.0, 'initial_stiffness': 312559.0},
        'specimen': {'elements': [{'model': 'elastic', 'stiffness': 312559.0}]},
    }), encoding='utf-8')
    return path


def _emulator(tmp_path: Path, settings: str) -> Any:
    config = tmp_path / 'driver.yaml'
    config.write_text(settings, encoding='utf-8')
    return make_driver('emulator', DriverContext(
        1, {'test_file': str(_test_file(tmp_path)), 'driver_config': str(config)}))


@pytest.mark.parametrize(('settings', 'message'), [
    ('emulator: {kq: 1.0}\n', 'driver.yaml: emulator.kq: unknown key'),
    ('emulator: {piston_mass: -50.0}\n',
     'driver.yaml: emulator.piston_mass: must be > 0, got -50.0'),
    ('emulator: {kp: true}\n', 'driver.yaml: emulator.kp: must be a number, got true'),
    ('ramp_hold: {samples: 0}\n', 'driver.yaml: ramp_hold.samples: must be >= 1, got 0'),
    ('ramp_hold: {ramp_time: 0.1, ramp_velocity: 0.01}\n',
     ('driver.yaml: ramp_hold.ramp_velocity: ramp_time and ramp_velocity are exclusive, got both '
      '(0.1 s and 0.01 m/s)')),
    ('errors: {systematic: 1.5}\n', 'driver.yaml: errors.systematic: must be <= 1, got 1.5'),
    ('errors: {delay_steps: false}\n',
     'driver.yaml: errors.delay_steps: must be an integer, got false'),
    ('emulatr: {}\n', 'driver.yaml: emulatr: unknown key'),
    ('[1, 2]\n', 'driver.yaml: a driver settings file must be a mapping of sections, got list'),
    ('emulator: {kp: 1, kp: 2}\n', "driver.yaml: line 1: emulator.kp: given twice"),
])
def test_a_bad_settings_file_is_one_line_naming_the_file_and_the_path(
        tmp_path: Path, settings: str, message: str) -> None:
    with pytest.raises(BridgeConfigError) as info:
        _emulator(tmp_path, settings)
    assert str(info.value).startswith(message), str(info.value)
    assert '\n' not in str(info.value)


def test_a_missing_settings_file_names_it(tmp_path: Path) -> None:
    with pytest.raises(BridgeConfigError, match=r'missing.yaml: cannot read the driver settings'):
        make_driver('daqmx', DriverContext(1, {'driver_config': str(tmp_path / 'missing.yaml')}))


def test_the_typed_settings_reach_the_emulator_driver(tmp_path: Path) -> None:
    driver = _emulator(tmp_path, (
        'emulator: {kp: 5000, delay_ticks: 2}\n'
        'ramp_hold: {ramp_velocity: 0.05, samples: 4}\n'
        'errors: {systematic: -0.02, seed: 3}\n'))
    assert isinstance(driver, EmulatorDriver)
    parameters = driver.emulator.parameters
    assert parameters.kp == 5000.0 and isinstance(parameters.kp, float)
    assert parameters.delay_ticks == 2 and parameters.rate == 1000.0
    assert driver.executor.parameters == RampHoldParameters(ramp_velocity=0.05, samples=4)
    assert driver.executor.errors == ErrorModel(systematic=-0.02, seed=3)


def test_the_typed_settings_reach_the_daqmx_driver() -> None:
    driver = make_driver('daqmx', DriverContext(1, {'driver_config': str(EXAMPLE)}))
    assert isinstance(driver, DaqmxDriver)
    assert driver.config == DaqmxConfig.from_yaml(EXAMPLE)
    (channel,) = driver.config.channels
    assert (channel.name, channel.command_channel, channel.force_scale) == (
        'top', 'Dev1/ao0', 25000.0)


def test_the_daqmx_driver_needs_its_section(tmp_path: Path) -> None:
    path = tmp_path / 'settings.yaml'
    path.write_text('emulator: {}\n', encoding='utf-8')
    with pytest.raises(BridgeConfigError, match=r'^settings.yaml: daqmx: is required'):
        make_driver('daqmx', DriverContext(1, {'driver_config': str(path)}))


@pytest.mark.parametrize(('dataclass', 'model'), [
    (EmulatorParameters, EmulatorSection), (RampHoldParameters, RampHoldSection),
    (DaqmxChannelConfig, DaqmxChannelSection), (DaqmxConfig, DaqmxSection),
    (ErrorModel, ErrorsSection),
])
def test_the_parameter_classes_are_the_schemas_models(dataclass: type, model: Any) -> None:
    ours = {field.name: None if field.default is MISSING else field.default
            for field in fields(dataclass)}
    theirs = {name: None if info.is_required() else info.default
              for name, info in model.model_fields.items()}
    assert ours == theirs
