"""The step loop: one test advanced step by step, at one site or across several.

* :mod:`.protocol` — which feedback advances a step, re-sends and holds;
* :mod:`.session` — :class:`TestSession`, one test step by step (owns trial, commit, revert,
  hold);
* :mod:`.coordinator` — the step protocol across the sites of a substructured test;
* :mod:`.dispatch` — the one step loop of the node and the ROS-free runner;
* :mod:`.epochs` — whose specimen state answers; :mod:`.steering` — a person's pause, hold
  and e-stop, durable; :mod:`.progress` — progress lines.

The loop reads the test (:mod:`..definition`, :mod:`..collapse`) and writes through
:mod:`..record`; neither imports the loop.

The loop writes through :mod:`..record`; the record never imports the loop.
"""
