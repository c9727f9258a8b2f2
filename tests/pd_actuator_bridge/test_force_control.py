"""Force and mixed control in the actuator bridge core (issue 16): the checks before anything
moves, the force ramp's sub-steps, the stroke checks after each (a runaway holds), the
ramp-down at deactivation, the drivers that refuse force control and the unchanged plain path.

References: closed forms (ceil(P/inc) equal sub-steps, the last exactly P; an ideal force loop
on a spring, x = F/k), scripted drivers (a stroke that runs away), the loopback driver's plain
path, and a simulated specimen (``SpecimenServer``) fed the bridge's sub-steps one by one
against the same specimen fed the whole command (it ramps by itself).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import pytest

from pd_actuator_bridge.core import (
    ActuatorBridge,
    ActuatorDriver,
    ActuatorMeasurement,
    BridgeConfigError,
    DaqmxDriver,
    DriverError,
    EmulatorDriver,
    GenericTCPDriver,
    OpenSeesAdapterDriver,
    SafetyLimits,
    StepId,
    force_substep_key,
)
from pd_actuator_bridge.core.drivers.base import SUBSTEP_STRIDE
from pd_common.protocol import Feedback, FeedbackStatus, StepKey
from pd_common.specimen import BilinearKinematic, ColumnSpecimen, SpecimenServer
from support.loopback import LoopbackDriver

OK, LIMIT, FAULT = FeedbackStatus.OK, FeedbackStatus.LIMIT, FeedbackStatus.FAULT
D, F = 0, 1  # control modes
K = 1.0e5     # N/m, the fake specimen's stiffness per DOF
NAMES = ('horizontal', 'vertical')


def limits(**overrides: float) -> SafetyLimits:
    values = {'max_displacement': 0.25, 'max_increment': 0.125, 'max_force': 2.0e4,
              'max_force_increment': 3000.0}
    values.update(overrides)
    return SafetyLimits(**values)


class ForceDriver(ActuatorDriver):
    """An ideal actuator on springs of stiffness ``K``: displacement-controlled DOFs go to their
    target, force-controlled ones hold their force (x = F / K). ``stroke(n, dof, x)`` may
    script the measured stroke of each DOF at the n-th force sub-step (1-based). Synchronous unless
    ``asynchronous``; then :meth:`answer` reports the sub-step in flight."""

    driver_name = 'fake_force'

    def __init__(self, n_dof: int = 2, *, asynchronous: bool = False,
                 stroke: Callable[[int, int, float], float] | None = None) -> None:
        super().__init__()
        self._n = n_dof
        self.x = [0.0] * n_dof
        self.f = [0.0] * n_dof
        self.plain: list[tuple[StepId, tuple[float, ...]]] = []
        self.sub: list[tuple[StepId, tuple[float, ...], tuple[int, ...], tuple[float, ...]]] = []
        self.hold_count = 0
        self.asynchronous = asynchronous
        self.stroke = stroke
        self.pending: StepId | None = None

    @property
    def n_dof(self) -> int:
        return self._n

    def force_control_problem(self) -> str | None:
        return None

    def command(self, step: StepId, target: Sequence[float]) -> None:
        self.plain.append((step, tuple(target)))
        self.x = [float(v) for v in target]
        self.f = [K * v for v in self.x]
        self._emit(ActuatorMeasurement(step, tuple(self.x), tuple(self.f)))

    def command_force(self, step: StepId, target: Sequence[float],
                      control_mode: Sequence[int], target_force: Sequence[float]) -> None:
        self.sub.append((step, tuple(target), tuple(control_mode), tuple(target_force)))
        for dof in range(self._n):
            if control_mode[dof] == F:
                x, f = target_force[dof] / K, float(target_force[dof])
            else:
                x = float(target[dof])
                f = K * x
            if self.stroke is not None:
                x = self.stroke(len(self.sub), dof, x)
            self.x[dof], self.f[dof] = x, f
        if self.asynchronous:
            self.pending = step
        else:
            self._emit(ActuatorMeasurement(step, tuple(self.x), tuple(self.f)))

    def answer(self) -> None:
        step, self.pending = self.pending, None
        assert step is not None
        self._emit(ActuatorMeasurement(step, tuple(self.x), tuple(self.f)))

    def hold(self) -> None:
        self.hold_count += 1

    def position(self) -> list[float]:
        return list(self.x)


def bridge_with(driver: ActuatorDriver, lim: SafetyLimits | None = None) -> ActuatorBridge:
    names = NAMES[:driver.n_dof] if driver.n_dof <= 2 else [f'a{i}' for i in range(driver.n_dof)]
    return ActuatorBridge(driver, lim or limits(), names)


def mixed(bridge: ActuatorBridge, step: StepId, x: float, force: float,
          test_id: str = 't') -> Feedback | None:
    """Horizontal displacement-controlled at ``x``, vertical force-controlled at ``force``."""
    return bridge.handle_command(test_id, step, (x, 0.0),
                                 control_mode=(D, F), target_force=(0.0, force))


# -- before anything moves ------------------------------------------------------------------------
@pytest.mark.parametrize('force', [20000.5, -20000.5, 1.0e9])
def test_a_force_target_beyond_max_force_is_refused_before_any_driver_call(force: float) -> None:
    driver = ForceDriver()
    bridge = bridge_with(driver)
    reply = mixed(bridge, 1, 0.01, force)
    assert reply is not None and reply.status is LIMIT
    assert 'DOF 1 (vertical)' in reply.message and 'max_force 20000 N' in reply.message
    assert 'target force' in reply.message and '\n' not in reply.message
    assert driver.sub == [] and driver.plain == []
    assert bridge.state == 'holding' and driver.hold_count == 1
    assert bridge.held_force == (0.0, 0.0)


def test_a_force_target_exactly_at_max_force_is_allowed() -> None:
    driver = ForceDriver()
    bridge = bridge_with(driver, limits(max_force_increment=0.0, max_increment=0.25))
    reply = mixed(bridge, 1, 0.0, -20000.0)
    assert reply is not None and reply.status is OK, reply
    assert [sub[3][1] for sub in driver.sub] == [-20000.0]


def test_displacement_limits_still_apply_to_the_displacement_controlled_dof() -> None:
    driver = ForceDriver()
    bridge = bridge_with(driver)
    reply = mixed(bridge, 1, 0.2, 1000.0)  # |dx| 0.2 > max_increment 0.125
    assert reply is not None and reply.status is LIMIT
    assert 'DOF 0 (horizontal)' in reply.message and 'max_increment' in reply.message
    assert driver.sub == []


def test_the_force_controlled_dofs_target_displacement_is_not_imposed_nor_limited() -> None:
    driver = ForceDriver()
    driver.x = [0.0, 0.2]  # the vertical stroke is where its force took it
    bridge = bridge_with(driver, limits(max_force_increment=0.0))
    # its target displacement (the last measured, 0.2) would be an increment of 0.2 - but it
    # is not imposed; and a wrong one (0.0, an increment of 0.2 from 0.2) is not checked
    reply = bridge.handle_command('t', 1, (0.01, 0.0), control_mode=(D, F),
                                  target_force=(0.0, 0.2 * K))
    assert reply is not None and reply.status is OK, reply
    assert driver.sub[0][1] == (0.01, 0.2)  # sent: the measured stroke, not the 0.0


@pytest.mark.parametrize(('modes', 'forces', 'words'), [
    ((D,), (0.0,), '1 control modes and 1 target forces for 2 DOF'),
    ((D, F), (0.0,), '2 control modes and 1 target forces for 2 DOF'),
    ((), (0.0, 1.0), '2 target forces without control modes'),
    ((D, 2), (0.0, 1.0), 'DOF 1 (vertical): unknown control mode 2'),
    ((D, F), (0.0, math.nan), 'DOF 1 (vertical): target force nan is not finite'),
    ((D, F), (0.0, math.inf), 'DOF 1 (vertical): target force inf is not finite'),
])
def test_inconsistent_modes_or_forces_are_a_one_line_fault_and_nothing_moves(
        modes: tuple[int, ...], forces: tuple[float, ...], words: str) -> None:
    driver = ForceDriver()
    bridge = bridge_with(driver)
    reply = bridge.handle_command('t', 1, (0.01, 0.0), control_mode=modes, target_force=forces)
    assert reply is not None and reply.status is FAULT
    assert reply.message.startswith('invalid control: ') and words in reply.message
    assert '\n' not in reply.message
    assert driver.sub == [] and driver.plain == [] and bridge.state == 'holding'


# -- the ramp -------------------------------------------------------------------------------------
@pytest.mark.parametrize(('load', 'increment'), [(10000.0, 3000.0), (-12000.0, 2500.0),
                                                 (7000.0, 7000.0), (5000.0, 0.0)])
def test_a_force_ramp_goes_in_ceil_p_over_inc_substeps_each_within_inc_the_last_exactly_p(
        load: float, increment: float) -> None:
    driver = ForceDriver()
    bridge = bridge_with(driver, limits(max_force_increment=increment))
    reply = mixed(bridge, StepKey(3, 1), 0.01, load)
    assert reply is not None and reply.status is OK, reply
    n = math.ceil(abs(load) / increment) if increment > 0.0 else 1
    forces = [sub[3][1] for sub in driver.sub]
    assert len(forces) == n
    assert forces[-1] == load  # exactly
    changes = [b - a for a, b in zip([0.0, *forces], forces)]
    assert all(abs(change) <= (increment or abs(load)) * (1 + 1e-12) for change in changes)
    assert all(change * load > 0 for change in changes)  # monotone towards the target
    assert forces == pytest.approx([load * k / n for k in range(1, n + 1)], rel=1e-15)
    # every sub-step: its own id (*key, s), the modes, the horizontal at its target from the
    # first one, the displacement-controlled DOF's force 0
    assert [sub[0] for sub in driver.sub] == [(3, 1, s) for s in range(n)]
    assert all(sub[2] == (D, F) and sub[1][0] == 0.01 and sub[3][0] == 0.0 for sub in driver.sub)
    assert driver.plain == []
    # answered once, for the integrator's step, with the last sub-step's measurement
    assert reply.key == (3, 1)
    assert reply.measured_displacement == (0.01, load / K)
    assert reply.restoring_force == (0.01 * K, load)
    assert bridge.held_force == (0.0, load) and bridge.state == 'ready'
    assert bridge.force_substeps == n


def test_the_next_ramp_starts_from_the_held_force_and_an_unchanged_force_is_one_substep() -> None:
    driver = ForceDriver()
    bridge = bridge_with(driver)  # max_force_increment 3000
    mixed(bridge, 1, 0.0, 10000.0)
    del driver.sub[:]
    reply = mixed(bridge, 2, 0.01, 4000.0)  # 10000 -> 4000: two sub-steps of 3000
    assert reply is not None and reply.status is OK
    assert [sub[3][1] for sub in driver.sub] == [7000.0, 4000.0]
    assert [sub[0] for sub in driver.sub] == [(2, 0), (2, 1)]  # int step 2: ids (2, s)
    del driver.sub[:]
    reply = mixed(bridge, 3, 0.02, 4000.0)  # the same force: one sub-step (the horizontal moves)
    assert reply is not None and reply.status is OK
    assert [(sub[1][0], sub[3][1]) for sub in driver.sub] == [(0.02, 4000.0)]


def test_two_force_controlled_dofs_each_follow_their_own_ramp() -> None:
    driver = ForceDriver(3)
    bridge = bridge_with(driver)  # max_force_increment 3000
    reply = bridge.handle_command('t', 1, (0.0, 0.0, 0.0), control_mode=(F, D, F),
                                  target_force=(9000.0, 0.0, -3000.0))
    assert reply is not None and reply.status is OK
    # DOF 0: 3000, 6000, 9000; DOF 2 arrives at -3000 in one and holds it
    assert [(sub[3][0], sub[3][2]) for sub in driver.sub] == [
        (3000.0, -3000.0), (6000.0, -3000.0), (9000.0, -3000.0)]


def test_an_asynchronous_driver_gets_each_substep_only_after_the_previous_one_answered() -> None:
    driver = ForceDriver(asynchronous=True)
    bridge = bridge_with(driver)
    replies: list[Feedback] = []
    bridge.set_reply_callback(replies.append)
    assert mixed(bridge, 1, 0.01, 9000.0) is None
    for k in range(1, 4):
        assert len(driver.sub) == k and bridge.state == 'busy' and replies == []
        assert bridge.in_flight == ('t', 1)
        # a stale measurement (an earlier sub-step, or the integrator's step) is ignored
        bridge.handle_measurement(ActuatorMeasurement(1, (0.0, 0.0), (0.0, 0.0)))
        driver.answer()
    assert [sub[3][1] for sub in driver.sub] == [3000.0, 6000.0, 9000.0]
    assert len(replies) == 1 and replies[0].status is OK and replies[0].step == 1
    assert bridge.ignored_measurements == 3 and bridge.state == 'ready'


# -- the checks after each sub-step ---------------------------------------------------------------
def test_a_runaway_force_controlled_actuator_holds_with_a_limit_and_no_more_substeps() -> None:
    # the vertical stroke grows 0.1 m per sub-step: beyond max_displacement 0.25 at the 3rd
    driver = ForceDriver(stroke=lambda n, dof, x: 0.1 * n if dof == 1 else x)
    bridge = bridge_with(driver, limits(max_increment=1.0))
    reply = mixed(bridge, 5, 0.01, 15000.0)  # 5 sub-steps of 3000 planned
    assert reply is not None and reply.status is LIMIT and reply.step == 5
    assert len(driver.sub) == 3  # none after the runaway
    message = reply.message
    assert message.startswith('DOF 1 (vertical), force-controlled: measured stroke 0.3 m')
    assert 'exceeds max_displacement 0.25 m' in message
    assert 'at force ramp sub-step 3 of 5' in message and '\n' not in message
    assert bridge.state == 'holding' and driver.hold_count == 1
    assert bridge.held_force == (0.0, 9000.0)  # the last commanded force
    # held: the next command moves nothing
    again = mixed(bridge, 6, 0.01, 15000.0)
    assert again is not None and again.status is LIMIT and len(driver.sub) == 3


def test_the_force_controlled_stroke_change_within_the_step_is_limited_by_max_increment() -> None:
    # 0.04 m per sub-step: 0.12 m at the 3rd sub-step > max_increment 0.1 (within 0.25)
    driver = ForceDriver(stroke=lambda n, dof, x: 0.04 * n if dof == 1 else x)
    bridge = bridge_with(driver, limits(max_increment=0.1))
    reply = mixed(bridge, 1, 0.0, 15000.0)
    assert reply is not None and reply.status is LIMIT
    assert len(driver.sub) == 3
    assert 'DOF 1 (vertical), force-controlled: stroke change 0.12 m within the step' in (
        reply.message)
    assert 'from 0 m to 0.12 m' in reply.message
    assert 'exceeds max_increment 0.1 m at force ramp sub-step 3 of 5' in reply.message


def test_the_stroke_change_counts_from_where_the_step_began() -> None:
    # each step moves the vertical stroke 0.08 m (within max_increment 0.1) although it is
    # 0.16 m from zero at the second step: only the change within the step counts
    driver = ForceDriver(stroke=lambda n, dof, x: 0.08 * n if dof == 1 else x)
    bridge = bridge_with(driver, limits(max_increment=0.1, max_force_increment=0.0))
    for step, load in enumerate((1000.0, 2000.0), start=1):
        reply = mixed(bridge, step, 0.0, load)
        assert reply is not None and reply.status is OK, reply
    assert reply.measured_displacement[1] == pytest.approx(0.16)
    reply = mixed(bridge, 3, 0.0, 3000.0)  # 0.24 m: fine; a 4th would be 0.32 > 0.25
    assert reply is not None and reply.status is OK
    reply = mixed(bridge, 4, 0.0, 4000.0)
    assert reply is not None and reply.status is LIMIT and 'max_displacement' in reply.message


def test_a_measured_force_beyond_max_force_mid_ramp_holds() -> None:
    class Overshoot(ForceDriver):
        def command_force(self, step: StepId, target: Sequence[float],
                          control_mode: Sequence[int], target_force: Sequence[float]) -> None:
            forces = list(target_force)
            if len(self.sub) == 1:
                forces[1] = 25000.0  # the load cell reads beyond max_force at sub-step 2
            super().command_force(step, target, control_mode, forces)

    driver = Overshoot()
    bridge = bridge_with(driver)
    reply = mixed(bridge, 1, 0.0, 9000.0)
    assert reply is not None and reply.status is LIMIT
    assert len(driver.sub) == 2
    assert 'DOF 1 (vertical): measured force 25000 N exceeds max_force 20000 N' in reply.message
    assert reply.message.endswith('at force ramp sub-step 2 of 3')


def test_tracking_is_checked_on_the_displacement_controlled_dofs_only() -> None:
    lim = limits(tracking_tolerance=0.003)
    ok = bridge_with(ForceDriver(), lim)
    reply = mixed(ok, 1, 0.01, 3000.0)
    assert reply is not None and reply.status is OK  # vertical stroke 0.03 != target 0.0
    # the horizontal lags more at each sub-step: 0.004 m > 0.003 m at the 2nd
    driver = ForceDriver(stroke=lambda n, dof, x: x - 0.002 * n if dof == 0 else x)
    bridge = bridge_with(driver, lim)
    reply = mixed(bridge, 1, 0.01, 9000.0)
    assert reply is not None and reply.status is FAULT and len(driver.sub) == 2
    assert 'DOF 0 (horizontal): tracking error 0.004 m' in reply.message


def test_a_driver_failing_mid_ramp_is_a_fault_and_holds() -> None:
    class Failing(ForceDriver):
        def command_force(self, step: StepId, target: Sequence[float],
                          control_mode: Sequence[int], target_force: Sequence[float]) -> None:
            if len(self.sub) == 1:
                msg = 'valve'
                raise DriverError(msg)
            super().command_force(step, target, control_mode, target_force)

    driver = Failing()
    bridge = bridge_with(driver)
    reply = mixed(bridge, 1, 0.0, 9000.0)
    assert reply is not None and reply.status is FAULT
    assert reply.message == ('driver command_force() failed at force ramp sub-step 2 of 3: '
                             'DriverError: valve')


# -- deactivation ---------------------------------------------------------------------------------
def test_ramp_down_takes_the_force_to_zero_in_substeps_continuing_the_numbering() -> None:
    driver = ForceDriver()
    bridge = bridge_with(driver)  # max_force_increment 3000
    mixed(bridge, StepKey(7, 2), 0.01, 10000.0)  # 4 sub-steps (7, 2, 0..3)
    del driver.sub[:]
    note = bridge.ramp_down()
    assert note.startswith('ramping force down to 0 N in 4 sub-steps')
    assert 'DOF 1 (vertical) at 10000 N' in note
    assert [sub[3][1] for sub in driver.sub] == [7500.0, 5000.0, 2500.0, 0.0]  # never a jump
    assert [sub[0] for sub in driver.sub] == [(7, 2, s) for s in range(4, 8)]
    assert all(sub[1][0] == 0.01 and sub[2] == (D, F) for sub in driver.sub)  # held in place
    assert bridge.held_force == (0.0, 0.0) and bridge.state == 'ready'
    assert not bridge.ramping_down
    assert bridge.ramp_down_note == 'ramped force down to 0 N in 4 sub-steps'
    assert driver.plain == [] and driver.hold_count == 0
    assert bridge.ramp_down() == ''  # nothing held any more
    # the sub-step keys a specimen sees: all new, in order
    keys = [force_substep_key((7, 2, s)) for s in range(8)]
    assert keys == sorted(set(keys)) and keys[0] == (7, 2 * SUBSTEP_STRIDE)


def test_ramp_down_with_an_asynchronous_driver_continues_as_answers_arrive() -> None:
    driver = ForceDriver(asynchronous=True)
    bridge = bridge_with(driver)
    replies: list[Feedback] = []
    bridge.set_reply_callback(replies.append)
    mixed(bridge, 1, 0.0, 6000.0)
    driver.answer()
    driver.answer()
    assert len(replies) == 1 and replies[0].status is OK
    note = bridge.ramp_down()
    assert 'in 2 sub-steps' in note and bridge.ramping_down
    assert mixed(bridge, 2, 0.0, 6000.0) is None  # nothing else moves meanwhile
    driver.answer()
    assert bridge.ramping_down and driver.sub[-1][3][1] == 0.0
    driver.answer()
    assert not bridge.ramping_down and bridge.held_force == (0.0, 0.0)
    assert [sub[3][1] for sub in driver.sub] == [3000.0, 6000.0, 3000.0, 0.0]
    assert len(replies) == 1  # a ramp-down answers no step


def test_ramp_down_checks_each_substep_and_a_runaway_stops_it() -> None:
    driver = ForceDriver(stroke=lambda n, dof, x: (0.05 * n if n > 3 else x) if dof == 1 else x)
    bridge = bridge_with(driver, limits(max_increment=0.1))
    mixed(bridge, 1, 0.0, 9000.0)  # 3 sub-steps to 0.09 m, then the ramp-down runs away: 0.2
    bridge.ramp_down()
    assert bridge.state == 'holding'
    assert len(driver.sub) == 4
    assert bridge.ramp_down_note.startswith('force ramp-down stopped: DOF 1 (vertical), '
                                            'force-controlled: stroke change')
    assert 'at force ramp-down sub-step 1 of 3' in bridge.ramp_down_note


def test_no_ramp_down_while_holding_the_forces_stay_and_the_note_says_so() -> None:
    driver = ForceDriver()
    bridge = bridge_with(driver)
    mixed(bridge, 1, 0.0, 6000.0)
    bridge.emergency_stop('button')
    count = len(driver.sub)
    note = bridge.ramp_down()
    assert note.startswith('force not ramped down (holding: emergency stop: button)')
    assert 'DOF 1 (vertical) at 6000 N kept' in note
    assert len(driver.sub) == count and bridge.held_force == (0.0, 6000.0)


def test_no_ramp_down_after_a_displacement_only_command() -> None:
    driver = ForceDriver()
    bridge = bridge_with(driver)
    mixed(bridge, 1, 0.0, 6000.0)
    bridge.handle_command('t', 2, (0.0, 0.06))  # both displacement-controlled now
    assert bridge.ramp_down() == '' and driver.plain == [(2, (0.0, 0.06))]


# -- plain commands and drivers without force control ---------------------------------------------
def spring(x: list[float]) -> list[float]:
    return [1000.0 * v for v in x]


def plain_run(**kwargs: object) -> tuple[list[Feedback | None], list[object], int]:
    driver = LoopbackDriver(spring, 2)
    driver.open()
    bridge = ActuatorBridge(driver, SafetyLimits(max_displacement=0.25, max_increment=0.125,
                                                 max_force=100.0), ['a', 'b'])
    replies = [bridge.handle_command('t', step, target, **kwargs)  # type: ignore[arg-type]
               for step, target in enumerate([(0.0, 0.0), (0.05, -0.05), (0.05, -0.05),
                                              (0.1, 0.0), (0.2, 0.0)])]
    return replies, list(driver.commands), driver.hold_count


def test_a_displacement_only_command_behaves_exactly_as_before() -> None:
    before = plain_run()
    # closed forms: f = 1000 x; 100 N is exactly max_force; 0.2 - 0.1 is within
    # max_increment but |f| = 200 N > max_force 100 N holds
    replies, commands, holds = before
    assert [r.status if r else None for r in replies] == [OK, OK, OK, OK, LIMIT]
    assert replies[1] is not None and replies[1].restoring_force == (50.0, -50.0)
    assert len(commands) == 5 and holds == 1
    assert plain_run(control_mode=(), target_force=()) == before
    assert plain_run(control_mode=(D, D), target_force=(0.0, 0.0)) == before


@pytest.mark.parametrize('driver', [
    GenericTCPDriver('127.0.0.1', 1, n_dof=2),
    OpenSeesAdapterDriver('127.0.0.1', 1, 2),
    LoopbackDriver(spring, 2),
], ids=['generic_tcp', 'opensees_adapter', 'loopback'])
def test_a_mixed_command_to_a_driver_without_force_control_is_a_one_line_fault(
        driver: ActuatorDriver) -> None:
    bridge = ActuatorBridge(driver, limits(), list(NAMES))
    reply = mixed(bridge, 1, 0.0, 1000.0)
    assert reply is not None and reply.status is FAULT
    name = driver.driver_name or type(driver).__name__
    assert reply.message.startswith(f'driver {name}: force control not supported; ')
    assert '\n' not in reply.message and bridge.state == 'holding'
    assert getattr(driver, 'commands', []) == []
    with pytest.raises(DriverError, match=f'driver {name}: force control not supported'):
        driver.command_force((1, 0), [0.0, 0.0], [D, F], [0.0, 1.0])


@pytest.mark.parametrize('cls', [EmulatorDriver, DaqmxDriver], ids=['emulator', 'daqmx'])
def test_the_emulator_and_daqmx_refuse_force_control(cls: type[ActuatorDriver]) -> None:
    driver = cls.__new__(cls)  # the refusal does not depend on the configuration
    problem = driver.force_control_problem()
    assert problem is not None and problem.startswith('force control not supported; ')
    assert cls.driver_name in ('emulator', 'daqmx')


# -- the key scheme and the simulated specimen ----------------------------------------------------
def test_force_substep_keys_are_new_and_in_order_across_substeps_iterations_and_steps() -> None:
    ids = [(4, 9, 3), (5, 0, 0), (5, 0, 1), (5, 0, 65535), (5, 1, 0), (5, 1, 2), (6, 0, 0)]
    keys = [force_substep_key(i) for i in ids]
    assert keys == sorted(keys) and len(set(keys)) == len(keys)
    assert force_substep_key((5, 1, 2)) == (5, 65538)
    assert force_substep_key((5, 2)) == (5, 2)  # an int step: iteration 0
    with pytest.raises(DriverError, match='at most 65536 sub-steps'):
        force_substep_key((5, 0, 65536))
    with pytest.raises(DriverError, match='iteration 65536'):
        force_substep_key((5, 65536, 0))


class SpecimenDriver(ActuatorDriver):
    """Forwards each move to a SpecimenServer keyed like ``sim_servo`` does (synchronous)."""

    driver_name = 'specimen'

    def __init__(self, server: SpecimenServer) -> None:
        super().__init__()
        self.server = server
        self.keys: list[tuple[int, int]] = []

    @property
    def n_dof(self) -> int:
        return self.server.specimen.n_dof

    def force_control_problem(self) -> str | None:
        return None

    def command(self, step: StepId, target: Sequence[float]) -> None:
        number, iteration = step if isinstance(step, tuple) else (step, 0)
        self._answer(step, self.server.handle('t', number, target, iteration=iteration))

    def command_force(self, step: StepId, target: Sequence[float],
                      control_mode: Sequence[int], target_force: Sequence[float]) -> None:
        number, iteration = force_substep_key(step)
        self.keys.append((number, iteration))
        self._answer(step, self.server.handle('t', number, target, iteration=iteration,
                                              control_mode=control_mode,
                                              target_force=target_force))

    def _answer(self, step: StepId, answer: object) -> None:
        assert answer is not None and answer.status is OK, answer  # type: ignore[attr-defined]
        self._emit(ActuatorMeasurement(
            step, tuple(answer.measured_displacement),  # type: ignore[attr-defined]
            tuple(answer.restoring_force)))  # type: ignore[attr-defined]

    def hold(self) -> None:
        pass

    def position(self) -> list[float]:
        return list(self.server.position)


class CountingColumn(ColumnSpecimen):
    def __init__(self) -> None:
        super().__init__(BilinearKinematic(1.0e6, 3.0e4, -0.02), 3.0, 1.0e9)
        self.commits: list[tuple[float, float]] = []

    def commit(self) -> None:
        super().commit()
        self.commits.append(self.committed_displacement())


def test_the_specimen_sees_the_bridges_substeps_as_its_own_ramps_states_bit_for_bit() -> None:
    increment = 2500.0
    through_bridge = SpecimenServer(CountingColumn(), max_force_increment=increment)
    driver = SpecimenDriver(through_bridge)
    bridge = ActuatorBridge(driver, SafetyLimits(
        max_displacement=0.1, max_increment=0.01, max_force=6.0e4,
        max_force_increment=increment), ['horizontal', 'vertical'])
    direct = SpecimenServer(CountingColumn(), max_force_increment=increment)
    commands = [(StepKey(0, 0), 0.0, -24950.0), (StepKey(1, 0), 0.002, -24950.0),
                (StepKey(2, 0), 0.004, -30000.0), (StepKey(2, 1), 0.0041, -30000.0),
                (StepKey(3, 0), 0.003, -24950.0)]
    for key, u, load in commands:
        v = direct.position[1]  # a force-controlled DOF's target: the last measured
        expected = direct.handle('t', key.step, (u, v), iteration=key.iteration,
                                 control_mode=(D, F), target_force=(0.0, load))
        reply = bridge.handle_command('t', key, (u, v), control_mode=(D, F),
                                      target_force=(0.0, load))
        assert reply is not None and reply.status is OK, reply
        assert expected is not None
        assert reply.key == key
        assert reply.measured_displacement == expected.measured_displacement  # bit for bit
        assert reply.restoring_force == expected.restoring_force
    assert through_bridge.specimen.commits == direct.specimen.commits  # every state
    assert len(direct.specimen.commits) == 10 + 1 + 3 + 1 + 3
    assert through_bridge.ramp_substeps == 0  # each bridge sub-step was one state
    assert driver.keys == sorted(set(driver.keys))
    assert through_bridge.held == direct.held == bridge.held_force


# -- the parameter --------------------------------------------------------------------------------
def test_max_force_increment_is_validated_like_the_other_limits() -> None:
    base = {'max_displacement': 0.1, 'max_increment': 0.01, 'max_force': 1.0}
    assert SafetyLimits.from_mapping(base).max_force_increment == 0.0
    assert SafetyLimits.from_mapping({**base, 'max_force_increment': 250}).max_force_increment \
        == 250.0
    for bad in (-1.0, math.inf, math.nan, True, '5', None):
        with pytest.raises(BridgeConfigError, match=r'^bridge: max_force_increment must be a '
                                                    r'finite number >= 0 \(0 = off\)'):
            SafetyLimits.from_mapping({**base, 'max_force_increment': bad}, source='bridge')
    with pytest.raises(BridgeConfigError, match='max_force_increment'):
        SafetyLimits(0.1, 0.01, 1.0, max_force_increment=-5.0)


def test_a_restarted_bridge_ramps_from_the_load_the_specimen_carries() -> None:
    """A bridge restarted mid-test (the column carries 12,000 N) adopts the measured forces:
    holding the load is one sub-step at the load, a change ramps from it — never from 0 N."""
    driver = ForceDriver()
    bridge = bridge_with(driver)  # max_force_increment 3000
    assert bridge.adopt_held_force((5.0, 12000.0))
    assert bridge.held_force == (5.0, 12000.0)
    reply = mixed(bridge, 7, 0.0, 12000.0)
    assert reply is not None and reply.status is OK
    assert [sub[3][1] for sub in driver.sub] == [12000.0]
    del driver.sub[:]
    mixed(bridge, 8, 0.0, 6000.0)
    assert [sub[3][1] for sub in driver.sub] == [9000.0, 6000.0]
    # Once it commanded a force, a measurement no longer changes what it holds.
    assert not bridge.adopt_held_force((0.0, 0.0))
    assert bridge.held_force == (5.0, 6000.0)  # the horizontal one was never force-controlled
    fresh = bridge_with(ForceDriver())
    assert not fresh.adopt_held_force((0.0, math.nan))
    assert not fresh.adopt_held_force((1.0,))
    assert fresh.held_force == (0.0, 0.0)
