"""The rig a test runs on: its ROS domain, its discovery range and its key.

Read from the test file's ``rig`` section and/or a rig file (``run_test --rig FILE``, the same
keys; the test file's values win)::

    rig:
      domain_id: 42                  # ROS_DOMAIN_ID of the rig (0-101 or 215-232)
      discovery: localhost           # localhost (default) | subnet (a multi-host test)
      static_peers: [10.0.0.2]       # with subnet: the other hosts (ROS_STATIC_PEERS)
      key_file: ~/.config/pd/keys/rig.key   # the rig's key (a physical rig has one)

Keys: ``./pd keygen`` makes the rig's key; ``run_test`` makes a key per test in
``~/.local/state/pd/keys/`` when every site is simulated and no key is given, and removes the
test keys older than :data:`TEST_KEY_DAYS` days (the newest :data:`TEST_KEYS_KEPT` always
stay): keep a run's key elsewhere to check its bag's signatures later.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from pd_common.auth import default_rig_key, generate_key
from pd_common.config import SchemaError, YAMLError, read_yaml_file, validate_model, yaml_problem
from pd_common.config.schema_test_file import RigSection

__all__ = ['DISCOVERY', 'TEST_KEYS_KEPT', 'TEST_KEY_DAYS', 'RigError', 'RigSettings',
           'default_rig_key', 'load_rig', 'prune_test_keys', 'state_key_dir', 'test_key_path']

#: Days a per-test key is kept after it was made.
TEST_KEY_DAYS = 30
#: Per-test keys always kept (the newest), whatever their age.
TEST_KEYS_KEPT = 20

DISCOVERY = ('localhost', 'subnet')


class RigError(ValueError):
    """The rig settings are invalid (one line naming the file and the key)."""


@dataclass(frozen=True)
class RigSettings:
    """Where the test's nodes talk, and with which key.

    Attributes:
        domain_id: ROS_DOMAIN_ID (``None``: the environment's).
        discovery: ``localhost`` or ``subnet``.
        static_peers: ROS_STATIC_PEERS with ``subnet``.
        key_file: the rig's key file (``None``: not given).
    """

    domain_id: int | None = None
    discovery: str = 'localhost'
    static_peers: tuple[str, ...] = ()
    key_file: Path | None = None
    sources: tuple[str, ...] = field(default=(), compare=False)

    def environment(self, base: Mapping[str, str]) -> dict[str, str]:
        """The environment of the test's processes: domain and discovery of the rig."""
        env = dict(base)
        if self.domain_id is not None:
            env['ROS_DOMAIN_ID'] = str(self.domain_id)
        if self.discovery == 'subnet':
            env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'SUBNET'
            if self.static_peers:
                env['ROS_STATIC_PEERS'] = ';'.join(self.static_peers)
        else:
            env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
        return env


def _given(section: RigSection, base_dir: Path) -> dict[str, Any]:
    """The values a typed ``rig`` section gives (the keys set, not null); its key file resolved.

    A relative key file resolves against ``base_dir`` (the folder of the file that names it).
    """
    out: dict[str, Any] = section.model_dump(exclude_unset=True, exclude_none=True)
    if 'static_peers' in out:
        out['static_peers'] = tuple(out['static_peers'])
    if 'key_file' in out:
        path = Path(out['key_file']).expanduser()
        out['key_file'] = path if path.is_absolute() else base_dir / path
    return out


def load_rig(rig: RigSection | None, test_file: Path, rig_file: Path | None) -> RigSettings:
    """The rig settings of a test: its rig file's, overridden by its ``rig`` section.

    Args:
        rig: the test file's typed ``rig`` section (``TestFileModel.rig``; ``None``: none).
        test_file: the test file (its folder resolves a relative key file).
        rig_file: the rig file (``run_test --rig``), read and typed here by the same schema
            (:class:`~pd_common.config.schema_test_file.RigSection`), the section at its
            top level or under ``rig``.

    Raises:
        RigError: the rig file cannot be read or is refused: one line naming the file and the
            key (``rig.yaml: rig.domain_id: must be an integer in 0-101 or 215-232, got 300``).
    """
    values: dict[str, Any] = {}
    sources: list[str] = []
    if rig_file is not None:
        try:
            raw = read_yaml_file(rig_file)
        except OSError as err:
            msg = f'{rig_file}: cannot read the rig file ({err})'
            raise RigError(msg) from None
        except YAMLError as err:  # (PyYAML's message spans lines: its line and problem)
            msg = f'{rig_file}: cannot read the rig file ({yaml_problem(err)})'
            raise RigError(msg) from None
        section = raw.get('rig', raw) if isinstance(raw, Mapping) else raw
        try:  # (an empty file, or an empty rig section: no settings)
            typed = validate_model(RigSection, {} if section is None else section,
                                   rig_file.name, 'rig')
        except SchemaError as err:
            raise RigError(str(err)) from None
        values.update(_given(typed, rig_file.parent))
        sources.append(str(rig_file))
    if rig is not None:
        values.update(_given(rig, test_file.parent))
        sources.append(str(test_file))
    return RigSettings(**values, sources=tuple(sources))


def state_key_dir() -> Path:
    """Where ``run_test`` keeps the keys it makes per test (owner-only)."""
    base = os.environ.get('XDG_STATE_HOME') or str(Path.home() / '.local' / 'state')
    return Path(base) / 'pd' / 'keys'


def test_key_path(test_id: str) -> Path:
    """A new key file for one simulated test (created, owner-only).

    The old ones pruned (:func:`prune_test_keys`).
    """
    stamp = datetime.now(tz=UTC).strftime('%Y%m%d-%H%M%S-%f')
    path = state_key_dir() / f'{test_id}-{stamp}.key'
    generate_key(path)
    prune_test_keys(path.parent)
    return path


def prune_test_keys(directory: Path, *, days: float = TEST_KEY_DAYS,
                    kept: int = TEST_KEYS_KEPT, now: float | None = None) -> list[Path]:
    """Remove the per-test keys in ``directory`` older than ``days`` (by their modification time).

    Except the newest ``kept``; the files removed (a file that cannot be removed is left). Only
    ``*.key`` files are considered; the rig's key lives elsewhere.
    """
    limit = (datetime.now(tz=UTC).timestamp() if now is None else now) - days * 86400.0
    keys = []
    for path in directory.glob('*.key'):
        try:
            keys.append((path.stat().st_mtime, path))
        except OSError:
            continue
    keys.sort(reverse=True)
    removed = []
    for mtime, path in keys[kept:]:
        if mtime < limit:
            try:
                path.unlink()
            except OSError:
                continue
            removed.append(path)
    return removed
