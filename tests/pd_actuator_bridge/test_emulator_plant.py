"""The servo-hydraulic emulator under the transfer-system interface (plant model emulator)."""

from __future__ import annotations

import numpy as np
import pytest

import pd_actuator_bridge.core.drivers  # noqa: F401  (registers the emulator plant)
from pd_actuator_bridge.core.drivers.emulator_plant import EmulatorPlant
from pd_common.errors import RthsError
from pd_common.rths import ContinuousActuator, continuous_from_config, plant_from_config

DT = 1.0 / 4096.0


def test_emulator_plant_settles_on_the_command_and_lags_a_fast_one() -> None:
    plant = plant_from_config({'model': 'emulator'}, DT, 'plant')
    assert isinstance(plant, EmulatorPlant) and plant.dt == DT
    assert plant.emulator.rate == pytest.approx(4096.0)
    plant.reset()
    for _ in range(4096):        # one second at 1 mm
        plant.advance(1e-3)
    assert plant.output() == pytest.approx(1e-3, rel=2e-3)   # its PID integrates the error out
    # a 5 Hz sine: the output lags the command (the servo loop's delay), amplitude near 1
    plant.reset()
    t = np.arange(8192) * DT
    command = 1e-3 * np.sin(2 * np.pi * 5.0 * t)
    output = []
    for u in command:
        plant.advance(float(u))
        output.append(plant.output())
    y = np.array(output)[4096:]
    c = command[4096:]
    lags = [float(np.dot(np.roll(c, k), y)) for k in range(200)]
    lag = int(np.argmax(lags))
    assert 0 < lag < 200
    assert 0.8 < np.std(y) / np.std(c) < 1.2


def test_the_continuous_actuator_runs_on_the_emulator() -> None:
    config = continuous_from_config({'plant': {'model': 'emulator'}}, 'sites.lab1.transfer_system')
    actuator = ContinuousActuator(config, 1.0 / 1024.0)
    targets = 1e-3 * np.sin(2 * np.pi * 1.0 * np.arange(1, 1025) / 1024.0)
    measured = [actuator.step(float(x)).displacement for x in targets]
    assert np.max(np.abs(np.array(measured) - targets)) < 0.2e-3


@pytest.mark.parametrize(('section', 'match'), [
    ({'model': 'emulator', 'rate': 1000.0}, r'plant\.rate: is the transfer system'),
    ({'model': 'emulator', 'stiffness': -1.0}, r'plant\.stiffness: must be a positive'),
    ({'model': 'emulator', 'valve_flowz': 1.0}, 'valve_flowz'),
])
def test_bad_emulator_sections_are_one_line(section: dict, match: str) -> None:
    with pytest.raises(RthsError, match=match) as error:
        plant_from_config(section, DT, 'plant')
    assert '\n' not in str(error.value)
