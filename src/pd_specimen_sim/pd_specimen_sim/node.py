"""The simulated specimen node (``ros2 run pd_specimen_sim main``).

A thin shell around :class:`pd_specimen_sim.core.SpecimenServer`: it answers every
``step_command`` with a ``step_feedback`` holding the restoring force of its hysteresis model.
It speaks the same step protocol as the actuator bridge, so the integrator cannot tell (and does
not care) which one answers: swapping them is a launch-time choice (the namespace).

Topics (relative; namespace ``/pd`` by default, ``/pd/specimen`` behind a bridge):
``step_command`` (subscribed) and ``step_feedback`` (published), both reliable.

Parameters: ``test_file`` — the YAML test file; its ``specimen`` section and
``structure.dof_names`` define the specimen, and the optional ``specimen.errors`` mapping the
experimental errors injected into every step (see :mod:`pd_specimen_sim.core.server`).
``site`` — in a substructured test, the site this node simulates: the specimen is then
``sites.<site>.specimen`` and the node runs in the namespace ``/pd/<site>`` (``-r
__ns:=/pd/<site>``; ``/pd/<site>/specimen`` behind that site's bridge). ``dof_names`` — the
names of the specimen's DOFs (the site's actuators; default: ``structure.dof_names``, or
``a1, a2, ...`` for a site).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

import rclpy
import yaml
from builtin_interfaces.msg import Time
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.executors import ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from pd_msgs.msg import StepCommand, StepFeedback

from .core import SpecimenError
from .core.config import load_yaml
from .core.server import server_from_config

STEP_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)


def load_specimen_section(path: str | Path, site: str = ''
                          ) -> tuple[dict[str, Any], list[str] | None]:
    """The specimen section (of the test, or of ``site``) and the test's DOF names.

    The DOF names are ``None`` for a site (they are the site's actuators: the caller knows).

    Raises:
        SpecimenError: the file cannot be read or has no such section.
    """
    path = Path(path)
    try:
        raw = load_yaml(path.read_text(encoding='utf-8')) or {}
    except (OSError, yaml.YAMLError) as err:
        msg = f'{path}: cannot read the test file ({err})'
        raise SpecimenError(msg) from err
    if not isinstance(raw, dict):
        msg = f'{path.name}: a test file must be a mapping of sections'
        raise SpecimenError(msg)
    if site:
        sites = raw.get('sites')
        settings = sites.get(site) if isinstance(sites, dict) else None
        section = settings.get('specimen') if isinstance(settings, dict) else None
        if not isinstance(section, dict):
            msg = (f'{path.name}: sites.{site}.specimen: section is required for the '
                   f'simulated specimen of site {site!r}')
            raise SpecimenError(msg)
        return section, None
    if not isinstance(raw.get('specimen'), dict):
        msg = f'{path.name}: specimen: section is required for the simulated specimen'
        raise SpecimenError(msg)
    structure = raw.get('structure') or {}
    names = structure.get('dof_names') if isinstance(structure, dict) else None
    if names is None:
        mass = structure.get('mass') if isinstance(structure, dict) else None
        names = [f'u{i + 1}' for i in range(len(mass) if isinstance(mass, list) else 1)]
    return raw['specimen'], list(names)


class SpecimenSimNode(Node):
    """Answers step commands with a simulated specimen."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('pd_specimen_sim', namespace='pd', **kwargs)
        self.declare_parameter('test_file', '', ParameterDescriptor(
            description='YAML test file whose specimen section defines the specimen'))
        self.declare_parameter('site', '', ParameterDescriptor(
            description='site of a substructured test (its specimen: sites.<site>.specimen)'))
        self.declare_parameter('dof_names', [''], ParameterDescriptor(
            description='names of the specimen DOFs (default: from the test file)'))
        test_file = self.get_parameter('test_file').value
        if not test_file:
            msg = 'parameter test_file: a YAML test file is required'
            raise SpecimenError(msg)
        site = str(self.get_parameter('site').value)
        section, dof_names = load_specimen_section(test_file, site)
        given = [name for name in self.get_parameter('dof_names').value if name]
        if given:
            dof_names = given
        elif dof_names is None:
            elements = section.get('elements')
            dof_names = [f'a{i + 1}' for i in range(len(elements) if isinstance(
                elements, list) else 1)]
        source = Path(test_file).name
        try:
            self.server = server_from_config(section, base_dir=Path(test_file).resolve().parent,
                                             source=source, dof_names=dof_names)
        except SpecimenError as err:
            if not site:
                raise
            msg = str(err).replace(': specimen', f': sites.{site}.specimen', 1)
            raise SpecimenError(msg) from None
        self._feedback_pub = self.create_publisher(StepFeedback, 'step_feedback', STEP_QOS)
        self.create_subscription(StepCommand, 'step_command', self._on_command, STEP_QOS)
        self._feedback = StepFeedback()
        self.get_logger().info(f'simulated specimen ready: {len(dof_names)} DOF '
                               f'({", ".join(dof_names)}) on '
                               f'{self.resolve_topic_name("step_command")}')
        errors = self.server.errors
        if errors is not None and not errors.is_ideal:
            self.get_logger().warning(f'injecting experimental errors: {errors}')

    def _on_command(self, message: StepCommand) -> None:
        answer = self.server.handle(message.test_id, message.step,
                                    tuple(message.target_displacement),
                                    iteration=message.iteration)
        if answer is None:
            return
        feedback = self._feedback
        t_ns = time.time_ns()
        feedback.header.stamp = Time(sec=t_ns // 1_000_000_000,
                                     nanosec=t_ns % 1_000_000_000)
        feedback.test_id = answer.test_id
        feedback.step = answer.step
        feedback.iteration = answer.iteration
        feedback.measured_displacement = list(answer.displacement)
        feedback.restoring_force = list(answer.force)
        feedback.status = answer.status
        feedback.message = answer.message
        self._feedback_pub.publish(feedback)
        if answer.status != StepFeedback.STATUS_OK:
            self.get_logger().error(f'step {answer.step}: {answer.message}')


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run pd_specimen_sim main``."""
    rclpy.init(args=args)
    node: SpecimenSimNode | None = None
    executor: EventsExecutor | None = None
    try:
        try:
            node = SpecimenSimNode()
        except SpecimenError as err:
            print(f'pd_specimen_sim: error: {err}', file=sys.stderr)
            return 2
        executor = EventsExecutor()
        executor.add_node(node)
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if executor is not None:
            executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
