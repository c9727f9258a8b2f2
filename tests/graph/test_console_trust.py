"""The console shows only what the test's nodes signed (an attack on its screen).

A console node (with the test's key) in this process watches the domain; this test plays the
integrator and its receiver with the key, and a rogue without it on the same topics: a forged
test definition (wider limits on the gauges), forged, replayed and foreign step messages. The
console shows the definition only once the integrator's signed status names its digest, and
a command or feedback only as signed in the session the receiver's signed offer names; the
genuine ones all show. Without the console's checks every forgery here would be drawn.
"""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from test_graph import spin_until

pytestmark = pytest.mark.graph

GENUINE = json.dumps({'test': {'id': 'trust'}, 'sites': {'': {'bridge': {'max_stroke': 0.05}}}})
FORGED = json.dumps({'test': {'id': 'trust'}, 'sites': {'': {'bridge': {'max_stroke': 9.0}}}})


def test_the_console_shows_only_what_the_tests_nodes_signed(
        observer: Any, key_file: Path, tmp_path: Path) -> None:
    from std_msgs.msg import String

    from pd_common.auth import (
        WIRE_COMMAND,
        WIRE_FEEDBACK,
        Signer,
        generate_key,
        load_key,
        sign_wire_reply,
    )
    from pd_common.protocol import (
        Command,
        Feedback,
        Offer,
        Status,
        TestState,
        definition_digest,
        encode_command,
        encode_feedback,
    )
    from pd_common.ros import LATCHED_QOS, STEP_QOS
    from pd_common.ros.messages import offer_message, status_message
    from pd_console.console import ConsoleNode
    from pd_console.core import DEFINITIONS_KEPT, ConsoleModel
    from pd_msgs.msg import SessionOffer, StepCommand, StepFeedback, TestStatus

    key = load_key(key_file)
    rogue_key = generate_key(tmp_path / 'rogue.key')
    model = ConsoleModel(time.monotonic)
    console = ConsoleNode(model, threading.Lock(), {'key_file': str(key_file)},
                          context=observer.context)
    observer.executor_for_test.add_node(console)
    try:
        definition = observer.create_publisher(String, '/pd/test_definition', LATCHED_QOS)
        rogue_definition = observer.create_publisher(String, '/pd/test_definition',
                                                     LATCHED_QOS)
        status = observer.create_publisher(TestStatus, '/pd/test_status', LATCHED_QOS)
        offer = observer.create_publisher(SessionOffer, '/pd/session/offer', LATCHED_QOS)
        commands = observer.create_publisher(StepCommand, '/pd/step_command', STEP_QOS)
        feedback = observer.create_publisher(StepFeedback, '/pd/step_feedback', STEP_QOS)
        spin_until(observer, lambda: all(p.get_subscription_count() > 0 for p in (
            definition, rogue_definition, status, offer, commands, feedback)), 20.0,
            'the console to listen')

        def settle(seconds: float = 0.4) -> None:
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                observer.executor_for_test.spin_once(timeout_sec=0.02)

        # -- the definition: the genuine one, then a flood of forgeries before any status ----
        definition.publish(String(data=GENUINE))          # (latched: once, as the integrator)
        settle(0.2)
        flood = [json.dumps({'sites': {f'rogue{n}': {}}}) for n in range(DEFINITIONS_KEPT + 2)]
        for text in (FORGED, *flood, FORGED):  # more than it keeps: the genuine one goes
            rogue_definition.publish(String(data=text))
            settle(0.1)  # (each taken: the topic keeps one sample)
        assert not model.definition, 'a definition no signed status names'
        integrator = Signer(key)
        announcer = Signer(key)

        def genuine_status() -> None:  # (the integrator's heartbeat)
            status.publish(status_message(Status(
                test_id='trust', state=TestState.RUNNING, step=1, total_steps=10,
                omega_dt=0.1, node='/pd/pd_integrator', session=announcer.session,
                definition_digest=definition_digest(GENUINE)), signer=announcer))

        deadline = time.monotonic() + 15.0
        while model.definition != json.loads(GENUINE):  # read again, the genuine one shows
            assert time.monotonic() < deadline, 'the genuine definition never showed'
            genuine_status()
            settle(0.5)
        rogue_definition.publish(String(data=FORGED))
        settle()
        assert model.definition == json.loads(GENUINE)
        assert model.sites[''].limits['max_stroke'] == 0.05
        assert not any(site.startswith('rogue') for site in model.sites)

        # -- the step messages: only the hop's, in the receiver's session --------------------
        view = model.site('')

        def command(signer: Signer, step: int, sign_key: Any = None) -> tuple[bytes, Any]:
            record = Command(test_id='trust', step=step, test_time=0.01 * step,
                             dof_names=('u',), target_displacement=(0.001 * step,))
            if sign_key is not None:
                signer = Signer(sign_key, session=signer.session)
            return signer.sign_wire(WIRE_COMMAND, lambda signature: encode_command(
                record, time.time_ns(), signature))

        def reply(request: Any, step: int, force: float) -> bytes:
            record = Feedback(test_id='trust', step=step, measured_displacement=(0.001 * step,),
                              restoring_force=(force,))
            data, _ = sign_wire_reply(key, WIRE_FEEDBACK, lambda signature: encode_feedback(
                record, time.time_ns(), signature), request)
            return data

        early, _ = command(integrator, 1)
        commands.publish(early)                       # before the receiver's offer: not shown
        settle()
        assert view.commands == 0
        offer.publish(offer_message(Offer(
            stamp_ns=time.time_ns(), node='/pd/pd_simulator', challenge='c' * 32,
            active_session=integrator.session, authenticated=True, epoch='e', state_origin=0,
            restored=('', 0, 0), position=(0.0,), force=(0.0,)), Signer(key)))
        spin_until(observer, lambda: console._watch_gates[''].session == integrator.session,
                   10.0, 'the console to follow the offered session')
        genuine, signature = command(integrator, 2)
        answer = reply(signature, 2, 1500.0)
        commands.publish(genuine)
        feedback.publish(answer)
        spin_until(observer, lambda: view.commands == 1 and view.feedback_ok == 1, 10.0,
                   'the genuine command and its feedback to show')
        commands.publish(genuine)                                        # replayed
        forged = bytearray(command(integrator, 3)[0])
        forged[-40] ^= 0x01                                              # a byte flipped
        commands.publish(bytes(forged))
        commands.publish(command(integrator, 4, sign_key=rogue_key)[0])  # another key
        commands.publish(command(Signer(key), 5)[0])                     # another session
        feedback.publish(answer)                                         # a replayed answer
        settle()
        assert (view.commands, view.resends, view.feedback_ok) == (1, 0, 1)
        refused = console.refused()['step[default]']
        assert refused == {'no_session': 1, 'replayed': 2, 'forged': 1, 'wrong_key': 1,
                           'foreign_session': 1}, refused
        nxt, signature = command(integrator, 6)                          # the test goes on
        commands.publish(nxt)
        feedback.publish(reply(signature, 6, 1600.0))
        spin_until(observer, lambda: view.commands == 2 and view.feedback_ok == 2, 10.0,
                   'the next genuine step to show')
    finally:
        observer.executor_for_test.remove_node(console)
        console.destroy_node()
