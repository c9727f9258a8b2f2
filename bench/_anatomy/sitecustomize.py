"""A probe of where a node's step goes (``bench/step_anatomy.py``); loaded only by that bench.

Python imports ``sitecustomize`` at start-up from the path: the bench puts this folder first on
the ``PYTHONPATH`` of the processes it starts, with ``PD_ANATOMY_DIR`` naming where they write.
It wraps ``rclpy``'s ``Publisher.publish`` and the callbacks of raw (``raw=True``)
subscriptions, and times, per message a raw callback answers: from the callback's start to the
publish (the node's own work before the answer leaves), the publish call, and from its end to
the callback's end (work after the answer left). At exit each process writes the samples
(ns) to ``<PD_ANATOMY_DIR>/<executable>-<pid>.json``. Without ``PD_ANATOMY_DIR`` it does
nothing.
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
    publish = Publisher.publish

    def timed_publish(self: Any, message: Any) -> None:
        start = clock()
        publish(self, message)
        end = clock()
        if state['entered'] and isinstance(message, bytes):  # an answer of a raw callback
            before.append(start - state['entered'])
            publishing.append(end - start)
            state['published'] = end

    create_subscription = Node.create_subscription

    def timed_subscription(self: Any, msg_type: Any, topic: str, callback: Any, qos: Any,
                           **kwargs: Any) -> Any:
        if kwargs.get('raw'):
            inner = callback

            def callback(data: bytes) -> None:
                state['entered'], state['published'] = clock(), 0
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
        if before:
            name = Path(sys.argv[0]).parent.name or Path(sys.argv[0]).name or 'python'
            (folder / f'{name}-{os.getpid()}.json').write_text(json.dumps(samples))

    atexit.register(write)


_FOLDER = os.environ.get('PD_ANATOMY_DIR')
if _FOLDER:
    try:
        _install(Path(_FOLDER))
    except ImportError:  # a process without rclpy: nothing to time
        pass
