"""Send a signed operator control and wait until its receiver confirms it: ``./pd control``.

To the integrator (``/pd/test_control``): ``pause``, ``resume``, ``hold``, ``abort``. To a
bridge (``--bridge [--site SITE]``, ``/pd/[<site>/]bridge/control``): ``reset``,
``reset_emergency_stop``, ``hold``, and its lifecycle transitions ``configure``,
``activate``, ``deactivate``, ``cleanup`` (with a key, the bridge takes them only so). The
control is bound to its receiver as the receiver's signed status names it (its node, its
instance session, its test), signed with the rig's or test's key and stamped now; the receiver
acknowledges it in its status, and the command waits for that: it prints what the receiver did
(exit 0), or why it refused (exit 1), and sends the control again (signed anew) when no
acknowledgement comes within a second, until ``--timeout`` (exit 1, naming the receiver).

The emergency stop needs no key: ``./pd control estop`` waits until the number of listeners
on the lab-wide ``/pd/emergency_stop`` topic stops growing, publishes the stop ten times in
one second (every listener latches it, a repeat changes nothing), and then waits until every
bridge and integrator that listens says it holds (its status' ``emergency_stop``), sending the
stop again meanwhile; it exits 1 naming any that did not confirm.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import String

from pd_common.auth import KEY_FILE_ENV, AuthError, Key, describe_refusals, load_key
from pd_common.dds import use_discovery_profile
from pd_common.protocol import (
    BRIDGE_CONTROLS,
    GLOBAL_EMERGENCY_STOP,
    TEST_CONTROLS,
    clip_reason,
    operator_name,
    site_topic_name,
)
from pd_common.ros import (
    CONTROL_DEPTH,
    RESEND_S,
    ControlSender,
    emergency_stop_receivers,
    repeat_emergency_stop,
    settle_listeners,
)

from .rig import default_rig_key

#: Seconds after the stop during which late-discovered listeners are still looked for.
LATE_DISCOVERY_S = 2.0


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """Command-line arguments."""
    parser = argparse.ArgumentParser(prog='control', description=__doc__.splitlines()[0])
    parser.add_argument('command', help=f'{", ".join(TEST_CONTROLS)} (integrator); '
                        f'{", ".join(BRIDGE_CONTROLS)} (with --bridge); estop (no key)')
    parser.add_argument('--bridge', action='store_true', help="to a bridge's bridge/control")
    parser.add_argument('--site', default='', help='the site of a substructured test')
    parser.add_argument('--key', type=Path, default=None,
                        help=f'key file (default: ${KEY_FILE_ENV}, then {default_rig_key()})')
    parser.add_argument('--reason', default='', help='why (shown in the logs, statuses and the '
                        'record; at most 256 characters)')
    parser.add_argument('--timeout', type=float, default=10.0,
                        help='seconds to wait for the receiver and its confirmation '
                        '(default 10)')
    return parser.parse_args(argv)


def _key_path(args: argparse.Namespace) -> Path:
    return args.key or Path(os.environ.get(KEY_FILE_ENV) or default_rig_key())


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``./pd control``; returns the exit status.

    Entry point: 0 when the receiver confirmed the control, 1 if it refused it or did not
    confirm it, 2 on bad input.
    """
    args = parse_args(argv)
    command = args.command.strip().lower()
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    allowed = BRIDGE_CONTROLS if args.bridge else (*TEST_CONTROLS, 'estop')
    if command not in allowed:
        print(f'control: error: {command!r} is not a {"bridge" if args.bridge else "test"} '
              f'control ({", ".join(allowed)})', file=sys.stderr)
        return 2
    if not (args.timeout > 0.0 and math.isfinite(args.timeout)):
        print(f'control: error: --timeout: must be a positive number of seconds, got '
              f'{args.timeout:g}', file=sys.stderr)
        return 2
    key: Key | None = None
    if command != 'estop':
        try:
            key = load_key(_key_path(args))
        except AuthError as err:
            print(f'control: error: {err}', file=sys.stderr)
            return 2
    else:  # anyone may stop; a key (if one is at hand) only checks the confirmations
        try:
            key = load_key(_key_path(args)) if _key_path(args).exists() else None
        except AuthError:
            key = None
    # (the shipped Fast DDS profile: the lab's nodes announce themselves every 250 ms and this
    # process every 100 ms at first, so they are found in a fraction of a second)
    use_discovery_profile()
    rclpy.init()
    try:
        node = Node('pd_control', namespace='pd')

        def spin(seconds: float) -> None:
            until = time.monotonic() + seconds
            while (left := until - time.monotonic()) > 0.0:
                rclpy.spin_once(node, timeout_sec=left)

        if command == 'estop':
            return _emergency_stop(node, key, args, spin)
        return _control(node, key, command, args, spin)
    except (KeyboardInterrupt, ExternalShutdownException):  # a signal while it waits
        print(f'control: error: interrupted: {command} not confirmed', file=sys.stderr)
        return 1
    finally:
        rclpy.try_shutdown()


def _control(node: Node, key: Key | None, command: str, args: argparse.Namespace,
             spin: object) -> int:
    """A signed control, bound to its receiver, until it is acknowledged."""
    assert callable(spin)
    sender = ControlSender(node, key, operator_name('pd control'))
    if args.bridge:
        topic = site_topic_name(args.site, 'bridge/control')
        status_topic = site_topic_name(args.site, 'bridge/status')
    else:
        topic, status_topic = (site_topic_name('', 'test_control'),
                               site_topic_name('', 'test_status'))
    sender.watch(status_topic)
    deadline = time.monotonic() + args.timeout
    while not sender.ready(topic, status_topic):
        if time.monotonic() > deadline:
            refused = describe_refusals(sender.gate.refused)
            why = (f'its statuses were refused ({refused}: the right key?)' if refused else
                   'no status from its node, or it does not listen (is the test running? '
                   'same ROS_DOMAIN_ID?)')
            print(f'control: error: no receiver for {command} on {topic}: {why}',
                  file=sys.stderr)
            return 1
        spin(0.05)
    sent = sender.send(command, topic, status_topic, clip_reason(args.reason))
    assert sent is not None
    receiver = sent.control.target
    while time.monotonic() < deadline:
        ack = sender.acknowledgement(sent)
        if ack is not None:
            if ack.ok:
                print(f'control: {command} taken by {receiver} (test {sent.control.test_id!r})'
                      f': {ack.outcome}')
                return 0
            print(f'control: error: {receiver} did not take {command}: {ack.outcome}',
                  file=sys.stderr)
            return 1
        if time.monotonic() - sent.sent_at >= RESEND_S:
            sent = sender.resend(sent)
        spin(0.05)
    print(f'control: error: {command} not confirmed by {receiver} within {args.timeout:g} s '
          f'(sent {sent.attempts} times on {topic})', file=sys.stderr)
    return 1


def _emergency_stop(node: Node, key: Key | None, args: argparse.Namespace,
                    spin: object) -> int:
    """The lab-wide stop, until every bridge and integrator listening confirms it holds."""
    assert callable(spin)
    topic = GLOBAL_EMERGENCY_STOP
    publisher = node.create_publisher(String, topic, CONTROL_DEPTH)
    message = String(data=clip_reason(args.reason) or 'pd control estop')
    deadline = time.monotonic() + args.timeout
    listeners = settle_listeners(publisher.get_subscription_count, timeout=args.timeout,
                                 settle=0.5, wait=spin)
    if listeners == 0:
        print(f'control: error: nobody listens on {topic} (is the test running? same '
              'ROS_DOMAIN_ID?)', file=sys.stderr)
        return 1
    receivers = emergency_stop_receivers(node, topic)
    sender = ControlSender(node, key, operator_name('pd control'))
    for status_topic in receivers.values():
        sender.watch(status_topic)
    repeat_emergency_stop(lambda: publisher.publish(message), sleep=spin)
    last_sent = time.monotonic()
    # A receiver discovered late (a site's bridge on a loaded machine) still gets the stop and
    # must confirm it: the listeners are looked up again while the confirmations come in, for
    # at least LATE_DISCOVERY_S.
    look_until = time.monotonic() + LATE_DISCOVERY_S

    def unconfirmed() -> list[str]:
        return [name for name, status_topic in sorted(receivers.items())
                if not (status_topic in sender.statuses
                        and sender.statuses[status_topic].emergency_stop)]

    while time.monotonic() < max(deadline, look_until):
        for name, status_topic in emergency_stop_receivers(node, topic).items():
            if name not in receivers:
                receivers[name] = status_topic
                sender.watch(status_topic)
        missing = unconfirmed()
        if not missing and time.monotonic() >= look_until:
            break
        if missing and time.monotonic() - last_sent >= 0.5:  # (latched: a repeat is counted)
            publisher.publish(message)
            last_sent = time.monotonic()
        spin(0.05)
    missing = unconfirmed()
    listeners = max(listeners, publisher.get_subscription_count())
    others = listeners - len(receivers)
    extra = f'; {others} other listener(s) cannot confirm' if others > 0 else ''
    if missing:
        print(f'control: error: estop sent on {topic} ({listeners} listening), but not '
              f'confirmed by {", ".join(missing)} within {args.timeout:g} s{extra}',
              file=sys.stderr)
        return 1
    names = ', '.join(sorted(receivers)) or 'no bridge or integrator listens'
    print(f'control: estop sent on {topic} ({listeners} listening); holding: {names}{extra}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
