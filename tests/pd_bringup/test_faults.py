"""The fault plan and the fault injector (pure: no ROS, a fake clock).

* a plan parses from its one-line form and reads back from its string; every bad item,
  out-of-range value and a sum of probabilities above 1 is refused in one line naming it;
* the fates are deterministic per seed and direction (the n-th message always meets the same
  fate, whatever its timing; a restored injector continues the sequence), and each fate's
  frequency is its probability;
* delayed messages are released in order of their release time, after at most ``delay_s``,
  and may be overtaken; a reordered message goes out right after the next one, or on its own
  after ``delay_s``;
* the counters add up (what goes in = what goes out + dropped - duplicated + held), and the
  proxies' reports are summed into ``summary.json``.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import pytest

from pd_bringup.faults import (
    COUNTERS,
    DEFAULT_DELAY_S,
    Fate,
    FaultInjector,
    FaultPlan,
    FaultPlanError,
    attach_reports,
    fault_summary,
    proxy_command,
)

FULL = 'drop=0.1,duplicate=0.1,delay=0.1,reorder=0.1,delay_s=0.05,seed=1'


def scripted(fates: Iterable[Fate], plan: FaultPlan | None = None) -> FaultInjector[str]:
    """An injector whose fates are ``fates`` (holds as the plan's ``delay_s``)."""
    injector: FaultInjector[str] = FaultInjector(plan or FaultPlan(), 'scripted')
    queue = iter(fates)
    delay_s = injector.plan.delay_s

    def decide() -> tuple[Fate, float]:
        fate = next(queue)
        return fate, delay_s if fate in (Fate.DELAY, Fate.REORDER) else 0.0

    injector.decide = decide  # type: ignore[method-assign]
    return injector


def fates(injector: FaultInjector[Any], n: int) -> list[tuple[Fate, float]]:
    return [injector.decide() for _ in range(n)]


# -- the plan ----------------------------------------------------------------------------------
def test_plan_parses_every_item_and_reads_back_from_its_string() -> None:
    plan = FaultPlan.parse(FULL)
    assert plan == FaultPlan(drop=0.1, duplicate=0.1, delay=0.1, reorder=0.1, delay_s=0.05,
                             seed=1)
    assert str(plan) == FULL
    assert FaultPlan.parse(str(plan)) == plan
    assert plan.as_dict() == {'drop': 0.1, 'duplicate': 0.1, 'delay': 0.1, 'reorder': 0.1,
                              'delay_s': 0.05, 'seed': 1}
    assert math.isclose(plan.total, 0.4)
    assert not plan.transparent
    # Spaces, any order; names not given keep their defaults.
    partial = FaultPlan.parse(' seed = 7 , drop=0.25 ')
    assert partial == FaultPlan(drop=0.25, seed=7)
    assert partial.delay_s == DEFAULT_DELAY_S
    # No faults.
    for text in ('', 'none', ' None '):
        assert FaultPlan.parse(text).transparent
    # Probabilities may add up to exactly 1; a value of many digits survives the string.
    assert FaultPlan.parse('drop=0.25,duplicate=0.25,delay=0.25,reorder=0.25').total == 1.0
    precise = FaultPlan.parse('drop=0.123456789,delay_s=1e-3')
    assert FaultPlan.parse(str(precise)) == precise


@pytest.mark.parametrize(('text', 'message'), [
    ('drop', r"^fault plan: item 'drop': expected name=value$"),
    ('drop=', r"^fault plan: item 'drop=': expected name=value$"),
    ('=0.1', r"^fault plan: item '=0\.1': expected name=value$"),
    ('loss=0.1', (r"^fault plan: item 'loss=0\.1': unknown name 'loss' \(drop, duplicate, "
                  r'delay, reorder, delay_s, seed\)$')),
    ('drop=0.1,drop=0.2', r"^fault plan: item 'drop=0\.2': drop is given twice$"),
    ('drop=a lot', r"^fault plan: item 'drop=a lot': 'a lot' is not a number$"),
    ('seed=1.5', r"^fault plan: item 'seed=1\.5': '1\.5' is not an integer$"),
    ('seed=-1', r"^fault plan: item 'seed=-1': the seed must be a non-negative integer$"),
    ('drop=1.5', r"^fault plan: item 'drop=1\.5': a probability must be in \[0, 1\]$"),
    ('reorder=-0.1', r"^fault plan: item 'reorder=-0\.1': a probability must be in \[0, 1\]$"),
    ('delay=nan', r"^fault plan: item 'delay=nan': must be a finite number$"),
    ('duplicate=inf', r"^fault plan: item 'duplicate=inf': must be a finite number$"),
    ('delay_s=0', r"^fault plan: item 'delay_s=0': the largest delay must be positive"),
    ('delay_s=-0.05', r"^fault plan: item 'delay_s=-0\.05': the largest delay must be"),
    ('drop=0.1,,delay=0.1', r"^fault plan 'drop=0\.1,,delay=0\.1': an empty item"),
    ('drop=0.1,', r"^fault plan 'drop=0\.1,': an empty item"),
    ('drop=0.5,duplicate=0.3,delay=0.3', (r"^fault plan 'drop=0\.5,duplicate=0\.3,delay=0\.3': "
                                          r'the probabilities add up to 1\.1, more than 1')),
])
def test_bad_plans_are_refused_in_one_line_naming_the_item(text: str, message: str) -> None:
    with pytest.raises(FaultPlanError, match=message) as caught:
        FaultPlan.parse(text)
    assert '\n' not in str(caught.value)
    assert isinstance(caught.value, ValueError)


def test_a_plan_built_directly_is_checked_too() -> None:
    with pytest.raises(FaultPlanError, match=r'^fault plan: the probabilities add up to 1\.2'):
        FaultPlan(drop=0.6, delay=0.6)
    with pytest.raises(FaultPlanError, match=r'^fault plan: seed=-2: the seed must be'):
        FaultPlan(seed=-2)
    with pytest.raises(FaultPlanError, match=r'^fault plan: seed=True: the seed must be'):
        FaultPlan(seed=True)
    with pytest.raises(FaultPlanError, match=r'^fault plan: delay_s=0\.0: the largest delay'):
        FaultPlan(delay_s=0.0)
    with pytest.raises(FaultPlanError, match=r'^fault plan: drop=nan: must be a finite number'):
        FaultPlan(drop=math.nan)


def test_proxy_command_checks_the_plan_and_passes_it_canonical() -> None:
    with pytest.raises(FaultPlanError, match=r"^fault plan: item 'drop=2'"):
        proxy_command('/pd', '/pd/behind', 'drop=2', Path('faults.json'))
    command = proxy_command('/pd', '/pd/behind', 'seed=4, drop=0.2', Path('/run/faults.json'))
    assert Path(command[0]).name == 'fault_proxy'
    plan = 'drop=0.2,duplicate=0,delay=0,reorder=0,delay_s=0.05,seed=4'
    assert command[1:] == ['--ros-args', '-p', 'front:=/pd', '-p', 'back:=/pd/behind',
                           '-p', f'faults:={plan}', '-p', 'report_file:=/run/faults.json']


# -- determinism ---------------------------------------------------------------------------------
def test_fates_are_deterministic_per_seed_and_direction() -> None:
    plan = FaultPlan.parse(FULL)
    first = fates(FaultInjector(plan, '/pd/step_command'), 500)
    assert fates(FaultInjector(plan, '/pd/step_command'), 500) == first
    # Another direction, another seed: other fates.
    assert fates(FaultInjector(plan, '/pd/behind/step_feedback'), 500) != first
    other_seed = FaultPlan(drop=0.1, duplicate=0.1, delay=0.1, reorder=0.1, seed=2)
    assert fates(FaultInjector(other_seed, '/pd/step_command'), 500) != first


def test_the_nth_message_meets_the_same_fate_whatever_its_timing() -> None:
    plan = FaultPlan.parse(FULL)
    slow: FaultInjector[int] = FaultInjector(plan, 'x')
    fast: FaultInjector[int] = FaultInjector(plan, 'x')
    sent_slow: list[int] = []
    sent_fast: list[int] = []
    for n in range(400):
        sent_slow += slow.submit(n, now=n * 1.0)  # every hold has expired before the next
        sent_fast += fast.submit(n, now=n * 1e-3)
    sent_slow += slow.poll(math.inf)
    sent_fast += fast.poll(math.inf)
    assert slow.counts['received'] == fast.counts['received'] == 400
    for kind in ('dropped', 'duplicated', 'delayed', 'reordered'):
        assert slow.counts[kind] == fast.counts[kind] > 0
    # The same messages get through (in another order: the holds overlap when fast).
    assert Counter(sent_slow) == Counter(sent_fast)


def test_a_restored_injector_continues_the_fates_and_the_counters() -> None:
    plan = FaultPlan.parse(FULL)
    reference: FaultInjector[int] = FaultInjector(plan, 'x')
    before: FaultInjector[int] = FaultInjector(plan, 'x')
    for n in range(150):
        reference.submit(n, now=float(n))
        before.submit(n, now=float(n))
    reference.poll(math.inf)
    before.poll(math.inf)
    after: FaultInjector[int] = FaultInjector(plan, 'x')
    after.restore(json.loads(json.dumps(before.report())))  # through its JSON report
    assert after.counts == before.counts
    assert fates(after, 100) == fates(reference, 100)
    # Only before the first message, and only sane counters.
    with pytest.raises(ValueError, match='restore before the first message only'):
        before.restore(before.counts)
    with pytest.raises(ValueError, match=r'counter received=-1: not a non-negative integer'):
        FaultInjector(plan, 'x').restore({'received': -1})
    with pytest.raises(ValueError, match=r"counter dropped='3': not a non-negative integer"):
        FaultInjector(plan, 'x').restore({'dropped': '3'})


# -- frequencies ---------------------------------------------------------------------------------
def test_each_fate_happens_with_its_probability() -> None:
    plan = FaultPlan(drop=0.1, duplicate=0.2, delay=0.15, reorder=0.05, delay_s=0.2, seed=11)
    n = 40_000
    drawn = fates(FaultInjector(plan, 'x'), n)
    counts = Counter(fate for fate, _ in drawn)
    expected = {Fate.DROP: 0.1, Fate.DUPLICATE: 0.2, Fate.DELAY: 0.15, Fate.REORDER: 0.05,
                Fate.FORWARD: 0.5}
    for fate, probability in expected.items():
        sigma = math.sqrt(probability * (1.0 - probability) / n)
        assert abs(counts[fate] / n - probability) < 5 * sigma, (fate, counts[fate])
    # A delay is uniform in (0, delay_s]; a reordered message is held delay_s at most; the
    # others are not held.
    delays = [hold for fate, hold in drawn if fate is Fate.DELAY]
    assert min(delays) > 0.0 and max(delays) <= plan.delay_s
    assert abs(sum(delays) / len(delays) - plan.delay_s / 2) < 0.05 * plan.delay_s
    assert {hold for fate, hold in drawn if fate is Fate.REORDER} == {plan.delay_s}
    assert {hold for fate, hold in drawn if fate in (Fate.FORWARD, Fate.DROP,
                                                     Fate.DUPLICATE)} == {0.0}


def test_probabilities_of_zero_and_of_one() -> None:
    transparent: FaultInjector[int] = FaultInjector(FaultPlan(), 'x')
    assert [transparent.submit(n, float(n)) for n in range(100)] == [[n] for n in range(100)]
    assert transparent.counts['forwarded'] == 100
    always = FaultInjector(FaultPlan(drop=1.0), 'x')
    assert all(always.submit(n, 0.0) == [] for n in range(100))
    assert always.counts['dropped'] == 100
    no_forward = FaultPlan.parse('drop=0.25,duplicate=0.25,delay=0.25,reorder=0.25')
    assert Fate.FORWARD not in {fate for fate, _ in fates(FaultInjector(no_forward, 'x'),
                                                          2000)}


# -- delay -------------------------------------------------------------------------------------
def test_delayed_messages_are_released_in_order_of_their_release_time() -> None:
    plan = FaultPlan(delay=1.0, delay_s=0.1, seed=5)
    holds = [hold for _, hold in fates(FaultInjector(plan, 'x'), 20)]
    due = {n: 0.01 * n + hold for n, hold in enumerate(holds)}
    injector: FaultInjector[int] = FaultInjector(plan, 'x')
    released: list[tuple[float, int]] = []
    clock, tick = 0.0, 0.001

    def spin_until(t: float) -> None:  # the proxy's spin loop polls in between
        nonlocal clock
        while clock + tick <= t:
            clock += tick
            released.extend((clock, m) for m in injector.poll(clock))

    for n in range(20):
        spin_until(0.01 * n)
        released.extend((0.01 * n, m) for m in injector.submit(n, 0.01 * n))
    assert injector.held == 20 - len(released) > 0
    assert injector.next_release() == pytest.approx(
        min(due[n] for n in range(20) if n not in {m for _, m in released}))
    spin_until(1.0)
    assert injector.held == 0 and injector.next_release() is None
    # Each went out at the first poll after its release time, never before; the order is that
    # of the release times, so later messages overtook longer-held ones.
    assert sorted(m for _, m in released) == list(range(20))
    for when, m in released:
        assert due[m] <= when + 1e-12 and when < due[m] + tick + 1e-9
    order = [m for _, m in released]
    assert order == sorted(range(20), key=lambda m: due[m])
    assert order != list(range(20))
    assert injector.counts['delayed'] == injector.counts['forwarded'] == 20


def test_a_forwarded_message_overtakes_a_delayed_one() -> None:
    injector = scripted([Fate.DELAY, Fate.FORWARD], FaultPlan(delay_s=0.05))
    assert injector.submit('a', 0.0) == []
    assert injector.next_release() == pytest.approx(0.05)
    assert injector.submit('b', 0.01) == ['b']
    assert injector.poll(0.049) == []
    assert injector.poll(0.05) == ['a']
    assert injector.held == 0


def test_due_messages_go_out_before_the_one_submitted() -> None:
    injector = scripted([Fate.DELAY, Fate.FORWARD], FaultPlan(delay_s=0.05))
    injector.submit('a', 0.0)
    assert injector.submit('b', 0.2) == ['a', 'b']  # a's delay ran out before b came


# -- reorder -------------------------------------------------------------------------------------
def test_a_reordered_message_goes_out_right_after_the_next_one() -> None:
    injector = scripted([Fate.REORDER, Fate.FORWARD])
    assert injector.submit('a', 0.0) == []
    assert injector.held == 1
    assert injector.submit('b', 0.01) == ['b', 'a']
    assert injector.held == 0
    counts = injector.counts
    assert (counts['reordered'], counts['reorder_swapped'], counts['forwarded']) == (1, 1, 2)
    duplicated = scripted([Fate.REORDER, Fate.DUPLICATE])
    duplicated.submit('a', 0.0)
    assert duplicated.submit('b', 0.01) == ['b', 'b', 'a']
    assert duplicated.counts['reorder_swapped'] == 1


@pytest.mark.parametrize('next_fate', [Fate.DROP, Fate.DELAY, Fate.REORDER])
def test_a_reordered_message_is_released_when_nothing_overtakes_it(next_fate: Fate) -> None:
    injector = scripted([Fate.REORDER, next_fate])
    injector.submit('a', 0.0)
    assert injector.submit('b', 0.01) == ['a']
    assert injector.counts['reorder_released'] == 1
    assert injector.counts['reorder_swapped'] == 0
    assert injector.held == (0 if next_fate is Fate.DROP else 1)  # b held (delay or reorder)
    assert injector.poll(1.0) == ([] if next_fate is Fate.DROP else ['b'])


def test_a_reordered_message_expires_after_delay_s_without_another_message() -> None:
    injector = scripted([Fate.REORDER, Fate.FORWARD], FaultPlan(delay_s=0.05))
    injector.submit('a', 0.0)
    assert injector.next_release() == pytest.approx(0.05)
    assert injector.poll(0.0499) == []
    assert injector.poll(0.05) == ['a']
    assert injector.counts['reorder_expired'] == 1
    assert injector.next_release() is None
    assert injector.submit('b', 0.06) == ['b']  # nothing is waiting for it any more
    assert injector.counts['reorder_swapped'] == 0
    # Expired between two messages: it goes out first, when the next one comes.
    late = scripted([Fate.REORDER, Fate.FORWARD], FaultPlan(delay_s=0.05))
    late.submit('a', 0.0)
    assert late.submit('b', 0.2) == ['a', 'b']
    assert (late.counts['reorder_expired'], late.counts['reorder_swapped']) == (1, 0)


# -- counters ------------------------------------------------------------------------------------
def test_counters_add_up_and_every_message_is_accounted_for() -> None:
    injector: FaultInjector[int] = FaultInjector(FaultPlan.parse(FULL), 'x')
    sent: list[int] = []
    for n in range(2000):
        now = 0.013 * n
        sent += injector.poll(now - 0.006)
        sent += injector.submit(n, now)
        counts = injector.counts
        assert (counts['forwarded'] + injector.held
                == counts['received'] - counts['dropped'] + counts['duplicated'])
    sent += injector.poll(math.inf)
    counts = injector.counts
    assert counts['received'] == 2000
    assert counts['forwarded'] == len(sent) == 2000 - counts['dropped'] + counts['duplicated']
    assert counts['reordered'] == (counts['reorder_swapped'] + counts['reorder_released']
                                   + counts['reorder_expired'])
    copies = Counter(sent)
    assert sum(1 for n in range(2000) if copies[n] == 0) == counts['dropped']
    assert sum(1 for n in range(2000) if copies[n] == 2) == counts['duplicated']
    assert set(copies.values()) == {1, 2}
    report = injector.report()
    assert set(report) == {*COUNTERS, 'held'} and report['held'] == 0


def test_reports_are_summed_into_the_summary(tmp_path: Path) -> None:
    def report(scale: int) -> dict[str, object]:
        counts = {name: scale * (i + 1) for i, name in enumerate(COUNTERS)}
        return {'faults': 'drop=0.1', 'step_command': {**counts, 'held': 0},
                'step_feedback': {**counts, 'held': 1}, 'session': {'starts_forwarded': 1}}

    block = fault_summary({'fault_proxy[a]': report(1), 'fault_proxy[b]': report(10)},
                          {'fault_proxy[a]': 'faults-a.json'})
    assert block['plan'] == 'drop=0.1'
    assert block['totals']['received'] == 2 * 1 + 2 * 10
    assert block['totals']['reorder_expired'] == 2 * 9 + 2 * 90
    assert block['totals']['held'] == 2
    assert block['proxies']['fault_proxy[a]']['report'] == 'faults-a.json'
    assert block['proxies']['fault_proxy[b]']['report'] == ''

    summary = tmp_path / 'summary.json'
    summary.write_text(json.dumps({'state': 'finished', 'steps': 3}), encoding='utf-8')
    (tmp_path / 'faults.json').write_text(json.dumps(report(1)), encoding='utf-8')
    (tmp_path / 'bad.json').write_text('{', encoding='utf-8')
    files = {'fault_proxy': tmp_path / 'faults.json', 'broken': tmp_path / 'bad.json',
             'never_started': tmp_path / 'missing.json'}
    attached = attach_reports(summary, files)
    data = json.loads(summary.read_text(encoding='utf-8'))
    assert data['state'] == 'finished' and data['faults'] == attached
    assert attached is not None
    assert set(attached['proxies']) == {'fault_proxy', 'broken'}
    assert attached['proxies']['fault_proxy']['report'] == 'faults.json'
    assert attached['proxies']['broken']['error'].startswith('bad.json: unreadable')
    assert attached['totals']['received'] == 2
    assert attach_reports(summary, {'x': tmp_path / 'missing.json'}) is None
    # Without a summary.json (the integrator wrote none) the block is still made.
    assert attach_reports(tmp_path / 'none.json', {'p': tmp_path / 'faults.json'}) is not None
    assert not (tmp_path / 'none.json').exists()
