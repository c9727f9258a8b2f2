"""The executor of every node: rclpy's EventsExecutor, spun with ``spin_once`` loops.

``EventsExecutor().spin()`` does not return on shutdown with the wheels of this workspace, so
the nodes spin it with ``spin_once(timeout_sec=...)`` in loops of their own (which also lets
them poll timeouts and stop flags between events).
"""

from __future__ import annotations

import atexit
import functools
import gc
import os
import signal
import sys
import threading
from collections.abc import Callable
from time import monotonic
from typing import TYPE_CHECKING, NoReturn, ParamSpec, TypeVar

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.experimental.events_executor import EventsExecutor
from rclpy.signals import SignalHandlerOptions

from pd_common.dds import use_discovery_profile
from pd_common.signals import StopFlag, stop_on_signals

if TYPE_CHECKING:
    from rclpy.executors import Executor
    from rclpy.node import Node

__all__ = ['TEARDOWN_TIMEOUT', 'events_executor', 'exit_process', 'init_with_stop_flag',
           'quiet_at_shutdown', 'run_node', 'settle_collector', 'spin_until_shutdown']

NodeT = TypeVar('NodeT', bound='Node')
Args = ParamSpec('Args')

#: Seconds a node process's rclpy teardown (executor shut down, node destroyed, rclpy shut
#: down) may take after its ``cleanup``; past them the process ends with its exit code.
TEARDOWN_TIMEOUT = 10.0


def events_executor(node: Node) -> Executor:
    """A new EventsExecutor with ``node`` added."""
    executor = EventsExecutor()
    executor.add_node(node)
    return executor


def spin_until_shutdown(executor: Executor, timeout_sec: float,
                        between: Callable[[], None] | None = None, *,
                        every: float = 0.0) -> None:
    """Spin ``executor`` until the context shuts down (SIGINT/SIGTERM).

    Calling ``between`` after a ``spin_once``, at most every ``every`` seconds (0: after every
    one). A node's periodic checks (timeouts of seconds) need not run after each message: at a
    thousand messages a second they would take their time from the steps.

    A callback (or ``between``) that was running when a signal shut the context down fails
    to publish or to count a publisher's matches ("publisher's context is invalid"): that is
    the shutdown, not an error, and ends the loop quietly; the same failure while the context
    is still up is raised. ``between`` is not called once the context is down.
    """
    context = executor.context
    due = 0.0
    while context.ok():
        try:
            executor.spin_once(timeout_sec=timeout_sec)
            if between is None:
                continue
            now = monotonic()
            if now >= due and context.ok():
                due = now + every
                between()
        except Exception:
            if context.ok():
                raise
            return


def quiet_at_shutdown(node: Node, callback: Callable[Args, None]) -> Callable[Args, None]:
    """``callback`` for a timer or a subscription of ``node``: quiet once the context is down.

    :func:`spin_until_shutdown`'s rule for the callbacks the executor runs. rclpy's signal
    handlers shut the context down outside the executor: a callback running at that moment
    fails to publish ("publisher's context is invalid"), and the executor would report it as a
    FATAL exception, logged to a rosout that is gone. That failure is the shutdown: the
    callback ends quietly. The same failure while the context is still up is raised.

    The wrapper carries ``callback``'s signature (``functools.wraps``): the executor reads it
    to decide whether a timer's callback takes a ``TimerInfo``, and a bare ``*args`` would
    make it pass one to a callback that takes none.
    """
    @functools.wraps(callback)
    def quiet(*args: Args.args, **kwargs: Args.kwargs) -> None:
        try:
            callback(*args, **kwargs)
        except Exception:
            if node.context.ok():
                raise

    return quiet


def init_with_stop_flag(args: list[str] | None = None) -> StopFlag:
    """``rclpy.init`` without rclpy's signal handlers.

    SIGINT and SIGTERM only set the returned flag, so a node that must end cleanly (write its
    record, publish its final status) does so from its own loop instead of being interrupted in the
    middle of a write. The flag takes no lock (:mod:`pd_common.signals`): a second signal
    during the first one's handling cannot deadlock the process. The process gets the shipped
    Fast DDS profile first (:func:`pd_common.dds.use_discovery_profile`).
    """
    use_discovery_profile()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop = StopFlag()
    stop_on_signals(stop)
    return stop


def run_node(program: str, make_node: Callable[[], NodeT],
             errors: tuple[type[Exception], ...],
             body: Callable[[NodeT, Executor], int | None], *,
             on_interrupt: Callable[[NodeT | None], int] | None = None,
             cleanup: Callable[[NodeT], None] | None = None,
             teardown_timeout: float | None = None) -> int:
    """The life of one node process after ``rclpy.init``: make, spin, clean up, shut down.

    Args:
        program: name for the one-line error of a node that cannot be made.
        make_node: builds the node; ``errors`` it raises are bad input: one line on stderr
            (``<program>: error: ...``) and exit code 2, no traceback.
        errors: the exceptions of bad input.
        body: runs the node with its executor; its return value is the exit code
            (``None``: 0).
        on_interrupt: called on SIGINT or an external shutdown (rclpy's signal handlers) with
            the node (``None`` if it was not made yet); returns the exit code (default 0).
        cleanup: called before the executor is shut down and the node destroyed (e.g. hold
            the actuator, close the state file), whatever ended the node.
        teardown_timeout: for a node process (never a node run in-process): seconds the
            teardown after ``cleanup`` may take. A reliable publisher whose matched reader
            was killed can block ``destroy_node`` for good (seen in Fast DDS); past the
            timeout one line goes to stderr and the process ends with its exit code (1 if
            an exception was on its way), its records already closed by ``body`` and
            ``cleanup``. ``None``: no limit.

    Returns:
        The exit code.
    """
    node: NodeT | None = None
    executor: Executor | None = None
    code = 0
    try:
        try:
            node = make_node()
        except errors as err:
            print(f'{program}: error: {err}', file=sys.stderr)
            return 2
        executor = events_executor(node)
        settle_collector()
        result = body(node, executor)
        code = 0 if result is None else result
    except (KeyboardInterrupt, ExternalShutdownException):
        code = on_interrupt(node) if on_interrupt is not None else 0
    except BaseException:
        code = 1  # the exit code if the teardown outlives its deadline; the error goes on
        raise
    finally:
        if node is not None and cleanup is not None:
            cleanup(node)
        deadline = (None if teardown_timeout is None
                    else _teardown_deadline(program, teardown_timeout, code))
        gc.unfreeze()  # (settle_collector's objects: the teardown may need them collected)
        if executor is not None:
            executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
        if deadline is not None:
            deadline.cancel()
            signal.alarm(0)
    return code


def settle_collector() -> None:
    """Leave what a node process made to start out of the cyclic garbage collector's passes.

    The modules, the node and its test are never garbage, yet a full pass of the collector
    walks them all: 15-40 ms in a node process (a stall of tens of steps in a 1024 Hz
    real-time test), and its middle generation ~1 ms. Collected once, then frozen
    (:func:`gc.freeze`): what the steps make is collected as before, only the start-up's
    objects are not walked again.
    """
    gc.collect()
    gc.freeze()


def _teardown_deadline(program: str, seconds: float, code: int) -> threading.Timer:
    """A started daemon timer that ends the process with ``code`` after ``seconds``."""

    def expire() -> None:
        try:
            print(f'{program}: warning: the rclpy teardown took over {seconds:g} s (a '
                  'publisher or the participant did not close); the process ends, its '
                  'records closed', file=sys.stderr, flush=True)
        except (OSError, ValueError):  # a closed stream: end anyway
            pass
        os._exit(code)

    timer = threading.Timer(seconds, expire)
    timer.daemon = True
    timer.start()
    # A backstop the interpreter cannot delay: a teardown blocked in C code that holds the
    # GIL never lets the timer's thread run; SIGALRM's default action ends the process anyway
    # (its records are closed already).
    if threading.current_thread() is threading.main_thread():
        signal.alarm(int(seconds) + 5)
    return timer


def exit_process(main: Callable[[], int | None]) -> NoReturn:
    """Run a process's ``main`` (which shuts rclpy down before it returns).

    Then end the process at once with its exit code.

    For a console entry point (``pd_integrator main`` and ``run_test``), never for a ``main``
    called in-process. After ``main`` returns, a normal exit would run the ``atexit``
    handlers and then tear down the interpreter's modules and the C++ libraries' static
    objects; for a process that has used Fast DDS the last two take 0.25–0.4 s (a fixed
    100 ms sleep among them) and nothing of them is needed: the participants and their
    shared-memory files are gone with ``rclpy.shutdown``, and every file ``main`` wrote is
    closed (the journal, the outputs). So the ``atexit`` handlers run (logging's flush among
    them), the standard streams are flushed, and the process ends. An exception from ``main``
    takes the normal way out (its traceback, exit code 1).
    """
    code = main()
    atexit._run_exitfuncs()  # what a normal exit runs first (private but stable in CPython)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe or stream: nothing left to flush
            pass
    os._exit(code or 0)
