"""The record of a test: what is kept on disk while it runs and what is made of it after.

* :mod:`.journal` — the crash-safe record (fsync'd, resumable);
* :mod:`.bag` — the rosbag2 (MCAP) record and reading it back; :mod:`.signatures` — the
  signed messages in it;
* :mod:`.history` — the committed response; :mod:`.energy` — its energy balance;
* :mod:`.outputs`, :mod:`.actuators`, :mod:`.figure_worker` — the run folder's CSV files,
  summary and figures;
* :mod:`.continuations` — run_test's restarts and a person's resumes among the run's events.

Nothing here imports the step loop (:mod:`..loop`): an import contract keeps it so.
"""
