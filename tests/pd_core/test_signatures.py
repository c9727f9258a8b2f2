"""Checking a run's recorded signatures again (``./pd replay --key``).

The journal holds the signed bytes as they travelled; each MAC is checked again from the
recorded fields with the key: the right key verifies all, an altered record fails its check,
and a key that none of the messages names is refused as the wrong key file.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from pd_common.auth import (
    WIRE_COMMAND,
    WIRE_FEEDBACK,
    Signer,
    generate_key,
    load_key,
    new_key,
    sign_wire_reply,
)
from pd_common.protocol import Command, Feedback, encode_command, encode_feedback
from pd_core.run.record.journal import JOURNAL_FILE, Journal, read_journal
from pd_core.run.record.signatures import ForeignKeyError, check_signatures
from pd_core.run.test_file import load_test_file
from pd_integrator import replay
from support.paths import DEFAULT_TEST

STEPS = 4


def signed_journal(path: Path, key: object, *, altered_step: int | None = None) -> None:
    """A journal of ``STEPS`` signed commands and feedback; ``altered_step``'s recorded
    feedback carries another force than the one its MAC covers (a bag altered after the test).
    """
    definition = load_test_file(DEFAULT_TEST).to_json()
    signer = Signer(key)  # type: ignore[arg-type]
    with Journal(path) as journal:
        journal.write_definition(definition, 1)
        for step in range(1, STEPS + 1):
            t_ns = 1_000 * step
            command = Command('t', step, 0.01 * step, ('top',), (0.001 * step,))
            feedback = Feedback('t', step, (0.001 * step,), (-10.0 * step,))
            _, signature = signer.sign_wire(
                WIRE_COMMAND, lambda bare, c=command, t=t_ns: encode_command(c, t, bare))
            _, reply = sign_wire_reply(
                key, WIRE_FEEDBACK,  # type: ignore[arg-type]
                lambda bare, f=feedback, t=t_ns: encode_feedback(f, t + 500, bare), signature)
            journal.write_command(command, t_ns, signature=signature)
            if step == altered_step:
                feedback = dataclasses.replace(feedback, restoring_force=(-11.0 * step,))
            journal.write_feedback(feedback, t_ns + 600, signature=reply, stamp_ns=t_ns + 500)


def test_the_key_that_signed_the_run_verifies_every_message(tmp_path: Path) -> None:
    key = new_key()
    signed_journal(tmp_path / JOURNAL_FILE, key)
    check = check_signatures(read_journal(tmp_path / JOURNAL_FILE), key)
    assert (check.verified, check.failed, check.unsigned) == (2 * STEPS, 0, 0)
    assert check.ok and check.key_id == key.key_id


def test_a_feedback_altered_after_the_test_fails_its_check(tmp_path: Path) -> None:
    key = new_key()
    signed_journal(tmp_path / JOURNAL_FILE, key, altered_step=3)
    check = check_signatures(read_journal(tmp_path / JOURNAL_FILE), key)
    assert (check.verified, check.failed) == (2 * STEPS - 1, 1)
    assert not check.ok


def test_a_key_that_signed_none_of_the_messages_is_refused(tmp_path: Path) -> None:
    key, other = new_key(), new_key()
    signed_journal(tmp_path / JOURNAL_FILE, key)
    expected = f'none of the recorded messages names key {other.key_id} .*{key.key_id}'
    with pytest.raises(ForeignKeyError, match=expected):
        check_signatures(read_journal(tmp_path / JOURNAL_FILE), other)


def test_replay_refuses_the_wrong_key_file_in_one_line_and_writes_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / 'run'
    run.mkdir()
    right, wrong = tmp_path / 'right.key', tmp_path / 'wrong.key'
    generate_key(right)
    generate_key(wrong)
    signed_journal(run / JOURNAL_FILE, load_key(right))
    out = tmp_path / 'replay'
    assert replay.main([str(run), '--out', str(out), '--no-figures', '--key', str(wrong)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and str(wrong) in lines[0] and 'names key' in lines[0], lines
    assert not out.exists()
