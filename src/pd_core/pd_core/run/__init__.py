"""Running a test, split by concern: the test, the step loop, the record.

* :mod:`.definition`, :mod:`.test_file`, :mod:`.collapse` — the test file,
  :class:`TestDefinition` and its collapse rule;
* :mod:`.loop` — the step loop: the step protocol, :class:`TestSession` (trial, commit,
  revert, hold), the coordinator of the sites, the dispatcher, epochs, steering;
* :mod:`.record` — the record: the journal, the bag, the committed response, the energy
  balance, the run folder's files and figures (it never imports the loop);
* :mod:`.runner` — ROS-free runs, replays and recovery; :mod:`.resume` — continuing a stopped
  run (the checks and the policy); :mod:`.bridge_limits` — a site's bridge limits offline.
"""

from __future__ import annotations

from .definition import TestDefinition
from .loop.protocol import StepProtocol, Verdict
from .loop.session import TestSession
from .record.history import ResponseHistory
from .test_file import PARAMETER_PATHS, from_dict, from_json, load_test_file

__all__ = [
    'PARAMETER_PATHS',
    'ResponseHistory',
    'StepProtocol',
    'TestDefinition',
    'TestSession',
    'Verdict',
    'from_dict',
    'from_json',
    'load_test_file',
]
