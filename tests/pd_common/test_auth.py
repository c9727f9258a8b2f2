"""Message authentication: key files, MACs over every field, sessions, replays, controls."""

from __future__ import annotations

import dataclasses
import hashlib
import hmac
import os
import struct
from pathlib import Path

import numpy as np
import pytest

from pd_common.auth import (
    CommandGate,
    ControlGate,
    Key,
    KeyFileError,
    Refusal,
    ReplyGate,
    Signer,
    canonical,
    command_payload,
    control_payload,
    feedback_payload,
    generate_key,
    load_key,
    mac_of,
    new_key,
    session_start_payload,
    verify_mac,
)
from pd_common.protocol import (
    Command,
    Control,
    Feedback,
    FeedbackStatus,
    SessionStart,
    Signature,
)

COMMAND = Command(test_id='t1', step=7, test_time=0.07, dof_names=('u1', 'u2'),
                  target_displacement=(0.0125, -0.003), iteration=1)
FEEDBACK = Feedback(test_id='t1', step=7, measured_displacement=(0.0124, -0.003),
                    restoring_force=(3900.0, -875.0), iteration=1)


# -- key files ---------------------------------------------------------------------------------
def test_a_generated_key_file_is_owner_only_and_loads_back(tmp_path: Path) -> None:
    path = tmp_path / 'keys' / 'rig.key'
    key = generate_key(path)
    assert (path.stat().st_mode & 0o777) == 0o600
    assert (path.parent.stat().st_mode & 0o777) == 0o700
    again = load_key(path)
    assert again == key and len(key.secret) == 32 and len(key.key_id) == 16
    assert key.secret.hex() not in repr(key)  # the secret is never printed
    with pytest.raises(KeyFileError, match='exists already'):
        generate_key(path)


@pytest.mark.parametrize('mode', [0o644, 0o640, 0o604, 0o660, 0o602])
def test_a_key_file_others_can_access_is_refused_in_one_line(tmp_path: Path, mode: int) -> None:
    path = tmp_path / 'rig.key'
    generate_key(path)
    os.chmod(path, mode)
    with pytest.raises(KeyFileError) as info:
        load_key(path)
    message = str(info.value)
    assert '\n' not in message
    assert str(path) in message and f'{mode:04o}' in message and 'chmod 600' in message


@pytest.mark.parametrize('text', ['', 'pd-hmac-sha256 v1 abc\n', 'hello world\n',
                                  'pd-hmac-sha256 v2 ' + '0' * 64 + '\n'])
def test_a_malformed_key_file_is_refused(tmp_path: Path, text: str) -> None:
    path = tmp_path / 'bad.key'
    path.write_text(text)
    os.chmod(path, 0o600)
    with pytest.raises(KeyFileError, match='not a key file'):
        load_key(path)


def test_a_missing_key_file_says_how_to_make_one(tmp_path: Path) -> None:
    with pytest.raises(KeyFileError, match='keygen'):
        load_key(tmp_path / 'none.key')


# -- MACs ----------------------------------------------------------------------------------------
def test_the_mac_is_hmac_sha256_of_the_canonical_fields() -> None:
    key = new_key()
    signer = Signer(key, session='ab' * 16)
    payload = command_payload(COMMAND)
    signature = signer.sign(payload)
    trailer = canonical('', (key.key_id, signer.session, 1))[5:]  # the fields after the kind
    expected = hmac.new(key.secret, payload + trailer, hashlib.sha256).digest()
    assert signature.mac == expected
    assert (signature.session, signature.sequence) == (signer.session, 1)
    assert signer.sign(payload).sequence == 2
    assert verify_mac(key, payload, signature) is None


@pytest.mark.parametrize('change', [
    {'test_id': 't2'}, {'step': 8}, {'iteration': 0}, {'test_time': 0.0700000001},
    {'dof_names': ('u1', 'u3')}, {'target_displacement': (0.0125, -0.0030000001)},
    {'target_displacement': (0.0125, -0.003, 0.0)},
])
def test_changing_any_command_field_makes_it_a_forgery(change: dict) -> None:
    key = new_key()
    signature = Signer(key).sign(command_payload(COMMAND))
    altered = dataclasses.replace(COMMAND, **change)
    assert verify_mac(key, command_payload(altered), signature) is Refusal.FORGED


@pytest.mark.parametrize('change', [
    {'restoring_force': (0.0, -875.0)}, {'measured_displacement': (0.0124, 0.0)},
    {'status': FeedbackStatus.FAULT}, {'message': 'x'}, {'step': 6},
])
def test_changing_any_feedback_field_makes_it_a_forgery(change: dict) -> None:
    key = new_key()
    signature = Signer(key).sign(feedback_payload(FEEDBACK))
    altered = dataclasses.replace(FEEDBACK, **change)
    assert verify_mac(key, feedback_payload(altered), signature) is Refusal.FORGED


def test_session_sequence_and_key_id_are_authenticated_too() -> None:
    key = new_key()
    payload = command_payload(COMMAND)
    signature = Signer(key).sign(payload)
    for change in ({'session': 'cd' * 16}, {'sequence': 2}):
        assert verify_mac(key, payload, dataclasses.replace(signature, **change)) \
            is Refusal.FORGED
    other = new_key()
    assert verify_mac(other, payload, signature) is Refusal.WRONG_KEY
    forged_id = dataclasses.replace(signature, key_id=other.key_id)
    assert verify_mac(other, payload, forged_id) is Refusal.FORGED
    assert verify_mac(key, payload, Signature()) is Refusal.UNSIGNED


def test_the_canonical_encoding_is_unambiguous() -> None:
    assert canonical('k', ('ab', 'c')) != canonical('k', ('a', 'bc'))
    assert canonical('k', (1,)) != canonical('k', (1.0,))
    assert canonical('k', (0.0,)) != canonical('k', (-0.0,))
    assert canonical('k', (['a'], 'b')) != canonical('k', (['a', 'b'],))
    assert canonical('StepCommand', ()) != canonical('StepFeedback', ())


# -- sessions ------------------------------------------------------------------------------------
def open_session(gate: CommandGate, key: Key) -> Signer:
    signer = Signer(key)
    start = SessionStart(test_id='t1', challenge=gate.challenge)
    assert gate.start(session_start_payload(start), start.challenge,
                      signer.sign(session_start_payload(start))) is None
    return signer


def test_commands_are_admitted_only_in_the_session_a_signed_start_opened() -> None:
    key = new_key()
    gate = CommandGate(key)
    payload = command_payload(COMMAND)
    rogue = Signer(key)  # even a key holder needs a session start first
    assert gate.admit(payload, rogue.sign(payload)) is Refusal.NO_SESSION
    signer = open_session(gate, key)
    first = signer.sign(payload)
    assert gate.admit(payload, first) is None
    assert gate.admit(payload, first) is Refusal.REPLAYED          # the same message again
    assert gate.admit(payload, rogue.sign(payload)) is Refusal.FOREIGN_SESSION
    assert gate.admit(payload, Signature()) is Refusal.UNSIGNED
    assert gate.admit(payload, Signer(new_key()).sign(payload)) is Refusal.WRONG_KEY
    assert gate.admit(command_payload(dataclasses.replace(COMMAND, step=8)),
                      signer.sign(payload)) is Refusal.FORGED
    assert gate.admit(payload, signer.sign(payload)) is None       # the next one is fine
    assert gate.refused == {'no_session': 1, 'replayed': 1, 'foreign_session': 1,
                            'unsigned': 1, 'wrong_key': 1, 'forged': 1}


def test_a_recorded_session_start_cannot_be_replayed() -> None:
    key = new_key()
    gate = CommandGate(key)
    signer = Signer(key)
    start = SessionStart(test_id='t1', challenge=gate.challenge)
    signature = signer.sign(session_start_payload(start))
    assert gate.start(session_start_payload(start), start.challenge, signature) is None
    # The challenge changed with the start: the same start again is refused.
    assert gate.start(session_start_payload(start), start.challenge, signature) \
        is Refusal.REPLAYED
    gate.close()
    assert gate.session is None
    assert gate.start(session_start_payload(start), start.challenge, signature) \
        is Refusal.REPLAYED


def test_replies_must_be_for_the_senders_session_with_increasing_sequence() -> None:
    key = new_key()
    mine, other = Signer(key), Signer(key)
    gate = ReplyGate(key, mine.session)
    payload = feedback_payload(FEEDBACK)
    reply = Signer(key, session=mine.session)
    signature = reply.sign(payload)
    assert gate.admit(payload, signature) is None
    assert gate.admit(payload, signature) is Refusal.REPLAYED
    assert gate.admit(payload, other.sign(payload)) is Refusal.FOREIGN_SESSION
    forged = feedback_payload(dataclasses.replace(FEEDBACK, restoring_force=(0.0, 0.0)))
    assert gate.admit(forged, reply.sign(payload)) is Refusal.FORGED


def test_without_a_key_every_gate_admits_everything() -> None:
    payload = command_payload(COMMAND)
    assert CommandGate(None).admit(payload, Signature()) is None
    assert ReplyGate(None, 's').admit(payload, Signature()) is None
    assert ControlGate(None).admit(payload, Signature(), 0.0) is None


# -- controls ------------------------------------------------------------------------------------
def test_controls_are_fresh_and_obeyed_once() -> None:
    key = new_key()
    now = [1000.0]
    gate = ControlGate(key, window=30.0, clock=lambda: now[0])
    control = Control(command='resume', stamp=now[0])
    signer = Signer(key)
    signature = signer.sign(control_payload(control))
    assert gate.admit(control_payload(control), signature, control.stamp) is None
    assert gate.admit(control_payload(control), signature, control.stamp) is Refusal.REPLAYED
    old = Control(command='abort', stamp=now[0] - 31.0)
    assert gate.admit(control_payload(old), signer.sign(control_payload(old)), old.stamp) \
        is Refusal.STALE
    later = Control(command='abort', stamp=now[0] + 31.0)
    assert gate.admit(control_payload(later), signer.sign(control_payload(later)),
                      later.stamp) is Refusal.STALE
    # A stamp changed after signing is a forgery.
    assert gate.admit(control_payload(dataclasses.replace(control, stamp=now[0] + 1.0)),
                      signer.sign(control_payload(control)), now[0] + 1.0) is Refusal.FORGED
    # Much later, the old session is forgotten but its stamp is stale: still refused.
    now[0] += 100.0
    assert gate.admit(control_payload(control), signature, control.stamp) is Refusal.STALE


def test_the_canonical_bytes_follow_the_documented_tags() -> None:
    # Built from the format the module documents (tag, 64-bit big-endian integers, IEEE-754
    # big-endian floats, 32-bit lengths), not from the encoder: exact types, numpy scalars,
    # bools, str subclasses and mixed sequences all give these bytes.
    class Name(str):  # a str subclass: its characters count, not its str()
        def __str__(self) -> str:
            return 'other'

    def text(value: str) -> bytes:
        data = value.encode('utf-8')
        return b's' + struct.pack('>I', len(data)) + data

    # (a numpy integer inside a sequence is encoded as its float)
    fields = ('é', 7, True, 0.1, -0.0, (1.5, float('nan')), (np.float64(2.5), 3),
              [Name('step'), np.int64(4)], b'\x00\x01', np.float64(-1.25), Name('step'), ())
    expected = b''.join([
        text('K'), text('é'), b'i' + struct.pack('>q', 7), b'b\x01',
        b'f' + struct.pack('>d', 0.1), b'f' + struct.pack('>d', -0.0),
        b'l' + struct.pack('>I', 2) + b'f' + struct.pack('>d', 1.5)
        + b'f' + struct.pack('>d', float('nan')),
        b'l' + struct.pack('>I', 2) + b'f' + struct.pack('>d', 2.5)
        + b'i' + struct.pack('>q', 3),
        b'l' + struct.pack('>I', 2) + text('step') + b'f' + struct.pack('>d', 4.0),
        b'y' + struct.pack('>I', 2) + b'\x00\x01', b'f' + struct.pack('>d', -1.25),
        text('step'), b'l' + struct.pack('>I', 0)])
    assert canonical('K', fields) == expected
    key = new_key()
    trailer = text(key.key_id) + text('ab' * 16) + b'i' + struct.pack('>q', 9)
    assert mac_of(key, expected, 'ab' * 16, 9) == hmac.new(
        key.secret, expected + trailer, hashlib.sha256).digest()
