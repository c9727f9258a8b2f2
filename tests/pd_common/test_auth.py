"""Message authentication: key files, MACs over every field, sessions, replays, controls."""

from __future__ import annotations

import dataclasses
import hashlib
import hmac
import os
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pd_common.auth import (
    WIRE_COMMAND,
    WIRE_FEEDBACK,
    CommandGate,
    ControlGate,
    Key,
    KeyFileError,
    Refusal,
    ReplyGate,
    Signer,
    StatusGate,
    WatchGate,
    WirePayload,
    canonical,
    command_payload,
    control_payload,
    feedback_payload,
    generate_key,
    load_key,
    mac_of,
    new_key,
    offer_payload,
    session_start_payload,
    sign_wire_reply,
    status_payload,
    verify_mac,
    wire_mac,
)
from pd_common.protocol import (
    Command,
    Control,
    Decoded,
    Feedback,
    FeedbackStatus,
    Offer,
    SessionStart,
    Signature,
    Status,
    covered_part,
    decode_command,
    decode_feedback,
    encode_command,
    encode_feedback,
    signed_from_bytes,
)
from pd_common.protocol import TestState as State

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
def sent_command(signer: Signer, command: Command = COMMAND, stamp_ns: int = 5
                 ) -> Decoded[Command]:
    """``command`` as the integrator sends it (signed as its bytes), as a receiver reads it."""
    data, _ = signer.sign_wire(WIRE_COMMAND,
                               lambda signature: encode_command(command, stamp_ns, signature))
    return decode_command(data)


def sent_reply(key: Key, request: Signature, feedback: Feedback = FEEDBACK, stamp_ns: int = 6
               ) -> Decoded[Feedback]:
    """``feedback`` as a receiver answers ``request``, as the sender reads it."""
    data, _ = sign_wire_reply(key, WIRE_FEEDBACK,
                              lambda signature: encode_feedback(feedback, stamp_ns, signature),
                              request)
    return decode_feedback(data)


def covered_with(decoded: Decoded[Any], record: Any) -> bytes:
    """The bytes a MAC covers of ``record`` sent with ``decoded``'s stamp and signature."""
    encode = encode_command if isinstance(record, Command) else encode_feedback
    bare = dataclasses.replace(decoded.signature, mac=b'')
    return covered_part(encode(record, decoded.stamp_ns, bare))


def test_a_step_message_mac_is_hmac_sha256_of_its_bytes() -> None:
    key = new_key()
    signer = Signer(key, session='ab' * 16)
    data, signature = signer.sign_wire(
        WIRE_COMMAND, lambda bare: encode_command(COMMAND, 5, bare))
    decoded = decode_command(data)
    assert decoded.signature == signature
    assert (signature.key_id, signature.session, signature.sequence) == (
        key.key_id, signer.session, 1)
    # the tag of the type, then the bytes through the sequence: the MAC's count and the MAC
    # close them
    assert data == decoded.covered + struct.pack('<I', 32) + signature.mac
    assert decoded.covered.endswith(struct.pack('<Q', 1))
    tag = b'pd-wire\x00pd_msgs/msg/StepCommand\x00'
    assert signature.mac == hmac.new(key.secret, tag + decoded.covered, hashlib.sha256).digest()
    assert verify_mac(key, command_payload(decoded.covered), signature) is None
    assert sent_command(signer).signature.sequence == 2
    # the same bytes under the other type's tag do not pass
    assert verify_mac(key, feedback_payload(decoded.covered), signature) is Refusal.FORGED


@pytest.mark.parametrize('length', [0, 1, 31, 32, 63, 64, 65, 131])
def test_the_wire_mac_is_the_hmac_modules_for_keys_of_any_length(length: int) -> None:
    # (HMAC is spelled out over hashlib's SHA-256 for speed; Python's hmac, OpenSSL's HMAC,
    # is the reference: short keys padded, keys longer than a block hashed first)
    secret = bytes((7 * index + 3) % 256 for index in range(length))
    key = Key(key_id='k' * 16, secret=secret)
    for kind in (WIRE_COMMAND, WIRE_FEEDBACK):
        for covered in (b'', b'\x00' * 55, bytes(range(256)) * 3):
            tag = b'pd-wire\x00' + kind.encode('ascii') + b'\x00'
            assert wire_mac(key, WirePayload(kind, covered)) == hmac.new(
                secret, tag + covered, hashlib.sha256).digest()


def test_the_mac_of_a_control_is_hmac_sha256_of_the_canonical_fields() -> None:
    key = new_key()
    signer = Signer(key, session='ab' * 16)
    payload = control_payload(Control(command='pause', stamp=1.5))
    signature = signer.sign(payload)
    trailer = canonical('', (key.key_id, signer.session, 1))[5:]  # the fields after the kind
    expected = hmac.new(key.secret, payload + trailer, hashlib.sha256).digest()
    assert signature.mac == expected
    assert signer.sign(payload).sequence == 2
    assert verify_mac(key, payload, signature) is None


@pytest.mark.parametrize('change', [
    {'test_id': 't2'}, {'step': 8}, {'iteration': 0}, {'test_time': 0.0700000001},
    {'dof_names': ('u1', 'u3')}, {'target_displacement': (0.0125, -0.0030000001)},
    {'target_displacement': (0.0125, -0.003, 0.0)},
])
def test_changing_any_command_field_makes_it_a_forgery(change: dict) -> None:
    key = new_key()
    sent = sent_command(Signer(key))
    altered = dataclasses.replace(COMMAND, **change)
    assert verify_mac(key, command_payload(covered_with(sent, altered)),
                      sent.signature) is Refusal.FORGED


@pytest.mark.parametrize('change', [
    {'restoring_force': (0.0, -875.0)}, {'measured_displacement': (0.0124, 0.0)},
    {'status': FeedbackStatus.FAULT}, {'message': 'x'}, {'step': 6},
])
def test_changing_any_feedback_field_makes_it_a_forgery(change: dict) -> None:
    key = new_key()
    sent = sent_reply(key, sent_command(Signer(key)).signature)
    altered = dataclasses.replace(FEEDBACK, **change)
    assert verify_mac(key, feedback_payload(covered_with(sent, altered)),
                      sent.signature) is Refusal.FORGED


def test_stamp_session_sequence_and_key_id_are_authenticated_too() -> None:
    key = new_key()
    sent = sent_command(Signer(key))
    assert verify_mac(key, command_payload(sent.covered), sent.signature) is None
    bare = dataclasses.replace(sent.signature, mac=b'')
    for stamp_ns, signature in ((sent.stamp_ns + 1, bare),
                                (sent.stamp_ns, dataclasses.replace(bare, session='cd' * 16)),
                                (sent.stamp_ns, dataclasses.replace(bare, sequence=2))):
        covered = covered_part(encode_command(COMMAND, stamp_ns, signature))
        # (the receiver reads the session and sequence from the bytes it checks)
        claimed = dataclasses.replace(signature, mac=sent.signature.mac)
        assert verify_mac(key, command_payload(covered), claimed) is Refusal.FORGED
    other = new_key()
    assert verify_mac(other, command_payload(sent.covered), sent.signature) \
        is Refusal.WRONG_KEY
    forged_id = dataclasses.replace(bare, key_id=other.key_id)
    covered = covered_part(encode_command(COMMAND, sent.stamp_ns, forged_id))
    assert verify_mac(other, command_payload(covered),
                      dataclasses.replace(forged_id, mac=sent.signature.mac)) is Refusal.FORGED
    assert verify_mac(key, command_payload(sent.covered), Signature()) is Refusal.UNSIGNED


@pytest.mark.parametrize('kind', ['command', 'feedback', 'mixed command'])
def test_every_byte_flipped_of_a_signed_step_message_is_refused(kind: str) -> None:
    """Each byte of the bytes that travel, flipped (each bit, and all bits): the message no
    longer decodes (refused as malformed) or its MAC fails. Nothing passes."""
    key = new_key()
    signer = Signer(key)
    gate = CommandGate(key)
    request = open_session(gate, key)
    if kind == 'feedback':
        data, _ = sign_wire_reply(key, WIRE_FEEDBACK,
                                  lambda bare: encode_feedback(FEEDBACK, 6, bare),
                                  sent_command(signer).signature)
        decode: Any = decode_feedback
        payload: Any = feedback_payload
    else:
        command = COMMAND if kind == 'command' else dataclasses.replace(
            COMMAND, control_mode=(0, 1), target_force=(0.0, 2.5e4))
        data, _ = request.sign_wire(WIRE_COMMAND,
                                    lambda bare: encode_command(command, 5, bare))
        decode, payload = decode_command, command_payload
    genuine = decode(data)
    assert verify_mac(key, payload(genuine.covered), genuine.signature) is None
    passed = []
    for index in range(len(data)):
        for mask in (0x01, 0x02, 0x04, 0x08, 0x10, 0x20, 0x40, 0x80, 0xff):
            damaged = bytearray(data)
            damaged[index] ^= mask
            read = signed_from_bytes(decode, bytes(damaged))
            if read is not None and verify_mac(key, payload(read.covered),
                                               read.signature) is None:
                passed.append((index, mask))
    assert passed == []
    if kind != 'feedback':  # and the gate still takes the genuine one (none was admitted)
        assert gate.admit(payload(genuine.covered), genuine.signature) is None


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


def admit(gate: CommandGate, sent: Decoded[Command]) -> Refusal | None:
    return gate.admit(command_payload(sent.covered), sent.signature)


def test_commands_are_admitted_only_in_the_session_a_signed_start_opened() -> None:
    key = new_key()
    gate = CommandGate(key)
    rogue = Signer(key)  # even a key holder needs a session start first
    assert admit(gate, sent_command(rogue)) is Refusal.NO_SESSION
    signer = open_session(gate, key)
    first = sent_command(signer)
    assert admit(gate, first) is None
    assert admit(gate, first) is Refusal.REPLAYED          # the same message again
    assert admit(gate, sent_command(rogue)) is Refusal.FOREIGN_SESSION
    assert gate.admit(command_payload(first.covered), Signature()) is Refusal.UNSIGNED
    assert admit(gate, sent_command(Signer(new_key()))) is Refusal.WRONG_KEY
    nxt = sent_command(signer)
    assert gate.admit(command_payload(covered_with(nxt, dataclasses.replace(COMMAND, step=8))),
                      nxt.signature) is Refusal.FORGED
    assert admit(gate, sent_command(signer)) is None       # the next one is fine
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

    def admit_reply(reply: Decoded[Feedback]) -> Refusal | None:
        return gate.admit(feedback_payload(reply.covered), reply.signature)

    first = sent_reply(key, sent_command(mine).signature)
    assert admit_reply(first) is None
    assert admit_reply(first) is Refusal.REPLAYED
    assert admit_reply(sent_reply(key, sent_command(other).signature)) \
        is Refusal.FOREIGN_SESSION
    nxt = sent_reply(key, sent_command(mine).signature)
    forged = covered_with(nxt, dataclasses.replace(FEEDBACK, restoring_force=(0.0, 0.0)))
    assert gate.admit(feedback_payload(forged), nxt.signature) is Refusal.FORGED
    assert admit_reply(nxt) is None
    # A bridge that holds answers its last command again, as a fault: another message for the
    # same request, new (an emergency stop is no replay); either answer again is a replay, and
    # so is the earlier request's.
    fault = sent_reply(key, nxt.signature, dataclasses.replace(
        FEEDBACK, status=FeedbackStatus.FAULT, message='emergency stop'))
    assert fault.signature.sequence == nxt.signature.sequence
    assert admit_reply(fault) is None
    assert admit_reply(fault) is Refusal.REPLAYED
    assert admit_reply(nxt) is Refusal.REPLAYED
    assert admit_reply(sent_reply(key, first.signature, fault.record)) is Refusal.REPLAYED
    assert gate.refused == {'replayed': 4, 'foreign_session': 1, 'forged': 1}


def test_an_observer_shows_only_the_hops_messages_in_the_receivers_session() -> None:
    """The console's gate: a forged, unsigned, foreign or replayed step message is not shown.

    Commands and their replies are admitted in the session the receiver's genuine offer names,
    each kind's sequence increasing; a new session (a restarted integrator) starts afresh.
    """
    key = new_key()
    integrator, rogue = Signer(key), Signer(key)
    gate = WatchGate(key)

    def watch(sent: Decoded[Any]) -> Refusal | None:
        payload = (command_payload if isinstance(sent.record, Command) else feedback_payload)
        return gate.admit(payload(sent.covered), sent.signature)

    command = sent_command(integrator)
    assert watch(command) is Refusal.NO_SESSION           # no offer heard yet
    gate.follow(integrator.session)
    reply = sent_reply(key, command.signature)
    assert watch(command) is None and watch(reply) is None  # a command, then its reply
    assert watch(command) is Refusal.REPLAYED and watch(reply) is Refusal.REPLAYED
    assert watch(sent_command(rogue)) is Refusal.FOREIGN_SESSION
    assert watch(sent_command(Signer(new_key()))) is Refusal.WRONG_KEY
    assert gate.admit(command_payload(command.covered), Signature()) is Refusal.UNSIGNED
    nxt = sent_command(integrator)
    assert gate.admit(command_payload(covered_with(nxt, dataclasses.replace(COMMAND, step=9))),
                      nxt.signature) is Refusal.FORGED
    forged = sent_reply(key, nxt.signature)
    assert gate.admit(feedback_payload(covered_with(forged, dataclasses.replace(
        FEEDBACK, restoring_force=(0.0, 0.0)))), forged.signature) is Refusal.FORGED
    ok = sent_reply(key, nxt.signature)
    assert watch(nxt) is None and watch(ok) is None
    # A bridge's hold answers the last command again, as a fault (the same sequence, another
    # message): shown once; either answer again is a replay.
    fault = sent_reply(key, nxt.signature, dataclasses.replace(
        FEEDBACK, status=FeedbackStatus.FAULT, message='emergency stop'))
    assert watch(fault) is None
    assert watch(fault) is Refusal.REPLAYED and watch(ok) is Refusal.REPLAYED
    # The receiver restarts: its offer names none, then the same session again (reopened);
    # what was shown before is still a replay.
    gate.follow('')
    assert watch(sent_command(integrator)) is Refusal.NO_SESSION
    gate.follow(integrator.session)
    assert watch(nxt) is Refusal.REPLAYED and watch(reply) is Refusal.REPLAYED
    # The receiver obeys a new session: the old one's messages are foreign, the new one's shown.
    restarted = Signer(key)
    gate.follow(restarted.session)
    assert watch(sent_command(integrator)) is Refusal.FOREIGN_SESSION
    assert watch(sent_command(restarted)) is None
    gate.follow('')                                        # none obeyed: nothing shown
    assert watch(sent_command(restarted)) is Refusal.NO_SESSION
    assert gate.refused == {'no_session': 3, 'replayed': 6, 'foreign_session': 2,
                            'wrong_key': 1, 'unsigned': 1, 'forged': 2}
    open_gate = WatchGate(None)                            # authentication off: all shown
    assert open_gate.admit(command_payload(command.covered), Signature()) is None


def test_without_a_key_every_gate_admits_everything() -> None:
    payload = command_payload(encode_command(COMMAND, 5))
    assert CommandGate(None).admit(payload, Signature()) is None
    assert ReplyGate(None, 's').admit(payload, Signature()) is None
    assert ControlGate(None).admit(Control(command='abort'), Signature(), 'any') is None
    assert StatusGate(None).admit('/pd/test_status', b'', Signature(), 0) is None


@pytest.mark.parametrize('key_id', ['é' * 16, '\u0000\u00ff', 'ключ', '\udcff'])
def test_a_key_id_that_is_no_key_id_is_another_key_at_every_gate(key_id: str) -> None:
    """Not ASCII: ``hmac.compare_digest`` raises on such a str; every gate refuses it as the
    wrong key (a rogue's one message with such a key id stopped the node reading it)."""
    key = new_key()
    signature = Signature(key_id=key_id, session='s' * 32, sequence=2, mac=b'\x00' * 32)
    payload = command_payload(encode_command(COMMAND, 5))
    assert verify_mac(key, payload, signature) is Refusal.WRONG_KEY
    assert verify_mac(key, b'canonical', signature) is Refusal.WRONG_KEY
    gate = CommandGate(key)
    assert gate.admit(payload, signature) is Refusal.WRONG_KEY
    assert ReplyGate(key, 's' * 32).admit(payload, signature) is Refusal.WRONG_KEY
    assert ControlGate(key).admit(Control(command='abort'), signature, 'any') is Refusal.WRONG_KEY
    assert StatusGate(key).admit('/pd/test_status', b'', signature, 0) is Refusal.WRONG_KEY
    watch = WatchGate(key)
    watch.follow('s' * 32)
    assert watch.admit(payload, signature) is Refusal.WRONG_KEY


# -- controls ------------------------------------------------------------------------------------
NODE = '/pd/lab1/pd_actuator_bridge'
INSTANCE = 'a1' * 16


def bound(command: str, stamp: float, **fields: str) -> Control:
    """A control bound to the receiver of these tests (overridable per field)."""
    binding = {'target': NODE, 'session': INSTANCE, 'test_id': 'T', **fields}
    return Control(command=command, stamp=stamp, sender='operator a@b (test)', **binding)


def test_controls_are_fresh_and_obeyed_once() -> None:
    key = new_key()
    now = [1000.0]
    gate = ControlGate(key, NODE, INSTANCE, window=30.0, clock=lambda: now[0])
    control = bound('resume', now[0])
    signer = Signer(key)
    signature = signer.sign(control_payload(control))
    assert gate.admit(control, signature, 'T') is None
    assert gate.admit(control, signature, 'T') is Refusal.REPLAYED
    old = bound('abort', now[0] - 31.0)
    assert gate.admit(old, signer.sign(control_payload(old)), 'T') is Refusal.STALE
    later = bound('abort', now[0] + 31.0)
    assert gate.admit(later, signer.sign(control_payload(later)), 'T') is Refusal.STALE
    # A stamp (or a sender, a reason) changed after signing is a forgery.
    for changed in (dataclasses.replace(control, stamp=now[0] + 1.0),
                    dataclasses.replace(control, sender='run_test'),
                    dataclasses.replace(control, reason='other')):
        assert gate.admit(changed, signer.sign(control_payload(control)), 'T') \
            is Refusal.FORGED
    # Much later the copy is still refused (stale, and replayed).
    now[0] += 100.0
    assert gate.admit(control, signature, 'T') is not None


def test_a_control_is_bound_to_its_node_its_instance_and_its_test() -> None:
    key = new_key()
    gate = ControlGate(key, NODE, INSTANCE, clock=lambda: 1000.0)
    signer = Signer(key)

    def admit(control: Control, test_id: str = 'T') -> Refusal | None:
        return gate.admit(control, signer.sign(control_payload(control)), test_id)

    # meant for site lab3's bridge, republished to lab1's: refused
    assert admit(bound('reset_emergency_stop', 1000.0,
                       target='/pd/lab3/pd_actuator_bridge')) is Refusal.MISDIRECTED
    # meant for an earlier process of this node (it restarted since): refused
    assert admit(bound('reset', 1000.0, session='b2' * 16)) is Refusal.FOREIGN_SESSION
    # meant for test A, the node serves test B now: refused
    assert admit(bound('resume', 1000.0, test_id='A'), test_id='B') is Refusal.FOREIGN_TEST
    # unbound (an old-style control): refused
    assert admit(Control(command='resume', stamp=1000.0)) is Refusal.MISDIRECTED
    assert admit(bound('resume', 1000.0)) is None
    assert dict(gate.refused) == {'misdirected': 2, 'foreign_session': 1, 'foreign_test': 1}


def test_the_replay_memory_is_seeded_from_the_record() -> None:
    key = new_key()
    signer = Signer(key)
    control = bound('reset', 1000.0)
    signature = signer.sign(control_payload(control))
    restarted = ControlGate(key, NODE, INSTANCE, clock=lambda: 1000.0)
    restarted.remember(signature.session, signature.sequence)
    assert restarted.admit(control, signature, 'T') is Refusal.REPLAYED
    later = bound('reset', 1000.0)
    assert restarted.admit(later, signer.sign(control_payload(later)), 'T') is None


def test_statements_are_signed_by_their_node_and_never_older_than_the_last() -> None:
    key = new_key()
    gate = StatusGate(key)
    status = Status(test_id='T', state=State.RUNNING, step=3, total_steps=9,
                    omega_dt=0.1, node=NODE, session=INSTANCE)
    first, second = Signer(key), Signer(key)  # two processes of the node
    topic = '/pd/lab1/bridge/status'

    def admit(signer: Signer, stamp: int, item: Status = status) -> Refusal | None:
        return gate.admit(topic, status_payload(item, stamp),
                          signer.sign(status_payload(status, stamp)), stamp)

    assert gate.admit(topic, status_payload(status, 5), Signature(), 5) is Refusal.UNSIGNED
    assert admit(Signer(new_key()), 5) is Refusal.WRONG_KEY
    assert admit(first, 5, dataclasses.replace(status, state=State.HOLDING)) \
        is Refusal.FORGED
    assert admit(first, 10) is None
    payload, signature = status_payload(status, 10), first.sign(status_payload(status, 10))
    assert gate.admit(topic, payload, signature, 10) is None
    assert gate.admit(topic, payload, signature, 10) is Refusal.REPLAYED  # the same again
    assert admit(second, 20) is None  # a restarted node: a newer session
    assert admit(first, 15) is Refusal.REPLAYED  # the earlier process's word: older
    # the offer's stamp is signed too
    offer = Offer(stamp_ns=30, node=NODE, challenge='c', active_session='', authenticated=True,
                  epoch='e', state_origin=0, restored=('', 0, 0), position=(0.0,),
                  force=(0.0,), configuration='{}')
    signature = second.sign(offer_payload(offer))
    assert gate.admit('/offer', offer_payload(dataclasses.replace(offer, position=(0.5,))),
                      signature, 30) is Refusal.FORGED
    assert gate.admit('/offer', offer_payload(offer), signature, 30) is None


def test_a_made_up_key_is_refused(tmp_path: Path) -> None:
    path = tmp_path / 'zero.key'
    path.write_text('pd-hmac-sha256 v1 ' + '00' * 32 + '\n', encoding='ascii')
    path.chmod(0o600)
    with pytest.raises(KeyFileError, match=r'zero\.key: a key must be random'):
        load_key(path)
    path.write_text('pd-hmac-sha256 v1 ' + '0102' * 16 + '\n', encoding='ascii')
    with pytest.raises(KeyFileError, match=r'2 distinct byte values'):
        load_key(path)


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
