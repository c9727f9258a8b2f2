"""A plug-in package adds a hysteresis model, a driver and a scheme without editing ours.

``tests/plugins/pd_plugin_example`` declares, in its ``pyproject.toml``, one entry point per
kind (``pd.hysteresis``: ``linear_spring``, ``pd.drivers``: ``spring_rig``, ``pd.schemes``:
``central_difference``, ``pd.compensators``: ``scaled``, ``pd.plants``: ``scaled_ideal``) and one
that does not load (``broken_spring``). The test installs it
into a temporary folder (:func:`support.plugin_package.install_example_plugin`) and, with
that folder on ``PYTHONPATH``:

* runs ``offline`` on a test whose specimen is the plug-in's spring under the plug-in's
  scheme: its ``response.csv`` is byte for byte the one of the built-in elastic model under
  Newmark explicit (the same spring, the same recursion);
* builds the plug-in's driver with ``make_driver`` from its declared parameters and reads the
  spring force it measures; builds its compensator and plant model by name.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from support.paths import ELCENTRO, PACKAGES, REPO
from support.plugin_package import install_example_plugin

GROUND_MOTION = ELCENTRO
K = 312559.0  # N/m: the thesis specimen's initial stiffness


@pytest.fixture(scope='module')
def site_packages(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The plug-in installed into a folder of its own (metadata and package)."""
    return install_example_plugin(tmp_path_factory.mktemp('plugin'))


def environment(site: Path) -> dict[str, str]:
    """The subprocess's environment: the plug-in, then the source tree, then the workspace."""
    env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST', 'ROS_DOMAIN_ID': '62'}
    paths = [str(site), *(str(REPO / 'src' / package) for package in PACKAGES)]
    if env.get('PYTHONPATH'):
        paths.append(env['PYTHONPATH'])
    env['PYTHONPATH'] = os.pathsep.join(paths)
    return env


def write_test(path: Path, scheme: str, element: dict[str, object]) -> Path:
    """A short linear SDOF test under El Centro with ``element`` as its specimen."""
    path.write_text(yaml.safe_dump({
        'test': {'id': path.stem, 'scheme': scheme, 'dt': 0.01, 'duration': 3.0},
        'structure': {'dof_names': ['top'], 'mass': 2543.4, 'damping': {'ratio': 0.05},
                      'initial_stiffness': K, 'influence': [1.0]},
        'ground_motion': {'file': str(GROUND_MOTION), 'units': 'g', 'g': 9.81},
        'specimen': {'topology': 'independent', 'elements': [element]},
    }), encoding='utf-8')
    return path


def offline(test: Path, out: Path, site: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, '-m', 'pd_integrator.offline', str(test), '--out', str(out),
         '--no-figures', '--quiet'],
        env=environment(site), cwd=test.parent, capture_output=True, text=True, check=False,
        stdin=subprocess.DEVNULL, timeout=300)


def test_offline_runs_the_plugins_model_and_scheme(site_packages: Path, tmp_path: Path) -> None:
    built_in = offline(write_test(tmp_path / 'built_in.yaml', 'newmark_explicit',
                                 {'model': 'elastic', 'stiffness': K}),
                       tmp_path / 'built_in', site_packages)
    assert built_in.returncode == 0, built_in.stderr
    plugin = offline(write_test(tmp_path / 'plugin.yaml', 'central_difference',
                               {'model': 'linear_spring', 'stiffness': 2.0 * K, 'factor': 0.5}),
                     tmp_path / 'plugin', site_packages)
    assert plugin.returncode == 0, plugin.stderr
    expected = (tmp_path / 'built_in' / 'response.csv').read_bytes()
    response = (tmp_path / 'plugin' / 'response.csv').read_bytes()
    assert expected.count(b'\n') > 300  # 3 s at 0.01 s
    assert response == expected
    # The broken plug-in is one line naming its entry point, never a traceback.
    assert 'Traceback' not in plugin.stderr
    broken = [line for line in plugin.stderr.splitlines() if 'broken_spring' in line]
    assert len(broken) == 1, plugin.stderr
    assert 'pd_plugin_example.missing:NOTHING' in broken[0]
    assert 'ModuleNotFoundError' in broken[0]


def test_a_plugin_models_keys_are_checked_by_its_declarations(site_packages: Path,
                                                               tmp_path: Path) -> None:
    bad = offline(write_test(tmp_path / 'bad.yaml', 'central_difference',
                            {'model': 'linear_spring', 'stiffness': K, 'factor': 20.0}),
                  tmp_path / 'bad', site_packages)
    assert bad.returncode != 0
    assert 'specimen.elements[0].factor: must be in (0, 10], got 20.0' in bad.stderr
    unknown = offline(write_test(tmp_path / 'unknown.yaml', 'newmark_explicit',
                                {'model': 'broken_spring', 'stiffness': K}),
                      tmp_path / 'unknown', site_packages)
    assert unknown.returncode != 0
    assert ("specimen.elements.0.model: must be one of 'elastic', 'epp', 'bilinear', "
            "'pushover', 'bouc_wen', 'linear_spring' (its plug-in did not load: "
            'ModuleNotFoundError') in unknown.stderr  # the schema, told the registered models


DRIVER_SCRIPT = """
import json
from pd_actuator_bridge.core import DriverContext, driver_names, driver_spec, make_driver
from pd_actuator_bridge.core.drivers.registry import DRIVERS

spec = driver_spec('spring_rig')
measured = []
driver = make_driver('spring_rig', DriverContext(2, {'spring_stiffness': 2.0e5}))
driver.set_measurement_callback(measured.append)
driver.open()
driver.command(1, [0.01, -0.02])
default = make_driver('spring_rig', DriverContext(1))
print(json.dumps({
    'names': list(driver_names()),
    'parameters': [[p.name, p.default, p.description] for p in spec.parameters],
    'class': type(driver).__name__,
    'force': list(measured[0].force),
    'position': driver.position(),
    'default_stiffness': default.stiffness,
    'broken': dict(DRIVERS.broken),
}))
"""


def run_script(script: str, site: Path) -> dict[str, object]:
    """Run ``script`` with the plug-in installed; what it prints is JSON."""
    completed = subprocess.run([sys.executable, '-c', script], env=environment(site),
                               capture_output=True, text=True, check=False, timeout=120)
    assert completed.returncode == 0, completed.stderr
    result: dict[str, object] = json.loads(completed.stdout)
    return result


def test_make_driver_builds_the_plugins_driver(site_packages: Path) -> None:
    result = run_script(DRIVER_SCRIPT, site_packages)
    names = result['names']
    assert isinstance(names, list) and 'spring_rig' in names and 'generic_tcp' in names
    assert result['parameters'] == [['spring_stiffness', K, "stiffness of the rig's spring, N/m"]]
    assert result['class'] == 'SpringRigDriver'
    assert result['force'] == [2.0e5 * 0.01, 2.0e5 * -0.02]
    assert result['position'] == [0.01, -0.02]
    assert result['default_stiffness'] == K
    assert result['broken'] == {}


RTHS_SCRIPT = """
import json
from pd_common.errors import RthsError
from pd_common.rths import plant_from_config, plant_model_names
from pd_common.rths.compensation import compensator_names, make_compensator

compensator = make_compensator('scaled', 1.0 / 1024, {'gain': 2.5})
try:
    make_compensator('scaled', 1.0 / 1024, {'gain': 'high'})
    refused = ''
except RthsError as err:
    refused = str(err)
plant = plant_from_config({'model': 'scaled_ideal', 'gain': 0.5}, 1.0 / 1024)
plant.advance(0.01)
print(json.dumps({
    'compensators': list(compensator_names()),
    'command': compensator.command(0.01, 0.0),
    'refused': refused,
    'plants': list(plant_model_names()),
    'output': plant.output(),
}))
"""


def test_the_plugins_compensator_and_plant_are_built_by_name(site_packages: Path) -> None:
    result = run_script(RTHS_SCRIPT, site_packages)
    assert result['compensators'] == ['adaptive', 'model_based', 'none', 'pi_p', 'polynomial',
                                      'scaled']
    assert result['command'] == 2.5 * 0.01
    assert result['refused'] == "compensator scaled: parameter gain must be float, got 'high'"
    assert result['plants'] == ['benchmark', 'ideal', 'scaled_ideal']
    assert result['output'] == 0.5 * 0.01


BRIDGE_FILE_SCRIPT = """
import sys
from pd_common.config import SchemaError, read_bridge_parameter_file
try:
    print(read_bridge_parameter_file(sys.argv[1]).parameters())
except SchemaError as err:
    print(err)
"""


@pytest.mark.parametrize(('parameters', 'with_plugin', 'expected'), [
    # a driver plug-in's declared parameter is a parameter of the bridge's file
    ({'driver': 'spring_rig', 'spring_stiffness': 2.0e5}, True, "'spring_stiffness': 200000.0"),
    # of its default's kind, and a misspelt one stays unknown
    ({'spring_stiffness': 'stiff'}, True,
     "bridge.yaml: /**.ros__parameters.spring_stiffness: must be a number"),
    ({'spring_stifness': 2.0e5}, True,
     'bridge.yaml: /**.ros__parameters.spring_stifness: unknown key'),
    # without the plug-in, its parameter is no parameter of the bridge
    ({'spring_stiffness': 2.0e5}, False,
     'bridge.yaml: /**.ros__parameters.spring_stiffness: unknown key'),
])
def test_a_bridge_file_may_set_a_driver_plugins_parameters(
        site_packages: Path, tmp_path: Path, parameters: dict[str, object], with_plugin: bool,
        expected: str) -> None:
    bridge = tmp_path / 'bridge.yaml'
    bridge.write_text(yaml.safe_dump({'/**': {'ros__parameters': parameters}}),
                      encoding='utf-8')
    env = environment(site_packages if with_plugin else tmp_path / 'no_plugin')
    done = subprocess.run([sys.executable, '-c', BRIDGE_FILE_SCRIPT, str(bridge)], env=env,
                          capture_output=True, text=True, check=False, timeout=120)
    assert done.returncode == 0, done.stderr
    assert expected in done.stdout, done.stdout
