"""How a run went on after it stopped: run_test's restarts, a person's resumes.

Both are run events (``/pd/run_events`` in the bag, ``run_events`` in ``summary.json``): a
process run_test restarted with its state is a ``restart`` event, the integrator continued from
its journal a ``resumed`` event. A ``resumed`` event whose note begins with
:data:`RESTART_NOTE` is run_test's restart of the integrator; any other is a person's
``./pd run --resume``.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

__all__ = ['RESTART_NOTE', 'count_continuations']

#: How the note of a ``resumed`` event begins when run_test restarted the integrator.
RESTART_NOTE = 'restarted by run_test'


def count_continuations(events: Iterable[Mapping[str, object]]) -> tuple[int, int]:
    """``(restarts, resumes)`` of a run's events (see the module)."""
    restarts = resumes = 0
    for event in events:
        what = event.get('what')
        if what == 'restart':
            restarts += 1
        elif what == 'resumed':
            if str(event.get('note') or '').startswith(RESTART_NOTE):
                restarts += 1
            else:
                resumes += 1
    return restarts, resumes
