"""Running a test: its definition, the step protocol, the session, the bag and the outputs.

* :mod:`.definition` — the test file's schema and :class:`TestDefinition`;
* :mod:`.protocol` — which feedback advances a step, re-sends and holds;
* :mod:`.session` — :class:`TestSession`, one test step by step (owns commit, revert, hold);
* :mod:`.coordinator` — the step protocol across the sites of a substructured test;
* :mod:`.dispatch` — the one step loop of the node and the ROS-free runner;
* :mod:`.history`, :mod:`.energy`, :mod:`.outputs` — the committed response and the run
  folder's CSV files, summary and figures;
* :mod:`.bag` — the rosbag2 record; :mod:`.runner` — ROS-free runs and replays;
  :mod:`.progress` — progress lines.
"""

from __future__ import annotations

from .definition import TestDefinition
from .history import ResponseHistory
from .protocol import StepProtocol, Verdict
from .session import TestSession
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
