"""Sealed parameters (pd_common.ros.seal_parameters): every change after start refused and
counted, a flood of calls logged once, not call by call."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from typing import Any

import pytest

rclpy = pytest.importorskip('rclpy')

from rclpy.parameter import Parameter  # noqa: E402

from pd_common.ros import SEALED, seal_parameters  # noqa: E402


@pytest.fixture
def node() -> Iterator[Any]:
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=98)
    made = rclpy.create_node('sealed_probe', context=context)
    try:
        yield made
    finally:
        made.destroy_node()
        rclpy.shutdown(context=context)


def test_every_change_is_refused_counted_and_a_flood_logged_once(
        node: Any, capfd: pytest.CaptureFixture[str]) -> None:
    node.declare_parameter('max_displacement', 0.25)
    refused: Counter[str] = Counter()
    seal_parameters(node, 'the probe', 'restart it', refused)
    for value in (10.0, 20.0, 30.0):
        [result] = node.set_parameters([Parameter('max_displacement', value=value)])
        assert not result.successful
        assert result.reason.startswith(f'{SEALED}: the parameters of the probe are fixed')
    assert node.get_parameter('max_displacement').value == 0.25
    assert refused == Counter({SEALED: 3})
    logged = [line for line in capfd.readouterr().err.splitlines() if 'refused set_parameters'
              in line]
    assert len(logged) == 1 and 'the probe is sealed' in logged[0], logged
