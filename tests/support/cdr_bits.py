"""What the CDR codec's tests share: bitwise comparison of records, and rosbags' own
serializer with the ``pd_msgs`` types (an implementation independent of the codec)."""

from __future__ import annotations

import dataclasses
import struct
from typing import Any

import numpy as np
from rosbags import typesys

from support.paths import REPO

MSG_DIR = REPO / 'src' / 'pd_msgs' / 'msg'


def pd_msgs_typestore() -> Any:
    """A rosbags typestore (ROS 2 Kilted) with every ``pd_msgs`` message of the source tree."""
    store = typesys.get_typestore(typesys.Stores.ROS2_KILTED)
    types: dict[str, Any] = {}
    for path in sorted(MSG_DIR.glob('*.msg')):
        types.update(typesys.get_types_from_msg(path.read_text(encoding='utf-8'),
                                                f'pd_msgs/msg/{path.stem}'))
    store.register(types)
    return store


def bits(value: Any) -> Any:
    """``value`` with every float replaced by its 8 bytes (NaN payloads, -0.0 compare)."""
    if isinstance(value, float):
        return ('f64', struct.pack('<d', value))
    if isinstance(value, np.ndarray):
        return bits(tuple(value.tolist()))
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return (type(value).__name__,
                tuple((f.name, bits(getattr(value, f.name))) for f in dataclasses.fields(value)))
    if isinstance(value, (tuple, list)):
        return tuple(bits(item) for item in value)
    if isinstance(value, bool):
        return ('bool', value)
    return (type(value).__name__, value)
