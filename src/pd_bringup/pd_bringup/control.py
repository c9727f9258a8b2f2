"""Send a signed operator control: ``./pd control COMMAND [options]``.

To the integrator (``/pd/test_control``): ``pause``, ``resume``, ``hold``, ``abort``, and
``restarted --reason WHAT`` (records in the run that a process was restarted by hand). To a
bridge (``--bridge``, ``/pd/[<site>/]bridge/control``): ``reset``, ``reset_emergency_stop``,
``hold``. The control is signed with the rig's or test's key, stamped now and sent once; the
receiver obeys it only if the signature, the stamp (within 30 s of its clock) and the sequence
are right. The emergency stop needs no key: ``./pd control estop`` waits until the number of
listeners on the lab-wide ``/pd/emergency_stop`` topic stops growing (every bridge and the
integrator listen), then publishes the stop ten times in one second (every listener latches it,
so a repeat changes nothing and a late-matched bridge still gets it).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import rclpy
from rclpy.node import Node
from std_msgs.msg import String

from pd_common.auth import KEY_FILE_ENV, AuthError, Signer, load_key
from pd_common.protocol import GLOBAL_EMERGENCY_STOP, site_topic_name
from pd_common.ros import CONTROL_DEPTH, repeat_emergency_stop, settle_listeners
from pd_msgs.msg import Control as ControlMessage

from .operator import signed_control
from .rig import default_rig_key

TEST_COMMANDS = ('pause', 'resume', 'hold', 'abort', 'restarted')
BRIDGE_COMMANDS = ('reset', 'reset_emergency_stop', 'hold')


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """Command-line arguments."""
    parser = argparse.ArgumentParser(prog='control', description=__doc__.splitlines()[0])
    parser.add_argument('command', help=f'{", ".join(TEST_COMMANDS)} (integrator); '
                        f'{", ".join(BRIDGE_COMMANDS)} (with --bridge); estop (no key)')
    parser.add_argument('--bridge', action='store_true', help="to a bridge's bridge/control")
    parser.add_argument('--site', default='', help='the site of a substructured test')
    parser.add_argument('--key', type=Path, default=None,
                        help=f'key file (default: ${KEY_FILE_ENV}, then {default_rig_key()})')
    parser.add_argument('--reason', default='', help='why (shown in the logs and statuses)')
    parser.add_argument('--timeout', type=float, default=10.0,
                        help='seconds to wait for the receiver (default 10)')
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    """Entry point; 0 when the control was delivered to a subscriber, 1 if none, 2 on input."""
    args = parse_args(argv)
    command = args.command.strip().lower()
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    allowed = BRIDGE_COMMANDS if args.bridge else (*TEST_COMMANDS, 'estop')
    if command not in allowed:
        print(f'control: error: {command!r} is not a {"bridge" if args.bridge else "test"} '
              f'control ({", ".join(allowed)})', file=sys.stderr)
        return 2
    signer = None
    if command != 'estop':
        path = args.key or Path(os.environ.get(KEY_FILE_ENV) or default_rig_key())
        try:
            signer = Signer(load_key(path))
        except AuthError as err:
            print(f'control: error: {err}', file=sys.stderr)
            return 2
    rclpy.init()
    try:
        node = Node('pd_control', namespace='pd')
        if command == 'estop':
            topic, publisher = GLOBAL_EMERGENCY_STOP, node.create_publisher(
                String, GLOBAL_EMERGENCY_STOP, CONTROL_DEPTH)
            message: object = String(data=args.reason or 'pd control estop')
        else:
            assert signer is not None
            topic = (site_topic_name(args.site, 'bridge/control') if args.bridge
                     else site_topic_name('', 'test_control'))
            publisher = node.create_publisher(ControlMessage, topic, CONTROL_DEPTH)
            message = signed_control(signer, command, args.site, args.reason)

        def spin(seconds: float) -> None:
            until = time.monotonic() + seconds
            while (left := until - time.monotonic()) > 0.0:
                rclpy.spin_once(node, timeout_sec=left)

        # The e-stop goes to every bridge and the integrator; a control to its one receiver.
        listeners = settle_listeners(publisher.get_subscription_count, timeout=args.timeout,
                                     settle=0.5 if command == 'estop' else 0.0, wait=spin)
        if listeners == 0:
            print(f'control: error: nobody listens on {topic} (is the test running? same '
                  'ROS_DOMAIN_ID?)', file=sys.stderr)
            return 1
        if command == 'estop':
            repeat_emergency_stop(lambda: publisher.publish(message), sleep=spin)
        else:
            publisher.publish(message)
        spin(0.5)  # let the reliable transport deliver it
        print(f'control: {command} sent on {topic} ({listeners} listening)')
        return 0
    finally:
        rclpy.try_shutdown()


if __name__ == '__main__':
    sys.exit(main())
