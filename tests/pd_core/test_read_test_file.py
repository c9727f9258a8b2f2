"""One reader of the test file (pd_common.config.read_test_file): read once per process,
typed by the schema, and a bad file refused by every reader with the same one line.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest
import yaml

from pd_common.config import (
    SchemaError,
    TestFileModel,
    read_test_data,
    read_test_file,
    read_yaml_file,
    validate_section,
)
from pd_common.config.schema_test_file import SiteSettings
from pd_common.errors import SpecimenError
from pd_common.specimen import SpecimenServer, load_site_server, load_specimen_section
from pd_core.errors import ConfigError
from pd_core.run.runner import site_servers
from pd_core.run.test_file import load_test_file, read_definition
from support.paths import DEFAULT_TEST, TWO_SITES


def write(folder: Path, raw: Any, name: str = 't.yaml') -> Path:
    path = folder / name
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    return path


def default_raw() -> dict[str, Any]:
    """The default test, its record named by an absolute path (written anywhere)."""
    raw = yaml.safe_load(DEFAULT_TEST.read_text(encoding='utf-8'))
    assert isinstance(raw, dict)
    raw['ground_motion']['file'] = str(DEFAULT_TEST.parent / raw['ground_motion']['file'])
    return raw


def test_a_shipped_file_is_read_typed_with_its_data() -> None:
    test = read_test_file(TWO_SITES)
    assert isinstance(test.model, TestFileModel)
    assert test.source == TWO_SITES.name
    assert test.base_dir == TWO_SITES.resolve().parent
    assert test.data == read_test_data(TWO_SITES)
    assert test.model.test.dt == test.data['test']['dt']
    assert set(test.model.sites or {}) == set(test.data['sites'])


@pytest.mark.parametrize(('text', 'message'), [
    ('test: {dt: 0.01}\ntest: {dt: 0.02}\n', r'^t\.yaml: line 2: '),
    ('- 1\n- 2\n', r'^t\.yaml: a test file must be a mapping of sections, got list$'),
])
def test_a_file_that_is_no_test_file_is_one_line(tmp_path: Path, text: str, message: str
                                                 ) -> None:
    path = tmp_path / 't.yaml'
    path.write_text(text, encoding='utf-8')
    with pytest.raises(SchemaError, match=message) as info:
        read_test_file(path)
    assert '\n' not in str(info.value)


def test_a_missing_file_names_its_path(tmp_path: Path) -> None:
    path = tmp_path / 'none.yaml'
    with pytest.raises(SchemaError) as info:
        read_test_data(path)
    assert str(info.value) == f'{path}: cannot read the test file (No such file or directory)'


def test_a_bad_specimen_is_the_same_line_for_every_reader(tmp_path: Path) -> None:
    raw = default_raw()
    raw['specimen']['elements'][0]['backbone']['bilinear']['yield_force'] = -1.0
    path = write(tmp_path, raw)
    expected = 't.yaml: specimen.elements.0.backbone.bilinear.yield_force: must be > 0, got -1.0'
    with pytest.raises(SchemaError) as schema:
        read_test_file(path)
    with pytest.raises(ConfigError) as integrator:
        load_test_file(path)
    with pytest.raises(SpecimenError) as section:
        load_specimen_section(path)
    with pytest.raises(SpecimenError) as simulator:
        load_site_server(path)
    assert {str(schema.value), str(integrator.value), str(section.value),
            str(simulator.value)} == {expected}


def test_the_definition_and_the_typed_file_come_from_one_read(tmp_path: Path) -> None:
    raw = default_raw()
    path = write(tmp_path, raw)
    definition, test = read_definition(path, {'dt': 0.005})
    assert definition.dt == 0.005 == test.model.test.dt  # the overrides in both
    assert test.data['specimen'] == raw['specimen']
    server, section, _ = load_site_server(test)  # (no second read: the file may be gone)
    path.unlink()
    assert section == raw['specimen']
    assert server is not None


def test_a_section_alone_is_refused_at_its_dotted_path() -> None:
    with pytest.raises(SchemaError) as info:
        validate_section('structure.elements', [{'type': 'spring', 'dofs': ['u'],
                                                 'stiffness': 0.0}], 'f.yaml')
    assert str(info.value) == 'f.yaml: structure.elements.0.stiffness: must be > 0, got 0.0'
    protocol = validate_section('protocol', {'max_retries': 5}, 'f.yaml')
    assert protocol.max_retries == 5
    assert protocol.feedback_timeout == 2.0


def test_a_test_id_is_refused_in_words(tmp_path: Path) -> None:
    raw = copy.deepcopy(default_raw())
    raw['test']['id'] = 'a b'
    with pytest.raises(ConfigError) as info:
        load_test_file(write(tmp_path, raw))
    assert str(info.value) == ('t.yaml: test.id: must be 1-64 letters, digits, "_", "-" or ".", '
                               "got 'a b'")


def test_the_definition_carries_the_typed_sites_and_elements() -> None:
    definition = load_test_file(TWO_SITES)
    lab1 = definition.site_settings['lab1']
    assert isinstance(lab1, SiteSettings) and lab1.bridge is not None
    assert (lab1.bridge.max_force, lab1.bridge.max_increment) == (1.0e6, 0.01)
    assert lab1.bridge.model_fields_set == {'max_force', 'max_displacement', 'max_increment'}
    # the raw section stays as written (the resolved form and the bridge limits read it)
    assert definition.sites is not None
    assert definition.sites['lab1']['bridge'] == {'max_force': 1.0e6, 'max_displacement': 0.1,
                                                  'max_increment': 0.01}
    assert [element.type for element in definition.elements] == [
        'experimental', 'story', 'experimental']
    assert load_test_file(DEFAULT_TEST).site_settings == {}


def test_the_runner_simulates_a_site_from_its_typed_settings(tmp_path: Path) -> None:
    raw = read_yaml_file(TWO_SITES)
    raw['ground_motion']['file'] = str(TWO_SITES.parent / raw['ground_motion']['file'])
    raw['sites']['lab1']['transfer_system'] = None  # (null: none, as the schema reads it)
    servers = site_servers(load_test_file(write(tmp_path, raw)))
    assert isinstance(servers['lab1'], SpecimenServer)
    assert servers['lab1'].max_force_increment == 0.0
    raw['sites']['lab3'] = None  # a site without settings has no specimen to simulate
    with pytest.raises(ConfigError, match=r'^t\.yaml: sites\.lab3\.specimen: section is '
                                          r'required for a simulated run$'):
        site_servers(load_test_file(write(tmp_path, raw)))
