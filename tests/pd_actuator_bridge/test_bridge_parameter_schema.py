"""The typed schema of the bridge's parameters (pd_common.config.schema_bridge) knows every
parameter the bridge node declares: the safety limits with the node's defaults, ``on_limit``
and each registered driver's parameters."""

from __future__ import annotations

import typing

import pd_actuator_bridge.sim_servo  # noqa: F401 (registers the sim_servo driver)
from pd_actuator_bridge.core.drivers.registry import driver_parameters
from pd_common.config.schema_bridge import BridgeParameters
from pd_common.experimental.limits import LIMIT_PARAMETERS, ON_LIMIT_OPTIONS


def test_the_limits_have_the_node_defaults() -> None:
    fields = BridgeParameters.model_fields
    for name, default in LIMIT_PARAMETERS.items():
        assert fields[name].default == default, name
    assert typing.get_args(fields['on_limit'].annotation) == ON_LIMIT_OPTIONS
    assert fields['on_limit'].default == ON_LIMIT_OPTIONS[0]


def test_every_driver_parameter_is_a_key_of_the_schema() -> None:
    names = {parameter.name for parameter, _ in driver_parameters()}
    assert names
    missing = sorted(names - set(BridgeParameters.model_fields))
    assert not missing, f'add to pd_common.config.schema_bridge: {missing}'
