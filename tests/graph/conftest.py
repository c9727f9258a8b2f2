"""Fixtures for graph tests (see graph_support for the helpers)."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from graph_support import (
    DOMAINS,
    REPO,
    Processes,
    remove_stale_segments,
    shm_segments,
    worker_index,
)
from netns_support import NetnsHub, NetnsUnavailable


@pytest.fixture
def domain_id() -> int:
    """A ROS domain of this test alone (distinct per xdist worker and per test)."""
    return 10 + 25 * worker_index() + next(DOMAINS) % 25


@pytest.fixture
def key_file(tmp_path: Path) -> Path:
    """The key of this test's nodes (owner-only), as run_test makes one per simulated test."""
    from pd_common.auth import generate_key

    path = tmp_path / 'keys' / 'test.key'
    generate_key(path)
    return path


@pytest.fixture
def rig_key(key_file: Path) -> Any:
    """The key itself, for the test's own signed controls."""
    from pd_common.auth import load_key

    return load_key(key_file)


@pytest.fixture
def ros_env(domain_id: int, key_file: Path, tmp_path: Path) -> dict[str, str]:
    """Environment for child nodes: the sourced workspace, this test's domain, host-only DDS,
    this test's key (``PD_KEY_FILE``: every node and run_test take it)."""
    env = dict(os.environ)
    env['ROS_DOMAIN_ID'] = str(domain_id)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env.setdefault('HOME', str(REPO))
    env['PYTHONUNBUFFERED'] = '1'
    env['PD_KEY_FILE'] = str(key_file)
    env['XDG_STATE_HOME'] = str(tmp_path / 'state')
    return env


@pytest.fixture
def processes(ros_env: dict[str, str], tmp_path: Path) -> Iterator[Processes]:
    """Process manager whose processes are always stopped after the test."""
    before = shm_segments()
    manager = Processes(ros_env, tmp_path)
    try:
        yield manager
    finally:
        manager.stop_all()
        remove_stale_segments(before)


@pytest.fixture
def observer(domain_id: int, monkeypatch: pytest.MonkeyPatch) -> Iterator[Any]:
    """An rclpy node in this test's domain (own context), shut down after the test."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    from pd_common.dds import discovery_profile

    # as every node does (they find it, and it them, at once); for this test alone
    for name, value in discovery_profile(os.environ).items():
        monkeypatch.setenv(name, value)
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain_id)
    node = Node('pd_test_observer', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    node.executor_for_test = executor
    try:
        yield node
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)


@pytest.fixture
def netns_hub() -> Iterator[Callable[..., NetnsHub]]:
    """Factory ``netns_hub('integrator', 'site_a', ...)``: network namespaces of this test alone
    (hub topology, see netns_support), deleted after the test with everything running in them.
    Skips the test when namespaces cannot be created (not root, no iproute2)."""
    before = shm_segments()
    try:
        with contextlib.ExitStack() as stack:

            def make(*names: str, **options: Any) -> NetnsHub:
                try:
                    return stack.enter_context(NetnsHub(names, **options))
                except NetnsUnavailable as exc:
                    pytest.skip(f'network namespaces unavailable: {exc}')
                raise AssertionError  # unreachable

            yield make
    finally:
        remove_stale_segments(before)
