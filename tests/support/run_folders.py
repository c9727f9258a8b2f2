"""A run folder of ``run_test`` stopped before its first step, as ``--resume`` finds it."""

from __future__ import annotations

from pathlib import Path

from pd_bringup.launcher import parse_args, plan_new_run
from pd_bringup.plan import LaunchPlan
from pd_core.run.loop.session import TestSession
from pd_core.run.record.journal import JOURNAL_FILE, Journal
from pd_core.run.runner import DEFINITION_JSON


def stopped_run(out: Path, test_file: Path, *options: str) -> LaunchPlan:
    """Plan ``run_test TEST_FILE --out OUT --no-authentication OPTIONS`` and leave its folder
    as a run stopped before its first step (resumable): its plan, its definition and a
    journal holding the definition and the first status."""
    plan, definition, _ = plan_new_run(parse_args(
        [str(test_file), '--out', str(out), '--no-authentication', *options]))
    plan.save()
    text = definition.to_json()
    (out / DEFINITION_JSON).write_text(text, encoding='utf-8')
    with Journal(out / JOURNAL_FILE) as journal:
        journal.write_definition(text, 1)
        journal.write_status(TestSession(definition).status(), 2)
    return plan
