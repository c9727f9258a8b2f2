"""The actuator bridge's safety limits, read from its parameter file, and which runs trip them.

The limits are those the bridge enforces (``pd_actuator_bridge.core.limits``): ``|x_target| <=
max_displacement``, ``|x_target − x_current| <= max_increment``, ``|x_target − x_current| /
step_duration <= max_velocity`` (only with both set) and ``|f_measured| <= max_force``; a value
exactly at a limit passes. They come from the bridge's ROS parameter file
(``pd_actuator_bridge/config/bridge.yaml``: ``/**: ros__parameters: {...}``, 0 = off for
``max_velocity`` and ``step_duration``), then the test file's ``bridge`` mapping (as
``run_test`` passes it to the bridge), then explicit overrides (command line). The integrator
does not import the bridge (the node packages are peers), so the file is read here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from pd_common.config import load_yaml
from pd_common.types import FloatArray

from .errors import PretestError

__all__ = ['LIMIT_NAMES', 'BridgeLimits', 'read_bridge_limits', 'trips']

#: The limits checked, in the bridge's order (a command's, then the measured force's).
LIMIT_NAMES = ('max_displacement', 'max_increment', 'max_velocity', 'max_force')
_REQUIRED = ('max_displacement', 'max_increment', 'max_force')
_OPTIONAL = ('max_velocity', 'step_duration')


@dataclass(frozen=True)
class BridgeLimits:
    """The bridge's limits (``None``: off).

    Attributes:
        max_displacement: largest ``|x|`` [m].
        max_increment: largest ``|Δx|`` per step [m].
        max_force: largest ``|f|`` [N].
        max_velocity: largest ``|Δx| / step_duration`` [m/s], or ``None``.
        step_duration: time the actuator takes for one step [s], or ``None``.
        source: where they came from (for the report).
    """

    max_displacement: float
    max_increment: float
    max_force: float
    max_velocity: float | None = None
    step_duration: float | None = None
    source: str = ''

    def value(self, name: str) -> float | None:
        """The limit ``name`` of :data:`LIMIT_NAMES` (``None``: not checked)."""
        if name == 'max_velocity':
            return self.max_velocity if self.step_duration is not None else None
        number: float = getattr(self, name)
        return number


def _parameters(raw: Any, source: str) -> Mapping[str, Any]:
    """The ``ros__parameters`` mapping of a ROS parameter file (or a plain mapping)."""
    if not isinstance(raw, Mapping):
        msg = f'{source}: must be a mapping of ROS parameters'
        raise PretestError(msg)
    for value in raw.values():
        if isinstance(value, Mapping) and isinstance(value.get('ros__parameters'), Mapping):
            parameters: Mapping[str, Any] = value['ros__parameters']
            return parameters
    return raw


def _number(value: Any, where: str, *, zero_off: bool) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(
            float(value)) or float(value) < 0.0 or (float(value) == 0.0 and not zero_off):
        what = 'a number >= 0 (0 = off)' if zero_off else 'a positive number'
        msg = f'{where}: must be {what}, got {value!r}'
        raise PretestError(msg)
    number = float(value)
    return None if number == 0.0 else number


def read_bridge_limits(path: str | Path, *layers: tuple[Mapping[str, Any] | None, str]
                       ) -> BridgeLimits:
    """The bridge's limits: its parameter file, then each ``(mapping, source)`` override.

    Keys other than the limits (``driver``, ``on_limit``, ...) are ignored.

    Raises:
        PretestError: the file cannot be read, a limit is missing or not a valid number.
    """
    path = Path(path)
    try:
        raw = load_yaml(path.read_text(encoding='utf-8'))
    except OSError as err:
        msg = f'{path}: cannot read the bridge parameters ({err.strerror})'
        raise PretestError(msg) from None
    except yaml.YAMLError as err:
        msg = f'{path}: not a YAML file ({getattr(err, "problem", None) or err})'
        raise PretestError(msg) from None
    values: dict[str, tuple[Any, str]] = {
        key: (value, f'{path.name}: {key}') for key, value in _parameters(raw, path.name).items()}
    sources = [path.name]
    for mapping, where in layers:
        if mapping is None:
            continue
        if not isinstance(mapping, Mapping):
            msg = f'{where}: must be a mapping of bridge parameters'
            raise PretestError(msg)
        sources.append(where)
        values.update({key: (value, f'{where}.{key}') for key, value in mapping.items()})
    limits: dict[str, float | None] = {}
    for key in _REQUIRED + _OPTIONAL:
        if key not in values:
            if key in _REQUIRED:
                msg = f'{path}: {key}: missing (a bridge limit)'
                raise PretestError(msg)
            limits[key] = None
            continue
        value, where = values[key]
        limits[key] = _number(value, where, zero_off=key in _OPTIONAL)
    required = {key: limits[key] for key in _REQUIRED}
    assert all(value is not None for value in required.values())
    return BridgeLimits(max_displacement=float(required['max_displacement'] or 0.0),
                        max_increment=float(required['max_increment'] or 0.0),
                        max_force=float(required['max_force'] or 0.0),
                        max_velocity=limits['max_velocity'],
                        step_duration=limits['step_duration'],
                        source=' + '.join(sources))


def trips(limits: BridgeLimits, *, peak_displacement: FloatArray, max_increment: FloatArray,
          peak_force: FloatArray) -> dict[str, np.ndarray]:
    """Per limit of :data:`LIMIT_NAMES`, which runs exceed it (a value at the limit passes).

    Limits that are off give all ``False``.
    """
    off = np.zeros(peak_displacement.shape, dtype=bool)
    result = {
        'max_displacement': peak_displacement > limits.max_displacement,
        'max_increment': max_increment > limits.max_increment,
        'max_velocity': off.copy(),
        'max_force': peak_force > limits.max_force,
    }
    if limits.max_velocity is not None and limits.step_duration is not None:
        result['max_velocity'] = max_increment / limits.step_duration > limits.max_velocity
    return result
