"""The cost of signing and verifying one step's messages (bench_security and bench_loop)."""

from __future__ import annotations

import time

from pd_common.auth import (
    Signer,
    command_payload,
    feedback_payload,
    new_key,
    sign_reply,
    verify_mac,
)
from pd_common.protocol import Command, Feedback


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
    command_signature = signer.sign(command_payload(command))
    feedback_signature = sign_reply(key, feedback_payload(feedback), command_signature)
    return {
        'auth_sign_command_us': per_call_us(
            lambda: signer.sign(command_payload(command)), count),
        'auth_verify_command_us': per_call_us(
            lambda: verify_mac(key, command_payload(command), command_signature), count),
        'auth_sign_feedback_us': per_call_us(
            lambda: sign_reply(key, feedback_payload(feedback), command_signature), count),
        'auth_verify_feedback_us': per_call_us(
            lambda: verify_mac(key, feedback_payload(feedback), feedback_signature), count),
    }
