"""The step's records made without their dataclass ``__init__`` (pd_common.protocol.frozen)."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import pytest

from pd_common.protocol import (
    Command,
    Feedback,
    FeedbackStatus,
    Signature,
    StateOrigin,
)
from pd_common.protocol.frozen import amended, command_of, feedback_of, signature_of

CASES: list[tuple[Any, Any, tuple[Any, ...]]] = [
    (Signature, signature_of, ('0123456789abcdef', 'ab' * 16, 7, b'\x01' * 32)),
    (Command, command_of, ('t', 3, 0.03, ('top', 'mid'), (0.1, -0.0), 2, (0, 1), (0.0, 5.0))),
    (Feedback, feedback_of, ('t', 3, (0.1, math.nan), (1.0, 2.0), FeedbackStatus.LIMIT, 'why',
                             1, 'e' * 16, StateOrigin.RESTORED)),
]


@pytest.mark.parametrize(('cls', 'maker', 'values'), CASES)
def test_a_made_record_is_the_one_its_init_makes(cls: Any, maker: Any,
                                                 values: tuple[Any, ...]) -> None:
    # every field of the class, in its order: a field added to the class fails this
    names = [field.name for field in dataclasses.fields(cls)]
    assert len(values) == len(names)
    made, reference = maker(*values), cls(*values)
    assert type(made) is cls
    assert vars(made) == vars(reference)
    assert list(vars(made)) == names
    assert repr(made) == repr(reference)
    assert dataclasses.astuple(made) == dataclasses.astuple(reference)
    if cls is Signature:
        assert made == reference
        assert hash(made) == hash(reference)
    with pytest.raises(dataclasses.FrozenInstanceError):
        made.step = 4  # frozen as any other


def test_amended_is_dataclasses_replace() -> None:
    feedback = Feedback(test_id='t', step=3, measured_displacement=(0.1,),
                        restoring_force=(1.0,), message='m')
    changes = {'test_id': 'u', 'epoch': 'e' * 16, 'state_origin': StateOrigin.RESTORED}
    made = amended(feedback, **changes)
    assert made == dataclasses.replace(feedback, **changes)
    assert list(vars(made)) == [field.name for field in dataclasses.fields(Feedback)]
    assert feedback.test_id == 't'  # the original is left as it was
    assert amended(feedback) == feedback
    with pytest.raises(TypeError, match='no field'):
        amended(feedback, epok='e')
