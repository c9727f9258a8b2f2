"""The force ramp of a force-controlled actuator."""

from __future__ import annotations

import math

import pytest

from pd_common.experimental.force_ramp import force_ramp


def test_the_ramp_is_equal_steps_within_the_increment_and_ends_on_the_target() -> None:
    ramp = force_ramp(0.0, 24950.0, 1000.0)
    assert len(ramp) == 25  # ceil(24.95)
    assert ramp[-1] == 24950.0
    steps = [b - a for a, b in zip([0.0, *ramp[:-1]], ramp)]
    assert max(abs(step) for step in steps) <= 1000.0
    assert steps == pytest.approx([24950.0 / 25] * 25, rel=1e-12)
    down = force_ramp(24950.0, 0.0, 5000.0)
    assert down == pytest.approx([19960.0, 14970.0, 9980.0, 4990.0, 0.0], abs=1e-9)
    assert down[-1] == 0.0


def test_no_ramp_no_change_and_bad_values() -> None:
    assert force_ramp(10.0, 10.0, 1.0) == []
    assert force_ramp(0.0, 5.0e4, 0.0) == [5.0e4]
    assert force_ramp(0.0, 500.0, 1000.0) == [500.0]
    for args in ((math.nan, 1.0, 1.0), (0.0, math.inf, 1.0), (0.0, 1.0, -1.0)):
        with pytest.raises(ValueError, match='force ramp'):
            force_ramp(*args)


def test_a_sub_step_ramped_again_is_one_step() -> None:
    for target, increment in ((24950.0, 2495.0), (1.0e4, 3.0e3), (-7.3e3, 0.7e3)):
        ramp = force_ramp(0.0, target, increment)
        held = 0.0
        for sub_target in ramp:
            assert force_ramp(held, sub_target, increment) == [sub_target]
            held = sub_target
