"""A bridge's actuator trajectory enters a run's record only as its bridge signed it.

The bridge signs each trajectory (``pd_common.ros.sign_trajectory``); the integrator decodes
the bytes that arrived with the run's own reader (``read_trajectory``) and admits them through
``admit_trajectory``: good MAC over every field and the four arrays, new on its topic, and the
node it names publishes that topic. Here the message goes the whole way as bytes: rclpy
serialises it, the reader decodes it, the gate judges it.
"""

from __future__ import annotations

import array
import math
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rclpy.serialization import serialize_message
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from pd_common.auth import Key, Refusal, Signer, StatusGate, new_key, trajectory_payload
from pd_common.ros import (
    admit_trajectory,
    fill_signature,
    remember_trajectory,
    sign_trajectory,
)
from pd_core.run.record.bag import msg_directory, read_trajectory, typestore
from pd_core.run.record.journal import JOURNAL_FILE, Journal, read_journal
from pd_msgs.msg import ActuatorTrajectory

BRIDGE = '/pd/lab1/pd_actuator_bridge'
SOURCE = '/pd/lab1/bridge/trajectory'
ARRAYS = ('time', 'command', 'measured_displacement', 'measured_force')


def admit(gate: StatusGate, source: str, message: Any, test_id: str = 't',
          not_before_ns: int = 0) -> Refusal | None:
    """As the integrator of test ``test_id`` admits it (its probe's moves are the test's)."""
    return admit_trajectory(gate, source, message, (test_id, test_id + ':probe'),
                            not_before_ns)


def trajectory(step: int = 3, sec: int = 100) -> ActuatorTrajectory:
    message = ActuatorTrajectory(test_id='t', step=step, iteration=1, rate=1000.0, n_dof=2,
                                 time=[0.0, 0.001, 0.002],
                                 command=[0.001, -0.0, 0.002, 1e-300, 0.003, -2.5],
                                 measured_displacement=[0.0011, 0.0, 0.0021, math.nan, 0.0031,
                                                        -2.4],
                                 measured_force=[5.0, -6.0, 7.0, 8.0, 1e308, -1e-308])
    message.header.stamp.sec = sec
    message.header.stamp.nanosec = 7
    return message


def arrived(message: ActuatorTrajectory) -> Any:
    """The message as the integrator reads it: its bytes, decoded by the run's reader."""
    return read_trajectory(bytes(serialize_message(message)), typestore())


def signed(key: Key, **kwargs: int) -> ActuatorTrajectory:
    message = trajectory(**kwargs)
    sign_trajectory(message, Signer(key), BRIDGE)
    return message


def test_a_signed_trajectory_is_admitted_once_on_its_bridges_topic() -> None:
    key = new_key()
    gate = StatusGate(key)
    signer = Signer(key)
    first, second = trajectory(step=3), trajectory(step=4, sec=101)
    for message in (first, second):
        sign_trajectory(message, signer, BRIDGE)
    assert first.node == BRIDGE and len(first.signature.mac) == 32
    assert admit(gate, SOURCE, arrived(first)) is None
    assert admit(gate, SOURCE, arrived(second)) is None
    assert admit(gate, SOURCE, arrived(first)) is Refusal.REPLAYED  # a recording
    assert gate.refused == {'replayed': 1}


def test_a_trajectory_copied_onto_another_bridges_topic_is_misdirected() -> None:
    key = new_key()
    gate = StatusGate(key)
    message = arrived(signed(key))
    assert admit(gate, '/pd/lab3/bridge/trajectory', message) is Refusal.MISDIRECTED
    assert admit(gate, '/pd/bridge/trajectory', message) is Refusal.MISDIRECTED
    assert gate.refused == {'misdirected': 2}
    assert admit(gate, SOURCE, message) is None  # (the gate remembered nothing)


def test_unsigned_and_other_keys_trajectories_are_refused_with_a_key_only() -> None:
    key = new_key()
    unsigned = trajectory()
    unsigned.node = BRIDGE
    assert admit(StatusGate(key), SOURCE, arrived(unsigned)) is Refusal.UNSIGNED
    assert admit(StatusGate(key), SOURCE,
                            arrived(signed(new_key()))) is Refusal.WRONG_KEY
    # Without a key nothing is authenticated: every well-formed trajectory is recorded.
    assert admit(StatusGate(None), '/anywhere', arrived(trajectory())) is None


@pytest.mark.parametrize('field', ['test_id', 'step', 'iteration', 'rate', 'n_dof', 'node',
                                   'stamp', *ARRAYS])
def test_a_change_to_any_field_after_signing_is_forged(field: str) -> None:
    key = new_key()
    message = signed(key)
    if field == 'n_dof':
        # (another DOF count no longer fits the arrays, so the reader refuses it first: that
        # the count is signed is seen in the payload, all else the same)
        with pytest.raises(ValueError, match='not an actuator trajectory'):
            message.n_dof += 1
            arrived(message)
        arrays = [[0.5, 0.25]] * 4
        assert (trajectory_payload(BRIDGE, 't', 3, 1, 1e3, 1, 5, arrays)
                != trajectory_payload(BRIDGE, 't', 3, 1, 1e3, 2, 5, arrays))
        return
    if field == 'stamp':
        message.header.stamp.nanosec += 1
    elif field in ARRAYS:
        values = list(getattr(message, field))
        values[-1] = math.nextafter(values[-1], math.inf)  # one ulp
        setattr(message, field, values)
    elif field == 'test_id':
        message.test_id = 'u'
    elif field == 'node':
        message.node = BRIDGE + 'x'
        # (at home still: the same namespace, another node name)
    else:
        setattr(message, field, type(getattr(message, field))(getattr(message, field) + 1))
    test_id = message.test_id  # (of this test: the MAC is what refuses it)
    assert admit(StatusGate(key), SOURCE, arrived(message), test_id=test_id) is Refusal.FORGED


def test_every_byte_of_a_signed_trajectory_counts() -> None:
    """Flip each byte of the message's bytes: each is refused, unreadable or taken as itself."""
    key = new_key()
    message = signed(key)
    data = bytes(serialize_message(message))
    store = typestore()
    assert admit(StatusGate(key), SOURCE, read_trajectory(data, store)) is None
    for index in range(len(data)):
        flipped = bytearray(data)
        flipped[index] ^= 0x01
        try:
            decoded = read_trajectory(bytes(flipped), store)
        except ValueError:
            continue  # not a trajectory: never recorded (counted as malformed)
        reason = admit(StatusGate(key), SOURCE, decoded)
        if reason is None:  # only CDR padding may change without changing the message
            assert bytes(serialize_message(_rebuilt(decoded))) == data, index
        else:
            assert reason in {Refusal.FORGED, Refusal.WRONG_KEY, Refusal.MISDIRECTED,
                              Refusal.FOREIGN_TEST, Refusal.MALFORMED, Refusal.UNSIGNED}, (
                index, reason)


def _rebuilt(decoded: Any) -> ActuatorTrajectory:
    """An rclpy message of a decoded one (its fields, its signature)."""
    message = ActuatorTrajectory(test_id=decoded.test_id, step=int(decoded.step),
                                 iteration=int(decoded.iteration), rate=float(decoded.rate),
                                 n_dof=int(decoded.n_dof), node=decoded.node,
                                 **{name: list(getattr(decoded, name)) for name in ARRAYS})
    message.header.stamp.sec = int(decoded.header.stamp.sec)
    message.header.stamp.nanosec = int(decoded.header.stamp.nanosec)
    signature = decoded.signature
    message.signature.key_id = signature.key_id
    message.signature.session = signature.session
    message.signature.sequence = int(signature.sequence)
    message.signature.mac = bytes(signature.mac)
    return message


def test_the_payload_hashes_the_arrays_values_whatever_holds_them() -> None:
    """A list, an array.array and a numpy array of the same values sign alike; -0.0 and 0.0,
    or two NaNs of different bits, do not."""
    values = [0.5, -0.0, math.nan, 1e-310]
    payload = [trajectory_payload('/n', 't', 1, 0, 1e3, 1, 5, [holder] * 4)
               for holder in (values, array.array('d', values), np.array(values))]
    assert payload[0] == payload[1] == payload[2]
    zero = trajectory_payload('/n', 't', 1, 0, 1e3, 1, 5, [[0.5, 0.0, math.nan, 1e-310]] * 4)
    assert zero != payload[0]
    (other_nan,) = struct.unpack('<d', struct.pack('<Q', 0x7FF8000000000001))
    assert trajectory_payload('/n', 't', 1, 0, 1e3, 1, 5,
                              [[0.5, -0.0, other_nan, 1e-310]] * 4) != payload[0]


def test_a_trajectory_with_a_signature_beyond_its_bounds_is_malformed() -> None:
    key = new_key()
    message = signed(key)
    fill_signature(message.signature, Signer(key).sign(b'x'))
    message.signature.key_id = 'k' * 1000
    gate = StatusGate(key)
    assert admit(gate, SOURCE, arrived(message)) is Refusal.MALFORMED
    assert gate.refused == {'malformed': 1}


def test_a_journals_trajectory_from_before_signatures_is_left_out_with_a_note(
        tmp_path: Path) -> None:
    """A run recorded by the version before (its trajectories without node and signature),
    recovered or resumed now: the step record reads whole, those records are left out, noted."""
    old_text = (msg_directory() / 'ActuatorTrajectory.msg').read_text(encoding='utf-8')
    old_text = '\n'.join(line for line in old_text.splitlines()
                         if not line.startswith(('string node', 'Signature signature')))
    old = get_typestore(Stores.ROS2_KILTED)
    old.register(get_types_from_msg(old_text, 'pd_msgs/msg/ActuatorTrajectory'))
    cls = old.types['pd_msgs/msg/ActuatorTrajectory']
    header = old.types['std_msgs/msg/Header'](
        stamp=old.types['builtin_interfaces/msg/Time'](sec=1, nanosec=2), frame_id='')
    values = np.array([0.001, 0.002])
    old_bytes = bytes(old.serialize_cdr(cls(header=header, test_id='t', step=3, iteration=0,
                                           rate=1000.0, n_dof=1, time=values, command=values,
                                           measured_displacement=values,
                                           measured_force=values),
                                       'pd_msgs/msg/ActuatorTrajectory'))
    path = tmp_path / JOURNAL_FILE
    with Journal(path) as journal:
        journal.write_definition('{"test": {"id": "t"}}', 1)
        journal.write_raw('/pd/bridge/trajectory', 2, old_bytes)
        journal.write_raw('/pd/bridge/trajectory', 3, bytes(serialize_message(trajectory())))
    run = read_journal(path)
    assert [t_ns for t_ns, _ in run.trajectories] == [3]
    assert len(run.notes) == 1 and run.notes[0].startswith(
        'left out 1 trajectory record (first: /pd/bridge/trajectory at log time 2 ns')


def test_a_trajectory_of_another_test_or_from_before_the_start_is_refused() -> None:
    """A recording of a genuine trajectory of an earlier run: another test's (foreign_test),
    or the same test's stamped before this recorder started, less 30 s for clocks (stale)."""
    key = new_key()
    message = arrived(signed(key, sec=100))
    gate = StatusGate(key)
    assert admit(gate, SOURCE, message, test_id='other') is Refusal.FOREIGN_TEST
    assert admit(gate, SOURCE, message, not_before_ns=100_000_000_008) is Refusal.STALE
    assert gate.refused == {'foreign_test': 1, 'stale': 1}
    assert admit(gate, SOURCE, message, not_before_ns=100_000_000_007) is None  # its stamp


def test_a_resumed_recorder_never_takes_what_its_record_holds_again() -> None:
    key = new_key()
    signer = Signer(key)
    recorded = []
    for step in (3, 4, 5):
        message = trajectory(step=step, sec=100 + step)
        sign_trajectory(message, signer, BRIDGE)
        recorded.append(arrived(message))
    gate = StatusGate(key)  # the resumed integrator's
    for message in recorded[:2]:  # what its journal held
        remember_trajectory(gate, message)
    assert admit(gate, SOURCE, recorded[0]) is Refusal.REPLAYED
    assert admit(gate, SOURCE, recorded[1]) is Refusal.REPLAYED
    assert admit(gate, SOURCE, recorded[2]) is None  # the next one
    # A record's trajectory from before signatures (no node, no signature) is nothing to
    # remember, and no error.
    old = StatusGate(key)
    unsigned = trajectory()
    remember_trajectory(old, arrived(unsigned))
    assert admit(old, SOURCE, recorded[0]) is None


def test_a_probe_moves_trajectory_is_the_tests_and_what_is_not_signed_is_said_so() -> None:
    """The probe's commands carry the test id and ':probe' (the bridge stamps its trajectories
    with them): they are the test's. And the signature is judged first: an unsigned recording
    from before the start is counted unsigned, not stale."""
    key = new_key()
    probe = trajectory()
    probe.test_id = 't:probe'
    sign_trajectory(probe, Signer(key), BRIDGE)
    assert admit(StatusGate(key), SOURCE, arrived(probe)) is None
    unsigned = trajectory(sec=1)
    unsigned.node = BRIDGE
    gate = StatusGate(key)
    assert admit(gate, SOURCE, arrived(unsigned), test_id='other',
                 not_before_ns=10**18) is Refusal.UNSIGNED
    assert gate.refused == {'unsigned': 1}
