"""The graph's step work in one process: both sides of the wire, without DDS (bench_loop).

Per step, what the integrator and a simulator do between receiving and publishing, with the
same pieces their nodes use: the integrator's session and dispatcher, its command encoded and
signed as it is published (a session's :class:`~pd_common.auth.Signer`), the bytes decoded,
admitted (:class:`~pd_common.auth.CommandGate`), served by the site's specimen and answered
signed as a reply; the reply decoded, admitted (:class:`~pd_common.auth.ReplyGate`) and given
to the dispatcher, which journals the bytes that travelled. Each message is encoded once, as
in the graph (the offline loop encodes its journal's messages, and a separate figure of
signing encodes them again).
"""

from __future__ import annotations

import time
from collections import deque
from pathlib import Path
from typing import Any

from pd_common.auth import (
    WIRE_COMMAND,
    WIRE_FEEDBACK,
    CommandGate,
    Key,
    ReplyGate,
    Signer,
    command_payload,
    feedback_payload,
    new_key,
    session_start_payload,
    sign_wire_reply,
)
from pd_common.protocol import (
    Command,
    SessionStart,
    decode_command,
    decode_feedback,
    encode_command,
    encode_feedback,
)
from pd_core.run.loop.dispatch import Sent, StepDispatcher
from pd_core.run.loop.session import TestSession
from pd_core.run.record.journal import Journal
from pd_core.run.runner import site_servers


def opened_gate(key: Key, signer: Signer, test_id: str) -> CommandGate:
    """A receiver's command gate with its session opened by ``signer``'s signed start."""
    gate = CommandGate(key)
    start = SessionStart(test_id=test_id, challenge=gate.challenge)
    refused = gate.start(session_start_payload(start), gate.challenge,
                         signer.sign(session_start_payload(start)))
    assert refused is None, refused
    return gate


def wire_loop(definition: Any, journal: Path) -> tuple[float, int]:
    """One run of the test through both sides' step work: seconds, committed steps."""
    key = new_key()
    servers = site_servers(definition)
    signer = Signer(key)
    # each receiver's session, opened by the sender's signed start
    gates = {site: opened_gate(key, signer, definition.test_id) for site in servers}
    replies = ReplyGate(key, signer.session)
    session = TestSession(definition)
    queue: deque[tuple[str, bytes]] = deque()

    def send(site: str, command: Command) -> Sent:
        stamp = dispatcher.send_stamp_ns
        data, signature = signer.sign_wire(
            WIRE_COMMAND, lambda bare: encode_command(command, stamp, bare))
        queue.append((site, data))
        return Sent(signature, data)

    start_time = time.perf_counter()
    with Journal(journal) as bag:
        dispatcher = StepDispatcher(session, send, bag)
        bag.write_definition(definition.to_json(), time.time_ns())
        dispatcher.start()
        while queue:
            site, data = queue.popleft()
            sent = decode_command(data)  # the simulator
            assert gates[site].admit(command_payload(sent.covered), sent.signature) is None
            command = sent.record
            answer = servers[site].handle(command.test_id, command.step,
                                          command.target_displacement,
                                          iteration=command.iteration,
                                          control_mode=command.control_mode,
                                          target_force=command.target_force)
            assert answer is not None
            stamp = time.time_ns()
            reply, _ = sign_wire_reply(key, WIRE_FEEDBACK,
                                       lambda bare, a=answer, s=stamp: encode_feedback(a, s, bare),
                                       sent.signature)
            arrived = decode_feedback(reply)  # the integrator
            assert replies.admit(feedback_payload(arrived.covered), arrived.signature) is None
            dispatcher.on_feedback(site, arrived.record, arrived.signature, arrived.stamp_ns,
                                   reply)
    return time.perf_counter() - start_time, session.committed_step
