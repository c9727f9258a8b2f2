"""The cost of turning one step's messages into bytes and back: the CDR codec against rclpy.

    python bench/bench_codec.py [--quick]

Figures (printed, and merged into ``bench/results.json`` under the names in brackets), each the
mean over 50,000 calls (10,000 with ``--quick``) after 500 warm-up calls, for one signed SDOF
``StepCommand`` and one signed ``StepFeedback`` (the messages of ``bench_security``):

* the codec of :mod:`pd_common.protocol.cdr`: record, stamp and signature to CDR bytes
  [``codec_command_encode_us``, ``codec_feedback_encode_us``] and back
  [``codec_command_decode_us``, ``codec_feedback_decode_us``];
* what the nodes do today with rclpy: the record to a ``pd_msgs`` message object
  (:mod:`pd_common.ros.messages`) [``rclpy_command_to_message_us``,
  ``rclpy_feedback_to_message_us``]; that and ``serialize_message``, the same bytes as the
  codec's encode [``rclpy_command_serialize_us``, ``rclpy_feedback_serialize_us``];
  ``deserialize_message`` and the conversion to the record and signature, what the codec's
  decode gives [``rclpy_command_deserialize_us``, ``rclpy_feedback_deserialize_us``].

A measurement, not a test: it asserts nothing. It uses no ROS graph (no node, no DDS).
"""

from __future__ import annotations

import argparse
import os
import sys

from _message_costs import per_call_us
from _results import RESULTS, merge_results
from pd_common.auth import WIRE_COMMAND, WIRE_FEEDBACK, Signer, new_key, sign_wire_reply
from pd_common.protocol import (
    Command,
    Feedback,
    Signature,
    command_from_message,
    decode_command,
    decode_feedback,
    encode_command,
    encode_feedback,
    feedback_from_message,
    signature_from_message,
    stamp_ns_of,
)

STAMP_NS = 1_767_225_600_123_456_789


def messages() -> tuple[Command, Feedback, Signature, Signature]:
    """One SDOF command and its feedback, and their signatures (as bench_security's)."""
    key = new_key()
    command = Command(test_id='thesis-5.1-elcentro', step=1234, test_time=12.34,
                      dof_names=('top',), target_displacement=(0.0123456789,))
    feedback = Feedback(test_id=command.test_id, step=1234,
                        measured_displacement=(0.0123456789,), restoring_force=(-3859.05,),
                        epoch='0123456789abcdef')
    _, command_signature = Signer(key).sign_wire(
        WIRE_COMMAND, lambda bare: encode_command(command, STAMP_NS, bare))
    _, feedback_signature = sign_wire_reply(
        key, WIRE_FEEDBACK, lambda bare: encode_feedback(feedback, STAMP_NS, bare),
        command_signature)
    return command, feedback, command_signature, feedback_signature


def codec_costs(count: int) -> dict[str, float]:
    """The codec's encode and decode times of one command and one feedback, µs."""
    command, feedback, command_signature, feedback_signature = messages()
    command_bytes = encode_command(command, STAMP_NS, command_signature)
    feedback_bytes = encode_feedback(feedback, STAMP_NS, feedback_signature)
    return {
        'codec_command_encode_us': per_call_us(
            lambda: encode_command(command, STAMP_NS, command_signature), count),
        'codec_command_decode_us': per_call_us(lambda: decode_command(command_bytes), count),
        'codec_feedback_encode_us': per_call_us(
            lambda: encode_feedback(feedback, STAMP_NS, feedback_signature), count),
        'codec_feedback_decode_us': per_call_us(lambda: decode_feedback(feedback_bytes), count),
    }


def rclpy_costs(count: int) -> dict[str, float]:
    """The same through rclpy message objects, µs (the path the nodes take today)."""
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    os.environ.setdefault('ROS_DOMAIN_ID', '217')
    from rclpy.serialization import deserialize_message, serialize_message

    from pd_common.ros.messages import command_message, feedback_message, stamp_from_ns
    from pd_msgs.msg import StepCommand, StepFeedback

    command, feedback, command_signature, feedback_signature = messages()
    stamp = stamp_from_ns(STAMP_NS)
    command_bytes = serialize_message(command_message(command, stamp,
                                                      signature=command_signature))
    feedback_bytes = serialize_message(feedback_message(feedback, stamp,
                                                        signature=feedback_signature))

    def read_command() -> object:
        message = deserialize_message(command_bytes, StepCommand)
        return (command_from_message(message), stamp_ns_of(message),
                signature_from_message(message.signature))

    def read_feedback() -> object:
        message = deserialize_message(feedback_bytes, StepFeedback)
        return (feedback_from_message(message), stamp_ns_of(message),
                signature_from_message(message.signature))

    return {
        'rclpy_command_to_message_us': per_call_us(
            lambda: command_message(command, stamp, signature=command_signature), count),
        'rclpy_command_serialize_us': per_call_us(
            lambda: serialize_message(command_message(command, stamp,
                                                      signature=command_signature)), count),
        'rclpy_command_deserialize_us': per_call_us(read_command, count),
        'rclpy_feedback_to_message_us': per_call_us(
            lambda: feedback_message(feedback, stamp, signature=feedback_signature), count),
        'rclpy_feedback_serialize_us': per_call_us(
            lambda: serialize_message(feedback_message(feedback, stamp,
                                                       signature=feedback_signature)), count),
        'rclpy_feedback_deserialize_us': per_call_us(read_feedback, count),
    }


def main(argv: list[str] | None = None) -> int:
    """Entry point."""
    parser = argparse.ArgumentParser(prog='bench_codec', description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='fewer calls')
    parser.add_argument('--no-save', action='store_true', help='print only')
    # ./pd bench passes its options to every bench script: the others' are not ours
    args, _ = parser.parse_known_args(argv)
    count = 10_000 if args.quick else 50_000
    figures = {**codec_costs(count), **rclpy_costs(count)}
    print('one signed SDOF step message, record <-> CDR bytes (mean per call):')
    for name, value in figures.items():
        print(f'  {name:<32} {value:8.2f} us')
    for kind in ('command', 'feedback'):
        encode = figures[f'rclpy_{kind}_serialize_us'] / figures[f'codec_{kind}_encode_us']
        decode = figures[f'rclpy_{kind}_deserialize_us'] / figures[f'codec_{kind}_decode_us']
        print(f'  {kind}: the codec encodes {encode:.1f}x and decodes {decode:.1f}x as fast as '
              'rclpy')
    if not args.no_save:
        merge_results(figures)
        print(f'  written to {RESULTS}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
