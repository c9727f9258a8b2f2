"""The genericClient element server's protocol, without ROS and without OpenSees.

Messages are built as ``GenericClient.cpp`` sends them (11 int32, then vectors of dataSize
doubles); a malformed or out-of-order one closes the connection, and a non-loopback bind is
refused without the explicit consent and an allow-list.
"""

from __future__ import annotations

import socket
import struct
import threading
import time

import pytest

from pd_common.opensees import (
    COMMIT,
    END,
    FORCE,
    ElementExchange,
    ElementLink,
    ElementLinkLostError,
    ElementProtocolError,
    check_bind,
    decode_size_message,
    encode_size_message,
    wire,
)

SIZE = decode_size_message(encode_size_message(1))


def trial(d: float, t: float) -> bytes:
    return wire.encode_trial(wire.Trial((d,), (0.0,), (0.0,), t), SIZE)


def test_size_message_of_generic_client() -> None:
    assert (SIZE.n_dof, SIZE.data_size) == (1, 256)
    with pytest.raises(ElementProtocolError, match='not a genericClient'):
        decode_size_message(struct.pack('<11i', 1, 0, 0, 0, 0, 0, 0, 0, 1, 0, 256))
    with pytest.raises(ElementProtocolError, match='44 bytes'):
        decode_size_message(b'\0' * 40)


def test_one_step_force_then_commit() -> None:
    exchange = ElementExchange(SIZE, [[1000.0]])
    assert exchange.take(trial(0.01, 0.01)) == (None, None)
    event, reply = exchange.take(wire.encode_action(wire.GET_TANGENT_STIFF, SIZE))
    assert event is None and reply is not None
    assert struct.unpack('<d', reply[:8])[0] == 1000.0
    event, _ = exchange.take(wire.encode_action(wire.GET_FORCE, SIZE))
    assert event is not None and event.kind == FORCE
    assert struct.unpack('<d', exchange.answer_force([10.0], [0.01])[:8])[0] == 10.0
    event, _ = exchange.take(wire.encode_action(wire.COMMIT_STATE, SIZE))
    assert event is not None and event.kind == COMMIT
    event, _ = exchange.take(wire.encode_action(wire.DIE, SIZE))
    assert event is not None and event.kind == END


@pytest.mark.parametrize(('messages', 'match'), [
    ([wire.encode_action(wire.GET_FORCE, SIZE)], 'no setTrialResponse'),
    ([trial(0.0, 0.01), wire.encode_action(wire.COMMIT_STATE, SIZE)], 'no force measured'),
    ([trial(0.0, 0.01), wire.encode_action(wire.GET_FORCE, SIZE),
      wire.encode_action(wire.GET_FORCE, SIZE)], 'still being answered'),
    ([wire.encode_reply([42.0], SIZE)], 'unknown action code'),
    ([wire.encode_trial(wire.Trial((float('nan'),), (0.0,), (0.0,), 0.0), SIZE)], 'non-finite'),
    ([b'\0' * 16], 'expected 2048 bytes'),
])
def test_malformed_or_out_of_order_is_refused(messages: list[bytes], match: str) -> None:
    exchange = ElementExchange(SIZE, [[1.0]])
    with pytest.raises(ElementProtocolError, match=match):
        for message in messages:
            exchange.take(message)


def test_time_running_backwards_is_refused() -> None:
    exchange = ElementExchange(SIZE, [[1.0]])
    exchange.take(trial(0.0, 0.02))
    exchange.take(wire.encode_action(wire.GET_FORCE, SIZE))
    exchange.answer_force([0.0], [0.0])
    exchange.take(wire.encode_action(wire.COMMIT_STATE, SIZE))
    with pytest.raises(ElementProtocolError, match='before the committed'):
        exchange.take(trial(0.0, 0.01))


def test_bind_policy() -> None:
    assert check_bind('127.0.0.1', [], False) == []
    with pytest.raises(ElementProtocolError, match=r'^host: .*allow_remote'):
        check_bind('0.0.0.0', ['10.0.0.2'], False)
    with pytest.raises(ElementProtocolError, match=r'^allow: '):
        check_bind('0.0.0.0', [], True)
    with pytest.raises(ElementProtocolError, match=r'^allow: not an IP'):
        check_bind('0.0.0.0', ['lab-pc'], True)
    warnings = check_bind('0.0.0.0', ['10.0.0.2'], True)
    assert len(warnings) == 1 and 'no authentication' in warnings[0]
    with pytest.raises(ElementProtocolError, match=r'^host: '):
        ElementLink('0.0.0.0', 0)


def test_a_malformed_message_closes_the_connection() -> None:
    link = ElementLink('127.0.0.1', 0, timeout=5.0)
    client = socket.create_connection(('127.0.0.1', link.port))
    client.sendall(encode_size_message(1))
    accepted = threading.Thread(target=link.accept, args=(lambda n: [[1.0]],))
    accepted.start()
    accepted.join(5)
    assert link.connected
    client.sendall(wire.encode_action(wire.COMMIT_STATE, link.exchange.size))
    with pytest.raises(ElementProtocolError, match='commitState: out of order'):
        link.next_event()
    assert not link.connected
    assert client.recv(1) == b''  # closed by the server, nothing was answered
    client.close()
    link.shutdown()


def test_waiting_for_the_element_calls_idle_until_the_timeout() -> None:
    """While the server waits (a connection, then a message), ``idle`` runs every half second
    (a node's heartbeat) and the timeout still ends the wait."""
    link = ElementLink('127.0.0.1', 0, timeout=1.6)
    calls: list[float] = []
    link.idle = lambda: calls.append(time.monotonic())
    start = time.monotonic()
    with pytest.raises(ElementLinkLostError, match=r'no OpenSees element connected within 1\.6 s'):
        link.accept(lambda n: [[1.0]])
    assert 1.5 <= time.monotonic() - start < 3.0
    assert len(calls) >= 2
    calls.clear()
    client = socket.create_connection(('127.0.0.1', link.port))
    client.sendall(encode_size_message(1))
    link.accept(lambda n: [[1.0]])
    start = time.monotonic()
    with pytest.raises(ElementLinkLostError, match=r'no message within 1\.6 s'):
        link.next_event()
    assert 1.5 <= time.monotonic() - start < 3.0 and len(calls) >= 2
    assert not link.connected
    client.close()
    link.shutdown()
