"""A probe of where a node's step goes (``bench/step_anatomy.py``); loaded only by that bench.

Python imports ``sitecustomize`` at start-up from the path: the bench puts this folder first on
the ``PYTHONPATH`` of the processes it starts, with ``PD_ANATOMY_DIR`` naming where they write.
It wraps ``rclpy``'s ``Publisher.publish`` and the callbacks of raw (``raw=True``)
subscriptions, and times, per message a raw callback answers: from the callback's start to the
publish (the node's own work before the answer leaves), the publish call, and from its end to
the callback's end (work after the answer left). At exit each process writes the samples
(ns) to ``<PD_ANATOMY_DIR>/<executable>-<pid>.json``. Without ``PD_ANATOMY_DIR`` it does
nothing.

For the real-time run's round trip (``step_anatomy.py --site rths``) it also keeps a time line
(``perf_counter_ns``: the machine's monotonic clock, the same in every process): every publish
of a step topic's bytes (start, end, ``command`` or ``feedback``), every raw callback's start on
one, and every target handed to a real-time actuator loop
(:meth:`pd_common.rths.realtime.RealtimeLoop.set_next_target`) with the time of the measurement
it answers.
"""

from __future__ import annotations

import atexit
import json
import os
import sys
import time
from pathlib import Path
from typing import Any


def _install(folder: Path) -> None:
    from rclpy.node import Node
    from rclpy.publisher import Publisher

    clock = time.perf_counter_ns
    samples: dict[str, list[int]] = {'before_publish': [], 'publish': [], 'after_publish': []}
    before, publishing, after = (samples[name] for name in samples)
    state = {'entered': 0, 'published': 0}
    line: dict[str, list[Any]] = {'chain_publish': [], 'chain_callback': [], 'chain_target': []}
    publish = Publisher.publish

    def kind(topic: str) -> str | None:
        return next((name for name in ('command', 'feedback')
                     if topic.endswith(f'step_{name}')), None)

    def timed_publish(self: Any, message: Any) -> None:
        start = clock()
        publish(self, message)
        end = clock()
        if isinstance(message, bytes) and (which := kind(self.topic_name)) is not None:
            line['chain_publish'].append((start, end, which))
        if state['entered'] and isinstance(message, bytes):  # an answer of a raw callback
            before.append(start - state['entered'])
            publishing.append(end - start)
            state['published'] = end

    def time_targets() -> None:
        """Wrap the real-time loop's target hand-over (once, when a node makes its topics)."""
        if state.get('targets'):
            return
        state['targets'] = 1
        try:
            from pd_common.rths.realtime import RealtimeLoop
        except ImportError:
            return
        set_next_target = RealtimeLoop.set_next_target

        def timed_target(self: Any, target: float) -> None:
            measured = self._measured_at  # (read before the hand-over consumes it)
            set_next_target(self, target)
            if measured is not None:
                line['chain_target'].append((clock(), round(measured * 1e9)))

        RealtimeLoop.set_next_target = timed_target  # type: ignore[method-assign]

    create_subscription = Node.create_subscription

    def timed_subscription(self: Any, msg_type: Any, topic: str, callback: Any, qos: Any,
                           **kwargs: Any) -> Any:
        time_targets()
        if kwargs.get('raw'):
            inner = callback
            which = kind(topic)

            def callback(data: bytes) -> None:
                state['entered'], state['published'] = clock(), 0
                if which is not None:
                    line['chain_callback'].append((state['entered'], which))
                try:
                    inner(data)
                finally:
                    if state['published']:
                        after.append(clock() - state['published'])
                    state['entered'] = 0

        return create_subscription(self, msg_type, topic, callback, qos, **kwargs)

    Publisher.publish = timed_publish  # type: ignore[method-assign]
    Node.create_subscription = timed_subscription  # type: ignore[method-assign]

    def write() -> None:
        if before or any(line.values()):
            name = Path(sys.argv[0]).parent.name or Path(sys.argv[0]).name or 'python'
            (folder / f'{name}-{os.getpid()}.json').write_text(json.dumps({**samples, **line}))

    atexit.register(write)


_FOLDER = os.environ.get('PD_ANATOMY_DIR')
if _FOLDER:
    try:
        _install(Path(_FOLDER))
    except ImportError:  # a process without rclpy: nothing to time
        pass
