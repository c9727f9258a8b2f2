"""``exit_process``: a console entry point ends at once after its ``main``, with its exit code,
its standard streams flushed and its ``atexit`` handlers run; an exception still takes the
normal way out; a node process shut down this way exits 0."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path


def _run(code: str, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
           'ROS_DOMAIN_ID': str(100 + os.getpid() % 100)}
    return subprocess.run([sys.executable, '-c', textwrap.dedent(code)], capture_output=True,
                          text=True, timeout=60, cwd=tmp_path, env=env, check=False)


def test_exit_code_streams_and_atexit_handlers(tmp_path: Path) -> None:
    result = _run('''
        import atexit, pathlib, sys
        from pd_common.ros import exit_process

        def main():
            atexit.register(lambda: pathlib.Path('atexit-ran').write_text('yes'))
            sys.stdout.write('no newline at the end')
            sys.stderr.write('on stderr too')
            return 3

        exit_process(main)
        print('never reached')
        ''', tmp_path)
    assert result.returncode == 3
    assert result.stdout == 'no newline at the end'
    assert result.stderr == 'on stderr too'
    assert (tmp_path / 'atexit-ran').read_text() == 'yes'


def test_none_is_exit_code_0_and_an_exception_exits_normally(tmp_path: Path) -> None:
    assert _run('''
        from pd_common.ros import exit_process
        exit_process(lambda: None)
        ''', tmp_path).returncode == 0
    failed = _run('''
        from pd_common.ros import exit_process

        def main():
            raise ValueError('a bug in main')

        exit_process(main)
        ''', tmp_path)
    assert failed.returncode == 1
    assert 'Traceback' in failed.stderr
    assert failed.stderr.strip().endswith('ValueError: a bug in main')


def test_a_node_process_shut_down_then_ended_at_once(tmp_path: Path) -> None:
    result = _run('''
        import rclpy
        from std_msgs.msg import String
        from pd_common.ros import events_executor, exit_process, run_node

        def main():
            rclpy.init()

            def body(node, executor):
                publisher = node.create_publisher(String, 'exit_process_probe', 10)
                publisher.publish(String(data='before the end'))
                for _ in range(5):
                    executor.spin_once(timeout_sec=0.01)
                node.get_logger().info('node done')
                return 7

            return run_node('probe', lambda: rclpy.create_node('exit_probe'), (), body)

        exit_process(main)
        ''', tmp_path)
    assert result.returncode == 7, result.stderr
    assert 'node done' in result.stderr
