"""The cost of signing and verifying one step's messages (bench_security and bench_loop).

Step messages are signed as their bytes: signing is encoding the message (empty MAC) and one
HMAC over the bytes, so the sign figures include the encoding; verifying is the HMAC over the
bytes that arrived (their decoding, which the receiver does anyway, not included).
"""

from __future__ import annotations

import time

from pd_common.auth import (
    WIRE_COMMAND,
    WIRE_FEEDBACK,
    Signer,
    command_payload,
    feedback_payload,
    new_key,
    sign_wire_reply,
    verify_mac,
)
from pd_common.protocol import (
    Command,
    Feedback,
    Signature,
    decode_command,
    decode_feedback,
    encode_command,
    encode_feedback,
)

STAMP_NS = 1_796_000_000_123_456_789


def per_call_us(function: object, count: int) -> float:
    """Mean time of ``function()`` over ``count`` calls, µs (after 500 warm-up calls)."""
    assert callable(function)
    for _ in range(500):
        function()
    start = time.perf_counter()
    for _ in range(count):
        function()
    return (time.perf_counter() - start) / count * 1e6


def message_costs(count: int) -> dict[str, float]:
    """Sign and verify times of one command and one feedback, µs."""
    key = new_key()
    signer = Signer(key)
    command = Command(test_id='thesis-5.1-elcentro', step=1234, test_time=12.34,
                      dof_names=('top',), target_displacement=(0.0123456789,))
    feedback = Feedback(test_id=command.test_id, step=1234,
                        measured_displacement=(0.0123456789,), restoring_force=(-3859.05,),
                        epoch='0123456789abcdef')
    def sign_command() -> tuple[bytes, Signature]:
        return signer.sign_wire(WIRE_COMMAND,
                                lambda bare: encode_command(command, STAMP_NS, bare))

    command_bytes, command_signature = sign_command()

    def sign_feedback() -> tuple[bytes, Signature]:
        return sign_wire_reply(key, WIRE_FEEDBACK,
                               lambda bare: encode_feedback(feedback, STAMP_NS, bare),
                               command_signature)

    sent_command = decode_command(command_bytes)
    sent_feedback = decode_feedback(sign_feedback()[0])
    return {
        'auth_sign_command_us': per_call_us(sign_command, count),
        'auth_verify_command_us': per_call_us(
            lambda: verify_mac(key, command_payload(sent_command.covered),
                               sent_command.signature), count),
        'auth_sign_feedback_us': per_call_us(sign_feedback, count),
        'auth_verify_feedback_us': per_call_us(
            lambda: verify_mac(key, feedback_payload(sent_feedback.covered),
                               sent_feedback.signature), count),
    }
