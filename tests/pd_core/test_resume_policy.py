"""The resume policy of a restored run (core.run.resume.decide_resume), without ROS.

Each rule is checked against the case that would break it: a person's stop on record must
never be resumed by a restart, a physical site never moves without the operator, a refused
check always holds, and a run that was running is the only one that goes on by itself.
"""

from __future__ import annotations

import pytest

from pd_common.protocol import TestState
from pd_core.run.resume import (
    ResumeAction,
    ResumeCheck,
    ResumeDecision,
    decide_resume,
)

RECORDED = [TestState.RUNNING, TestState.INTERRUPTED, TestState.PAUSED, TestState.HOLDING,
            TestState.IDLE]


def _decide(recorded: TestState, check: ResumeCheck | None = None, *,
            person_hold: str | None = None, hold_on_resume: bool = False,
            confirm_resume: bool = False) -> ResumeDecision:
    return decide_resume(recorded, check or ResumeCheck(), person_hold=person_hold,
                         hold_on_resume=hold_on_resume, confirm_resume=confirm_resume,
                         note='restart 1', gap_s=42.4)


@pytest.mark.parametrize('recorded', RECORDED)
def test_only_a_run_that_was_running_goes_on_by_itself(recorded: TestState) -> None:
    decision = _decide(recorded)
    if recorded in (TestState.RUNNING, TestState.INTERRUPTED):
        assert decision.action is ResumeAction.GO_ON
        assert decision.state is TestState.HOLDING  # until the loop re-sends what it owes
        assert decision.message == 'resumed from the record'
    else:
        assert decision.action is ResumeAction.STAY
        assert decision.state is recorded and decision.message is None  # its own message


@pytest.mark.parametrize('recorded', RECORDED)
@pytest.mark.parametrize('confirm_resume', [False, True])
def test_a_persons_stop_on_record_is_never_resumed_by_a_restart(
        recorded: TestState, confirm_resume: bool) -> None:
    decision = _decide(recorded, person_hold='emergency stop latched (smoke)',
                       confirm_resume=confirm_resume)
    assert decision.action is ResumeAction.WAIT_FOR_PERSON
    assert decision.state is not TestState.RUNNING
    assert decision.message == ('emergency stop latched (smoke); resume with ./pd control '
                                'resume')


def test_hold_on_resume_waits_for_a_person_and_says_why() -> None:
    decision = _decide(TestState.RUNNING, hold_on_resume=True)
    assert decision.action is ResumeAction.WAIT_FOR_PERSON
    assert decision.state is TestState.HOLDING
    assert 'restored after a stop (restart 1)' in (decision.message or '')


def test_a_physical_site_waits_for_the_operators_confirmation() -> None:
    check = ResumeCheck(confirm=['site lab: physical specimen, hardware state, at [0.01] m'])
    decision = _decide(TestState.RUNNING, check)
    assert decision.action is ResumeAction.WAIT_FOR_CONFIRMATION
    assert decision.state is TestState.HOLDING
    assert decision.message is not None
    assert decision.message.startswith('resumed after a gap of 42 s: site lab: physical')
    confirmed = _decide(TestState.RUNNING, check, confirm_resume=True)
    assert confirmed.action is ResumeAction.GO_ON


@pytest.mark.parametrize('recorded', RECORDED)
def test_a_refused_check_holds_whatever_else_is_said(recorded: TestState) -> None:
    check = ResumeCheck(refused=['site lab: a fresh specimen state'],
                        confirm=['site lab: physical specimen'])
    decision = _decide(recorded, check, person_hold=None, hold_on_resume=False,
                       confirm_resume=True)
    assert decision.action is ResumeAction.REFUSE
    assert decision.message == 'cannot resume: site lab: a fresh specimen state'
    assert decision.state is not TestState.RUNNING
