"""Reading a test file once per process: the file, its YAML and its typed schema.

Every process that reads a test file (the integrator, the specimen simulator, the bridge's
transfer-system driver, the launcher) reads it here: :func:`read_test_data` reads the file
(a regular one, bounded, UTF-8) and its YAML, and :func:`read_test_file` validates it against
the typed schema too (:func:`~.schema.validate_test_file`). A file that cannot be read or is
refused is one :class:`~.schema_base.SchemaError` of one line, the same in every reader::

    /runs/test.yaml: cannot read the test file (No such file or directory)
    test.yaml: line 3: found a key given twice, 'dt'
    test.yaml: specimen.elements.0.yield_force: must be > 0, got -1
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .document import read_document

if TYPE_CHECKING:
    from .schema_test_file import TestFileModel

__all__ = ['TestFile', 'read_test_data', 'read_test_file']


@dataclass(frozen=True)
class TestFile:
    """A test file read and validated: its typed model and the parsed YAML it came from.

    Attributes:
        path: the file as given.
        model: the typed test file.
        data: the parsed YAML (a mapping), for the builders that still read raw sections.
    """

    __test__ = False  # (not a pytest test class)

    path: Path
    model: TestFileModel
    data: Mapping[str, Any]

    @property
    def source(self) -> str:
        """The file's name, as messages name it."""
        return self.path.name

    @property
    def base_dir(self) -> Path:
        """The folder relative file names in the test file resolve against."""
        return self.path.resolve().parent


def read_test_data(path: str | Path) -> dict[str, Any]:
    """The parsed YAML of the test file ``path`` (an empty file: an empty mapping).

    Raises:
        SchemaError: the file cannot be read (missing, not a regular file, too large, not
            UTF-8: ``<path>: cannot read the test file (<reason>)``), is not YAML
            (``<name>: line N: <problem>``) or not a mapping of sections.
    """
    return read_document(path, what='test file')


def read_test_file(path: str | Path, *, hysteresis_models: Collection[str] | None = None,
                   broken_models: Mapping[str, str] | None = None) -> TestFile:
    """The test file ``path`` read (:func:`read_test_data`) and validated by the typed schema.

    Args:
        path: the YAML test file.
        hysteresis_models: the registered hysteresis models
            (``pd_common.specimen.HYSTERESIS_MODELS``; ``None``: any registry name).
        broken_models: plug-in models that did not load, with the reason.

    Raises:
        SchemaError: one line naming the file (and the dotted path of a refused value).
    """
    from .schema import validate_test_file  # noqa: PLC0415 (its models: on first use)

    path = Path(path)
    data = read_test_data(path)
    model = validate_test_file(data, path.name, hysteresis_models=hysteresis_models,
                               broken_models=broken_models)
    return TestFile(path=path, model=model, data=data)
