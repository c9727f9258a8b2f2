"""The typed schema of the test file and of the bridge's parameter file (pd_common.config.schema):
it accepts every shipped file, refuses broken ones with one line naming the file and the dotted
path, and the shipped JSON Schemas and the reference page are what the models generate.
"""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from pd_common.config import (
    DriverConfigFile,
    SchemaError,
    TestFileModel,
    json_schema,
    read_bridge_parameter_file,
    read_driver_config,
    read_yaml_file,
    validate_bridge_parameters,
    validate_model,
    validate_test_file,
)
from pd_common.config.schema import (
    BRIDGE_SCHEMA_FILE,
    DRIVER_CONFIG_SCHEMA_FILE,
    TEST_FILE_SCHEMA_FILE,
    json_schema_text,
)
from pd_common.config.schema_markdown import markdown_reference
from pd_common.config.schema_test_file import RealtimeSection
from pd_common.rths import ContinuousConfig
from pd_common.rths.cpu_latency import LARGEST_CPU_LATENCY
from pd_common.specimen import HYSTERESIS_MODELS
from support.paths import CONFIG, REPO

SCHEMA_DIR = REPO / 'src' / 'pd_common' / 'schema'
REFERENCE_PAGE = REPO / 'docs' / 'reference' / 'test-file.md'
BRIDGE_FILE = REPO / 'src' / 'pd_actuator_bridge' / 'config' / 'bridge.yaml'
#: How to regenerate what this file checks is in sync.
REGENERATE = ('regenerate with: ./pd schema --write src/pd_common/schema && '
              './pd schema --markdown > docs/reference/test-file.md')


def shipped_test_files() -> list[Path]:
    """The shipped test files (YAML files of the integrator's config with a structure)."""
    files = []
    for path in sorted(CONFIG.rglob('*.yaml')):
        raw = read_yaml_file(path)
        if isinstance(raw, dict) and 'structure' in raw:
            files.append(path)
    return files


def test_there_are_shipped_test_files() -> None:
    assert len(shipped_test_files()) >= 7


@pytest.mark.parametrize('path', shipped_test_files(), ids=lambda path: path.name)
def test_every_shipped_test_file_is_valid(path: Path) -> None:
    model = validate_test_file(read_yaml_file(path), path.name)
    assert isinstance(model, TestFileModel)
    assert model.test.dt > 0.0


@pytest.mark.parametrize('path', shipped_test_files(), ids=lambda path: path.name)
def test_every_shipped_test_file_names_the_shipped_schema(path: Path) -> None:
    first = path.read_text(encoding='utf-8').splitlines()[0]
    prefix = '# yaml-language-server: $schema='
    assert first.startswith(prefix), first
    target = (path.parent / first.removeprefix(prefix)).resolve()
    assert target == (SCHEMA_DIR / TEST_FILE_SCHEMA_FILE).resolve()


def test_test_files_in_tests_are_valid() -> None:
    files = [path for path in sorted((REPO / 'tests').rglob('*.yaml'))
             if isinstance(raw := read_yaml_file(path), dict) and 'structure' in raw]
    for path in files:
        validate_test_file(read_yaml_file(path), path.name)


def test_the_bridge_parameter_file_is_valid() -> None:
    parameters = validate_bridge_parameters(read_yaml_file(BRIDGE_FILE), BRIDGE_FILE.name)
    section = parameters.root['/**'].ros__parameters
    assert section.driver == 'sim_servo'
    assert section.on_limit == 'hold'


def default_raw() -> dict[str, Any]:
    raw = read_yaml_file(CONFIG / 'three_story_two_sites.yaml')
    assert isinstance(raw, dict)
    return raw


def _set(*path: Any, value: Any) -> Any:
    def change(raw: dict[str, Any]) -> None:
        target = raw
        for step in path[:-1]:
            target = target[step]
        target[path[-1]] = value
    return change


def _drop(*path: Any) -> Any:
    def change(raw: dict[str, Any]) -> None:
        target = raw
        for step in path[:-1]:
            target = target[step]
        del target[path[-1]]
    return change


#: Broken test files: the change, and the line expected (after ``case.yaml: ``).
BROKEN = {
    'negative yield force': (
        _set('sites', 'lab1', 'specimen', 'elements', 0, 'yield_force', value=-1),
        'sites.lab1.specimen.elements.0.yield_force: must be > 0, got -1'),
    'unknown key': (_set('protocol', 'feedback_timout', value=2.0),
                    'protocol.feedback_timout: unknown key'),
    'unknown section': (_set('simulation', value={}), 'simulation: unknown key'),
    'boolean mass': (_set('structure', 'mass', value=True),
                     'structure.mass: must be a number, got true'),
    'boolean in a mass list': (_set('structure', 'mass', value=[2.0e4, False, 1.5e4]),
                               'structure.mass.1: must be a number, got false'),
    'string dt': (_set('test', 'dt', value='0.005'), "test.dt: must be a number, got '0.005'"),
    'missing dt': (_drop('test', 'dt'), 'test.dt: is required'),
    'missing ground motion': (_drop('ground_motion'), 'ground_motion: is required'),
    'infinite scale': (_set('ground_motion', 'scale', value=float('inf')),
                       'ground_motion.scale: must be a finite number, got inf'),
    'unknown element type': (
        _set('structure', 'elements', 1, 'type', value='truss'),
        ("structure.elements.1.type: must be one of 'spring', 'story', 'beam_column', 'linear', "
        "'nonlinear_spring', 'experimental', got 'truss'")),
    'unknown hysteresis model': (
        _set('sites', 'lab3', 'specimen', 'elements', 0, 'model', value='takeda'),
        ("sites.lab3.specimen.elements.0.model: must be one of 'elastic', 'epp', 'bilinear', "
        "'pushover', 'bouc_wen', got 'takeda'")),
    'bridge limit': (_set('sites', 'lab1', 'bridge', 'max_force', value=0),
                     'sites.lab1.bridge.max_force: must be > 0, got 0'),
    'site name': (_set('sites', 'lab-2', value={}),
                  ('sites.lab-2: must be a name of letters, digits and _ starting with a '
                   "letter, got 'lab-2'")),
    'damping ratio': (_set('structure', 'damping', value={'ratio': 1.0}),
                      'structure.damping.ratio: must be < 1, got 1.0'),
    'direction': (_set('ground_motion', 'direction', value=2),
                  'ground_motion.direction: must be 1 or -1, got 2'),
    'repeated DOF names': (_set('structure', 'dof_names', value=['u1', 'u1', 'u3']),
                           'structure.dof_names: names must be unique, got ["u1", "u1", "u3"]'),
    'two dampings': (_set('structure', 'damping', value={'ratio': 0.05, 'modal': [0.05]}),
                     ('structure.damping: give exactly one of ratio, coefficient, rayleigh or '
                     'modal, got ratio, modal')),
}


@pytest.mark.parametrize('case', sorted(BROKEN))
def test_a_broken_test_file_is_one_line_naming_the_file_and_the_path(case: str) -> None:
    change, expected = BROKEN[case]
    raw = default_raw()
    change(raw)
    with pytest.raises(SchemaError) as caught:
        validate_test_file(raw, 'case.yaml', hysteresis_models=tuple(HYSTERESIS_MODELS))
    message = str(caught.value)
    assert message == f'case.yaml: {expected}'
    assert '\n' not in message
    assert caught.value.path == expected.split(': ', 1)[0]


def test_a_plugins_model_is_taken_when_registered_and_any_name_without_the_registry() -> None:
    raw = default_raw()
    _set('sites', 'lab3', 'specimen', 'elements', 0, value={'model': 'takeda', 'k0': 1.0})(raw)
    validate_test_file(raw, 'case.yaml')  # the specimen's builder checks the name and keys
    with HYSTERESIS_MODELS.added('takeda', replace(HYSTERESIS_MODELS['elastic'], name='takeda')):
        validate_test_file(raw, 'case.yaml', hysteresis_models=tuple(HYSTERESIS_MODELS))
    _set('sites', 'lab3', 'specimen', 'elements', 0, 'model', value='Takeda!')(raw)
    with pytest.raises(SchemaError, match=r'elements\.0\.model: '):
        validate_test_file(raw, 'case.yaml')


def test_the_original_is_left_alone_and_valid() -> None:
    raw = default_raw()
    before = copy.deepcopy(raw)
    validate_test_file(raw, 'case.yaml')
    assert raw == before


@pytest.mark.parametrize(('data', 'expected'), [
    ([1, 2], 'case.yaml: a test file must be a mapping of sections, got list'),
    (None, 'case.yaml: test: is required'),
])
def test_a_file_that_is_no_mapping_is_one_line(data: Any, expected: str) -> None:
    with pytest.raises(SchemaError, match=f'^{expected}$'.replace('.', r'\.')):
        validate_test_file(data, 'case.yaml')


def test_a_broken_bridge_parameter_file_is_one_line() -> None:
    raw = read_yaml_file(BRIDGE_FILE)
    raw['/**']['ros__parameters']['max_force'] = -5.0
    with pytest.raises(SchemaError) as caught:
        validate_bridge_parameters(raw, 'bridge.yaml')
    assert str(caught.value) == 'bridge.yaml: /**.ros__parameters.max_force: must be > 0, got -5.0'
    raw['/**']['ros__parameters']['max_force'] = 1.0
    raw['/**']['ros__parameters']['on_limit'] = 'clip'
    with pytest.raises(SchemaError, match=r"on_limit: must be one of 'hold', 'saturate', got "):
        validate_bridge_parameters(raw, 'bridge.yaml')


def test_the_json_schema_describes_keys_types_and_bounds() -> None:
    schema = json_schema()
    assert schema['$schema'] == 'https://json-schema.org/draft/2020-12/schema'
    assert set(schema['required']) == {'test', 'structure', 'ground_motion'}
    assert schema['additionalProperties'] is False
    test = schema['$defs']['TestSection']
    assert test['additionalProperties'] is False
    assert test['properties']['dt']['exclusiveMinimum'] == 0.0
    assert test['properties']['dt']['type'] == 'number'  # (JSON: a boolean is no number)
    assert 'time step' in test['properties']['dt']['description']
    sites = schema['properties']['sites']['anyOf'][0]
    assert sites['additionalProperties'] is False  # (site names follow a pattern)


@pytest.mark.parametrize(('bridge', 'name'), [(False, TEST_FILE_SCHEMA_FILE),
                                               (True, BRIDGE_SCHEMA_FILE)])
def test_the_shipped_json_schemas_are_what_the_models_generate(bridge: bool, name: str) -> None:
    shipped = (SCHEMA_DIR / name).read_text(encoding='utf-8')
    assert shipped == json_schema_text(bridge=bridge), REGENERATE
    assert json.loads(shipped) == json_schema(bridge=bridge)


def test_the_reference_page_is_what_the_schema_generates() -> None:
    page = REFERENCE_PAGE.read_text(encoding='utf-8')
    assert page == markdown_reference(json_schema()), REGENERATE
    for key in ('yield_force', 'feedback_timeout', 'max_force_increment', 'dof_names'):
        assert f'| `{key}` |' in page


@pytest.mark.parametrize(('args', 'page'), [(('--bridge', '--markdown'), 'bridge-parameters.md'),
                                            (('--driver', '--markdown'), 'driver-settings.md')])
def test_the_bridge_and_driver_reference_pages_are_what_the_schema_generates(
        args: tuple[str, ...], page: str) -> None:
    shipped = (REPO / 'docs' / 'reference' / page).read_text(encoding='utf-8')
    generated = subprocess.run([sys.executable, '-m', 'pd_common.config.schema_cli', *args],
                               capture_output=True, text=True, check=True, timeout=60).stdout
    assert shipped == generated, (f'regenerate: ./pd schema {" ".join(args)} > '
                                  f'docs/reference/{page}')
    assert '| `max_force` |' in shipped or '| `command_scale` |' in shipped


def test_the_command_prints_the_schema_and_the_page() -> None:
    def run(*args: str) -> str:
        return subprocess.run([sys.executable, '-m', 'pd_common.config.schema_cli', *args],
                              capture_output=True, text=True, check=True, timeout=60).stdout
    assert run() == json_schema_text()
    assert run('--bridge') == json_schema_text(bridge=True)
    assert run('--markdown') == REFERENCE_PAGE.read_text(encoding='utf-8')


def test_the_shipped_driver_settings_schema_is_what_the_model_generates() -> None:
    shipped = (SCHEMA_DIR / DRIVER_CONFIG_SCHEMA_FILE).read_text(encoding='utf-8')
    assert shipped == json_schema_text(driver=True), REGENERATE
    schema = json_schema(driver=True)
    assert schema['title'] == 'Actuator driver settings file'
    assert set(schema['properties']) == {'daqmx', 'emulator', 'ramp_hold', 'errors'}
    assert schema['additionalProperties'] is False


def test_the_shipped_daqmx_example_is_a_valid_driver_settings_file() -> None:
    example = REPO / 'src' / 'pd_actuator_bridge' / 'config' / 'daqmx_example.yaml'
    settings = read_driver_config(example)
    assert settings.daqmx is not None and settings.daqmx.channels[0].name == 'top'
    assert settings.emulator is None


@pytest.mark.parametrize(('text', 'message'), [
    ('/**:\n  ros__parameters: {max_force: -1}\n',
     'bridge.yaml: /**.ros__parameters.max_force: must be > 0, got -1'),
    ('/**:\n  ros__parameters: {max_increment: true}\n',
     'bridge.yaml: /**.ros__parameters.max_increment: must be a number, got true'),
    ('/**:\n  ros__parameters: {max_forse: 1.0}\n',
     'bridge.yaml: /**.ros__parameters.max_forse: unknown key'),
    ('- 1\n', 'bridge.yaml: a bridge parameter file must be a mapping of sections, got list'),
])
def test_a_bridge_parameter_file_is_read_once_typed(tmp_path: Path, text: str,
                                                    message: str) -> None:
    path = tmp_path / 'bridge.yaml'
    path.write_text(text, encoding='utf-8')
    with pytest.raises(SchemaError) as info:
        read_bridge_parameter_file(path)
    assert str(info.value) == message
    shipped = read_bridge_parameter_file(BRIDGE_FILE)
    assert shipped.root['/**'].ros__parameters.driver == 'sim_servo'


def test_a_check_of_a_mapping_names_the_key_it_refuses() -> None:
    channel = {'command_channel': 'Dev1/ao0', 'command_scale': 0.01,
               'displacement_channel': 'Dev1/ai0', 'displacement_scale': 0.01,
               'force_channel': 'Dev1/AI0', 'force_scale': 1000.0}
    with pytest.raises(SchemaError) as info:
        validate_model(DriverConfigFile, {'daqmx': {'channels': [channel]}}, 'rig.yaml')
    assert str(info.value) == ('rig.yaml: daqmx.channels.0.force_channel: same physical channel '
                               'as displacement_channel (Dev1/AI0)')


def test_the_realtime_section_states_the_loops_own_defaults_and_bound() -> None:
    """The schema restates what the real-time loop uses (it does not import the loop)."""
    section = RealtimeSection()
    config = ContinuousConfig(plant={'model': 'ideal'})
    assert (section.hold_at, section.slowdown_samples, section.cpu_latency) == (
        config.hold_at, config.slowdown_samples, config.cpu_latency)
    number = RealtimeSection.model_json_schema()['properties']['cpu_latency']['anyOf'][0]
    assert (number['minimum'], number['maximum']) == (0.0, LARGEST_CPU_LATENCY)
