"""Mixed control in the step protocol: per DOF a control mode and a target force, carried by
the command, its message, its signature, the journal and the bag."""

from __future__ import annotations

import dataclasses
import math
import struct
from pathlib import Path

import pytest

from pd_common.auth import WIRE_COMMAND, Signer, command_payload, new_key, verify_mac
from pd_common.protocol import (
    Command,
    ControlMode,
    Signature,
    command_from_message,
    covered_part,
    decode_command,
    encode_command,
)
from pd_common.ros import command_message
from pd_core.run.record.bag import BagRecorder, read_bag
from pd_core.run.record.journal import Journal, read_journal_records

MIXED = Command(test_id='column', step=3, test_time=0.06, dof_names=('horizontal', 'vertical'),
                target_displacement=(0.0125, -0.0004), control_mode=(0, 1),
                target_force=(0.0, 24950.0))


def test_modes_default_to_displacement_control() -> None:
    plain = Command(test_id='t', step=1, test_time=0.0, dof_names=('a', 'b'),
                    target_displacement=(0.1, 0.2))
    assert not plain.mixed
    assert plain.force_controlled() == (False, False)
    assert plain.control_error() is None
    assert MIXED.mixed
    assert MIXED.force_controlled() == (False, True)
    assert MIXED.control_error() is None
    assert ControlMode(1).label == 'force'


@pytest.mark.parametrize(('modes', 'forces', 'expected'), [
    ((), (1.0, 2.0), 'target forces without control modes'),
    ((0,), (0.0, 1.0), '1 control modes and 2 target forces for 2 DOFs'),
    ((0, 7), (0.0, 1.0), 'DOF 1: unknown control mode 7'),
    ((0, 1), (0.0, math.nan), 'DOF 1: target force nan is not finite'),
])
def test_inconsistent_modes_are_named(modes: tuple[int, ...], forces: tuple[float, ...],
                                      expected: str) -> None:
    command = Command(test_id='t', step=1, test_time=0.0, dof_names=('a', 'b'),
                      target_displacement=(0.1, 0.2), control_mode=modes, target_force=forces)
    error = command.control_error()
    assert error is not None and expected in error


def test_a_plain_command_carries_no_modes_nor_forces() -> None:
    plain = Command(test_id='t', step=2, test_time=0.04, dof_names=('a',),
                    target_displacement=(0.25,), iteration=1)
    data = encode_command(plain, 5)
    # the two empty arrays (control_mode, target_force) right after the target: 4-byte counts 0
    target_end = data.index(struct.pack('<d', 0.25)) + 8
    assert data[target_end:target_end + 8] == bytes(8)
    assert decode_command(data).record == plain


@pytest.mark.parametrize('changed', [
    {'control_mode': (1, 1)},
    {'target_force': (0.0, 24951.0)},
    {'control_mode': ()},
])
def test_the_signature_covers_modes_and_forces(changed: dict[str, object]) -> None:
    key = new_key()
    data, signature = Signer(key).sign_wire(WIRE_COMMAND,
                                            lambda bare: encode_command(MIXED, 5, bare))
    sent = decode_command(data)
    assert verify_mac(key, command_payload(sent.covered), signature) is None
    fields = {**MIXED.__dict__, **changed}
    if changed == {'control_mode': ()}:
        fields['target_force'] = ()
    tampered = Command(**fields)  # type: ignore[arg-type]
    covered = covered_part(encode_command(tampered, 5, dataclasses.replace(signature, mac=b'')))
    assert verify_mac(key, command_payload(covered), signature) is not None


def test_modes_round_trip_through_the_message_the_journal_and_the_bag(tmp_path: Path) -> None:
    message = command_message(MIXED)
    assert list(message.control_mode) == [0, 1]
    assert command_from_message(message) == MIXED

    with Journal(tmp_path / 'journal.pdj') as journal:
        journal.write_command(MIXED, 1, signature=Signature())
    records, _ = read_journal_records(tmp_path / 'journal.pdj')
    assert records[-1].item == MIXED

    with BagRecorder(tmp_path / 'bag') as recorder:
        recorder.write_definition('{}', 1)
        recorder.write_command(MIXED, 2)
    assert read_bag(tmp_path / 'bag').commands == [MIXED]
