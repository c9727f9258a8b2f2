"""Small rclpy processes for the network-namespace test (tests/graph/test_netns.py).

``netns_echo.py echo SITE``: subscribes to ``/pd_netns/ping`` and publishes every message back,
unchanged, on ``/pd_netns/pong_SITE``.

``netns_echo.py ping SITE[,SITE...] --count N --size M``: publishes ``/pd_netns/ping``
(Float64MultiArray: sequence number, then M−1 payload values) and waits for the answer of every
site on ``/pd_netns/pong_SITE``. Warm-up pings (negative sequence numbers, every 50 ms) run until
all sites answer one: that time from node creation is the discovery time. Then N round trips,
one at a time. Prints one JSON line ``RESULT {...}`` and exits 0 if every answer arrived.

The domain comes from ``ROS_DOMAIN_ID``, discovery and transports from the environment (see
netns_support.NetnsHub.env).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64MultiArray

QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)


def make_executor(context: rclpy.Context):
    """EventsExecutor if available (driven by spin_once only), else SingleThreadedExecutor."""
    try:
        from rclpy.experimental import EventsExecutor
        return EventsExecutor(context=context)
    except ImportError:
        from rclpy.executors import SingleThreadedExecutor
        return SingleThreadedExecutor(context=context)


def fastdds_shm_mapped() -> set[str]:
    """Fast DDS shared-memory files this process has mapped (none when UDP-only)."""
    with open('/proc/self/maps', encoding='utf-8', errors='replace') as maps:
        return {line.rsplit('/', 1)[-1].strip() for line in maps
                if '/dev/shm/' in line and 'fastdds' in line}


def echo(site: str, context: rclpy.Context) -> int:
    node = Node(f'netns_echo_{site}', context=context)
    pong = node.create_publisher(Float64MultiArray, f'/pd_netns/pong_{site}', QOS)
    node.create_subscription(Float64MultiArray, '/pd_netns/ping', pong.publish, QOS)
    executor = make_executor(context)
    executor.add_node(node)
    print(f'echo {site} ready', flush=True)
    while context.ok():
        executor.spin_once(timeout_sec=0.1)
    return 0


def ping(sites: list[str], count: int, size: int, timeout: float,
         context: rclpy.Context) -> int:
    started = time.monotonic()
    node = Node('netns_ping', context=context)
    publisher = node.create_publisher(Float64MultiArray, '/pd_netns/ping', QOS)
    answers: dict[str, set[int]] = {site: set() for site in sites}

    def on_pong(site: str):
        def callback(msg: Float64MultiArray) -> None:
            answers[site].add(int(msg.data[0]))
        return callback

    for site in sites:
        node.create_subscription(Float64MultiArray, f'/pd_netns/pong_{site}', on_pong(site),
                                 QOS)
    executor = make_executor(context)
    executor.add_node(node)
    payload = [float(i) for i in range(1, size)]

    def send(seq: int) -> None:
        msg = Float64MultiArray()
        msg.data = [float(seq), *payload]
        publisher.publish(msg)

    def all_answered(seq: int) -> bool:
        return all(seq in got for got in answers.values())

    # Discovery: warm-up pings until every site answers one.
    deadline = started + timeout
    seq = -1
    discovered = None
    next_send = 0.0
    warmups = 0
    while time.monotonic() < deadline:
        now = time.monotonic()
        if now >= next_send:
            seq -= 1
            send(seq)
            warmups += 1
            next_send = now + 0.05
        executor.spin_once(timeout_sec=0.005)
        if any(all_answered(s) for s in range(seq, 0)):
            discovered = time.monotonic() - started
            break
    result: dict[str, object] = {'sites': sites, 'size': size, 'count': count,
                                 'warmup_pings': warmups,
                                 'discovery_s': discovered,
                                 'message_bytes': 8 * size}
    if discovered is None:
        result['error'] = 'discovery timed out'
        print('RESULT ' + json.dumps(result), flush=True)
        return 1

    rtts = []
    missing = []
    for seq in range(count):
        sent = time.perf_counter()
        send(seq)
        limit = time.monotonic() + 2.0
        while not all_answered(seq) and time.monotonic() < limit:
            executor.spin_once(timeout_sec=0.01)
        if all_answered(seq):
            rtts.append(time.perf_counter() - sent)
        else:
            missing.append(seq)
    result.update({
        'answered': len(rtts), 'missing': missing,
        'shm_mapped': sorted(fastdds_shm_mapped()),
        'median_rtt_ms': 1e3 * statistics.median(rtts) if rtts else None,
        'max_rtt_ms': 1e3 * max(rtts) if rtts else None,
        'total_s': time.monotonic() - started,
    })
    print('RESULT ' + json.dumps(result), flush=True)
    return 0 if not missing else 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    sub = parser.add_subparsers(dest='role', required=True)
    e = sub.add_parser('echo')
    e.add_argument('site')
    p = sub.add_parser('ping')
    p.add_argument('sites', help='comma-separated site names')
    p.add_argument('--count', type=int, default=50)
    p.add_argument('--size', type=int, default=256, help='float64 values per message')
    p.add_argument('--timeout', type=float, default=10.0, help='discovery timeout, s')
    args = parser.parse_args(argv)

    context = rclpy.Context()
    rclpy.init(context=context, domain_id=int(os.environ.get('ROS_DOMAIN_ID', '0')))
    try:
        if args.role == 'echo':
            return echo(args.site, context)
        return ping(args.sites.split(','), args.count, args.size, args.timeout, context)
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0
    finally:
        if context.ok():
            rclpy.shutdown(context=context)


if __name__ == '__main__':
    sys.exit(main())
