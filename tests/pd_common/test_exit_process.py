"""``exit_process``: a console entry point ends at once after its ``main``, with its exit code,
its standard streams flushed and its ``atexit`` handlers run; an exception still takes the
normal way out; a node process shut down this way exits 0. ``run_node``'s teardown deadline:
a teardown that hangs ends the process with its exit code and one line; one in time is not
cut short later."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
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


_HANGING_TEARDOWN = '''
    import re, sys, time
    import rclpy
    from pd_common.ros import exit_process, run_node

    TIMEOUT = float(sys.argv[1])
    HANG = sys.argv[2] == 'hang'

    def make():
        node = rclpy.create_node('teardown_probe')
        if HANG:  # as a reliable publisher's destroy that never returns
            node.destroy_node = lambda: time.sleep(600)
        if sys.argv[2] == 'gil':  # ... and one that holds the GIL all along (re does)
            node.destroy_node = lambda: re.match(r'(a+)+$', 'a' * 60 + 'b')
        return node

    def body(node, executor):
        executor.spin_once(timeout_sec=0.01)
        return 5

    def main():
        rclpy.init()
        code = run_node('probe', make, (), body, teardown_timeout=TIMEOUT)
        time.sleep(3 * TIMEOUT)  # a deadline not cancelled would end the process here
        print('after run_node', code, flush=True)
        return 0

    exit_process(main)
    '''


def _run_teardown(tmp_path: Path, timeout: float, mode: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
           'ROS_DOMAIN_ID': str(100 + os.getpid() % 100)}
    return subprocess.run([sys.executable, '-c', textwrap.dedent(_HANGING_TEARDOWN),
                           str(timeout), mode], capture_output=True, text=True, timeout=60,
                          cwd=tmp_path, env=env, check=False)


def test_a_teardown_that_hangs_ends_the_process_with_its_code_at_the_deadline(
        tmp_path: Path) -> None:
    result = _run_teardown(tmp_path, 1.0, 'hang')
    assert result.returncode == 5, result.stderr
    assert 'after run_node' not in result.stdout
    lines = [line for line in result.stderr.splitlines() if 'teardown' in line]
    assert len(lines) == 1
    assert lines[0].startswith('probe: warning: the rclpy teardown took over 1 s')


def test_a_teardown_in_time_cancels_its_deadline(tmp_path: Path) -> None:
    result = _run_teardown(tmp_path, 0.5, 'normal')
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == 'after run_node 5'
    assert 'teardown' not in result.stderr


def test_a_teardown_that_holds_the_gil_still_ends(tmp_path: Path) -> None:
    """The timer's thread never runs while the teardown holds the GIL: the kernel's alarm
    (SIGALRM's default action) ends the process a few seconds after the deadline."""
    start = time.monotonic()
    result = _run_teardown(tmp_path, 1.0, 'gil')
    assert result.returncode == -signal.SIGALRM, result.stderr
    assert time.monotonic() - start < 30.0
    assert 'after run_node' not in result.stdout


def test_settle_collector_freezes_what_is_alive_and_still_collects_what_comes_after(
        tmp_path: Path) -> None:
    """A node process's start-up is collected once and frozen (a full pass of the collector
    no longer walks it); cycles made while the test steps are still collected."""
    result = _run('''
        import gc, weakref
        from pd_common.ros import settle_collector

        class Part:
            pass

        before = Part(); before.me = before; gone_before = weakref.ref(before); del before
        kept = [Part() for _ in range(1000)]
        settle_collector()
        assert gone_before() is None, 'the garbage of the start-up was not collected'
        assert gc.get_freeze_count() >= 1000, gc.get_freeze_count()
        after = Part(); after.me = after; gone_after = weakref.ref(after); del after
        gc.collect()
        assert gone_after() is None, 'a cycle made after the freeze was not collected'
        print('settled', len(kept))
    ''', tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == 'settled 1000'



def test_a_callback_that_fails_because_the_context_went_down_ends_quietly(
        tmp_path: Path) -> None:
    """A signal shuts the context down outside the executor: a timer's or a subscription's
    callback publishing then fails, and that failure is the shutdown (no FATAL log); while the
    context is up, it is raised."""
    result = _run('''
        import rclpy
        from std_msgs.msg import String
        from pd_common.ros import events_executor, quiet_at_shutdown

        rclpy.init()
        node = rclpy.create_node('quiet_probe')
        publisher = node.create_publisher(String, 'quiet_probe', 10)
        calls = []

        def beat():
            calls.append(1)
            publisher.publish(String(data='beat'))

        # run by the executor as a timer: it is called as it was written (no TimerInfo)
        timer = node.create_timer(0.01, quiet_at_shutdown(node, beat))
        executor = events_executor(node)
        while not calls:
            executor.spin_once(timeout_sec=0.1)
        node.destroy_timer(timer)
        print('timer ran', len(calls))
        calls.clear()

        def broken():
            raise RuntimeError('a bug')

        quiet_at_shutdown(node, beat)()  # context up: publishes
        try:
            quiet_at_shutdown(node, broken)()
        except RuntimeError:
            print('raised while up')
        rclpy.shutdown()
        try:
            beat()
        except Exception:
            print('unguarded fails once down')
        quiet_at_shutdown(node, beat)()  # context down: the same failure, quiet
        print('quiet', len(calls))

        def answer(data, *, topic=''):  # a subscription's callback (a raw message)
            calls.append(data)
            publisher.publish(String(data=data.decode()))

        try:
            answer(b'late')
        except Exception:
            print('unguarded answer fails once down')
        quiet_at_shutdown(node, answer)(b'late', topic='step_command')
        print('quiet answer', calls[-1].decode())
    ''', tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split('\n')[:6] == ['timer ran 1', 'raised while up',
                                             'unguarded fails once down', 'quiet 3',
                                             'unguarded answer fails once down',
                                             'quiet answer late']
