"""A receiver started by hand serves the same test file run twice as two runs."""

from __future__ import annotations

from pd_common.protocol import RunTags, StepKey, untag


def test_a_new_integrator_at_step_0_after_later_steps_starts_a_new_run() -> None:
    tags = RunTags()
    first = [tags.tag('T', StepKey(step), 'a') for step in range(4)]
    assert first == ['T'] * 4
    # the same session going back (a stale command) is not a new run; nor is a re-send
    assert tags.tag('T', StepKey(0), 'a') == 'T'
    assert tags.tag('T', StepKey(3), 'a') == 'T'
    # a resumed run (a new session) continues where the record stops: the same run
    assert tags.tag('T', StepKey(3), 'b') == 'T'
    assert tags.tag('T', StepKey(4), 'b') == 'T'
    # a new integrator starts the test file again: run 2, then its later steps, then run 3
    assert tags.tag('T', StepKey(0), 'c') == 'T#2'
    assert tags.tag('T', StepKey(1), 'c') == 'T#2'
    assert tags.tag('T', StepKey(1, 3), 'c') == 'T#2'
    assert tags.tag('T', StepKey(0), 'd') == 'T#3'
    assert untag('T#3') == 'T' and untag('T') == 'T'
    # another test is its own: its first run is untagged
    assert tags.tag('U', StepKey(5), 'd') == 'U'


def test_without_authentication_step_0_after_later_steps_is_a_new_run() -> None:
    tags = RunTags()
    assert [tags.tag('T', StepKey(step), '') for step in (0, 1, 2)] == ['T'] * 3
    assert tags.tag('T', StepKey(0), '') == 'T#2'
    # a crash at step 0 re-sends step 0: not later than anything, the same run
    fresh = RunTags()
    assert fresh.tag('T', StepKey(0), 'a') == fresh.tag('T', StepKey(0), 'b') == 'T'
