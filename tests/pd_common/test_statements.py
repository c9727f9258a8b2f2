"""A node's status is believed only on its own status topic (pd_common.ros.statements).

A genuine, signed status copied onto another node's status topic — one bridge's "holding"
onto another's, confirming an emergency stop that bridge never heard — is refused
(``misdirected``), before the gate remembers anything of it.
"""

from __future__ import annotations

import pytest

from pd_common.auth import Refusal, Signer, StatusGate, new_key
from pd_common.protocol import Offer, StateOrigin, Status, parse_acknowledgement
from pd_common.protocol import TestState as State  # (not a test class)
from pd_common.ros.messages import offer_message, status_message
from pd_common.ros.statements import at_home, read_offer, read_status


def holding(node: str, signer: Signer | None) -> object:
    return status_message(Status(test_id='t', state=State.HOLDING, step=3, total_steps=9,
                                 omega_dt=0.1, node=node, session='s' * 32,
                                 emergency_stop=True), signer=signer)


@pytest.mark.parametrize(('source', 'node', 'home'), [
    ('/pd/test_status', '/pd/pd_integrator', True),
    ('/pd/bridge/status', '/pd/pd_actuator_bridge', True),
    ('/pd/lab1/bridge/status', '/pd/lab1/pd_actuator_bridge', True),
    ('/pd/lab3/bridge/status', '/pd/lab1/pd_actuator_bridge', False),   # another site's
    ('/pd/bridge/status', '/pd/lab1/pd_actuator_bridge', False),
    ('/pd/lab1/bridge/status', '/pd/pd_actuator_bridge', False),
    ('/pd/lab1/specimen/bridge/status', '/pd/lab1/pd_actuator_bridge', False),
    ('/pd/test_status', '', False),                                      # names no node
    ('/pd/session/offer', '/pd/pd_simulator', False),                    # not a status topic
])
def test_a_status_is_at_home_only_on_its_nodes_status_topic(source: str, node: str,
                                                            home: bool) -> None:
    assert at_home(source, node) is home


def test_a_genuine_status_copied_onto_another_nodes_topic_is_refused() -> None:
    key = new_key()
    gate = StatusGate(key)
    lab1 = holding('/pd/lab1/pd_actuator_bridge', Signer(key))
    status, reason = read_status(gate, '/pd/lab3/bridge/status', lab1)
    assert (status, reason) == (None, Refusal.MISDIRECTED)
    assert gate.refused == {'misdirected': 1}
    status, reason = read_status(gate, '/pd/lab1/bridge/status', lab1)  # at home: taken
    assert reason is None and status is not None and status.emergency_stop
    # Without a key nothing is authenticated, and nothing is checked.
    assert read_status(StatusGate(None), '/pd/lab3/bridge/status',
                       holding('/pd/lab1/pd_actuator_bridge', None))[1] is None


def test_a_malformed_status_on_another_nodes_topic_is_malformed_not_a_crash() -> None:
    """Bounds first: a status whose signature is beyond its bounds is refused as malformed
    wherever it arrives (its reader never handles its signature: that raised in the
    integrator, killing it, when the topic check came first)."""
    gate = StatusGate(new_key())
    message = holding('/pd/lab1/pd_actuator_bridge', None)
    message.signature.key_id = 'k' * 500  # type: ignore[attr-defined]
    for source in ('/pd/lab3/bridge/status', '/pd/lab1/bridge/status'):
        assert read_status(gate, source, message) == (None, Refusal.MALFORMED)
    assert gate.refused == {'malformed': 2}


def test_an_offer_of_no_known_state_origin_is_a_fresh_state() -> None:
    """A bridge turned an offer's state origin into a ``StateOrigin`` itself: an unknown value
    (an unsigned offer, without a key) raised in its loop. Every reader now takes it as the
    feedback's is taken: ``FRESH`` (no history claimed)."""
    offer = Offer(stamp_ns=5, node='/pd/specimen/pd_specimen_sim', challenge='c' * 32,
                  active_session='', authenticated=False, epoch='0' * 16, state_origin=0,
                  restored=('', 0, 0), position=(0.0,), force=(0.0,), configuration='')
    message = offer_message(offer)
    message.state_origin = 7
    received, reason = read_offer(StatusGate(None), '/pd/specimen/session/offer', message)
    assert reason is None and received is not None
    assert StateOrigin.of(received.state_origin) is StateOrigin.FRESH
    assert [StateOrigin.of(value) for value in (0, 1, 2)] == list(StateOrigin)


@pytest.mark.parametrize('line', ['s:² abort: ok', 's:٣ abort: ok', 's:1² abort: ok'])
def test_an_acknowledgement_whose_sequence_is_no_ascii_number_is_none(line: str) -> None:
    """'²'.isdigit() holds but int('²') raises: such a line in an unsigned status stopped
    ``./pd control`` (and the launcher, the console) reading the acknowledgements."""
    assert parse_acknowledgement(line) is None
    assert parse_acknowledgement('s:12 abort: ok') is not None
