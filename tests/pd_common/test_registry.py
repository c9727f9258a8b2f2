"""The one registry pattern and the one parameter type (``pd_common.registry``)."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from importlib import metadata

import numpy as np
import pytest

from pd_common import registry as registry_module
from pd_common.registry import (
    GROUPS,
    Parameter,
    ParameterError,
    Registry,
    RegistryError,
    check_number,
    resolve_parameters,
)

#: Loaded by the fake entry points below (``test_registry:PLUGGED``).
PLUGGED = 'a plugged entry'
NOT_AN_INT = 'not an int'


@pytest.fixture
def entry_points(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[metadata.EntryPoint]]:
    """The installed entry points, replaced by the list the test fills."""
    points: list[metadata.EntryPoint] = []
    monkeypatch.setattr(registry_module, '_entry_points',
                        lambda group: tuple(point for point in points if point.group == group))
    yield points


def test_lookup_iteration_and_the_one_line_error() -> None:
    colours: Registry[int] = Registry('colour')
    colours.register('red', 1)
    colours.register('blue', 2)
    assert colours.lookup('blue') == 2 and colours['red'] == 1
    assert list(colours) == ['red', 'blue']  # registration order
    assert colours.names() == ('blue', 'red')  # sorted
    assert 'red' in colours and 'green' not in colours and len(colours) == 2
    with pytest.raises(RegistryError) as info:
        colours.lookup('green')
    assert str(info.value) == "unknown colour 'green' (known: blue, red)"
    with pytest.raises(RegistryError, match='unknown colour'):
        colours.lookup(['unhashable'])  # type: ignore[arg-type]


def test_register_refuses_bad_and_taken_names_and_what_admit_refuses() -> None:
    def admit(name: str, entry: object) -> int:
        if not isinstance(entry, int):
            msg = f'number {name}: expected an int'
            raise ValueError(msg)
        return entry

    numbers: Registry[int] = Registry('number', admit=admit, error=KeyError,
                                      unknown='no {kind} {name!r}; try {known}')
    numbers.register('one', 1)
    with pytest.raises(KeyError, match='number one: a number of that name is already'):
        numbers.register('one', 1)
    with pytest.raises(KeyError, match='must match'):
        numbers.register('One', 1)
    with pytest.raises(ValueError, match='expected an int'):
        numbers.register('two', 'two')
    with pytest.raises(KeyError, match="no number 'two'; try one"):
        numbers.lookup('two')


def test_added_and_copy_leave_the_registry_as_it_was() -> None:
    colours: Registry[int] = Registry('colour')
    colours.register('red', 1)
    with colours.added('green', 3):
        assert colours['green'] == 3
    assert 'green' not in colours
    twin = colours.copy()
    twin.register('blue', 2)
    assert 'blue' in twin and 'blue' not in colours


def test_plugins_load_lazily_once_and_a_broken_one_is_one_line(
        entry_points: list[metadata.EntryPoint], caplog: pytest.LogCaptureFixture) -> None:
    group = 'pd.test'
    entry_points.extend([
        metadata.EntryPoint('plugged', 'test_registry:PLUGGED', group),
        metadata.EntryPoint('missing', 'no_such_package.module:THING', group),
        metadata.EntryPoint('refused', 'test_registry:NOT_AN_INT', group),
        metadata.EntryPoint('other', 'test_registry:PLUGGED', 'pd.elsewhere'),
    ])

    def admit(name: str, entry: object) -> str:
        if entry == NOT_AN_INT:
            msg = f'thing {name}: refused'
            raise ValueError(msg)
        return str(entry)

    things: Registry[str] = Registry('thing', group, admit=admit)
    things.register('built_in', 'a built-in entry')
    assert things.loaded() == {'built_in': 'a built-in entry'}  # nothing loaded yet
    with caplog.at_level(logging.WARNING, logger='pd_common.registry'):
        assert list(things) == ['built_in', 'plugged']
        assert things.lookup('plugged') == PLUGGED
        assert things.names() == ('built_in', 'plugged')  # loaded once: no second warning
    lines = [record.getMessage() for record in caplog.records]
    assert len(lines) == 2
    assert all('\n' not in line and 'Traceback' not in line for line in lines)
    assert lines[0] == ('thing plug-in missing = no_such_package.module:THING (group pd.test) '
                        "not loaded: ModuleNotFoundError: No module named 'no_such_package'")
    assert lines[1].endswith('not loaded: ValueError: thing refused: refused')
    assert set(things.broken) == {'missing', 'refused'}
    with pytest.raises(RegistryError) as info:
        things.lookup('missing')
    assert str(info.value) == (
        "unknown thing 'missing' (known: built_in, plugged); its plug-in did not load: "
        "ModuleNotFoundError: No module named 'no_such_package'")


def test_a_plugin_does_not_replace_a_built_in(entry_points: list[metadata.EntryPoint],
                                              caplog: pytest.LogCaptureFixture) -> None:
    entry_points.append(metadata.EntryPoint('built_in', 'test_registry:PLUGGED', 'pd.test'))
    things: Registry[str] = Registry('thing', 'pd.test')
    things.register('built_in', 'mine')
    with caplog.at_level(logging.WARNING, logger='pd_common.registry'):
        assert things['built_in'] == 'mine'
    assert 'already registered' in things.broken['built_in']


def test_one_group_per_kind() -> None:
    assert dict(GROUPS) == {'scheme': 'pd.schemes', 'driver': 'pd.drivers',
                            'hysteresis model': 'pd.hysteresis',
                            'compensator': 'pd.compensators', 'plant model': 'pd.plants',
                            './pd command': 'pd.commands'}


# --------------------------------------------------------------------------- Parameter


def test_a_bounded_parameter() -> None:
    alpha = Parameter('alpha', -0.05, 'HHT alpha', low=-1.0 / 3.0, high=0.0)
    assert alpha.check(-0.1) == -0.1 and alpha.check(0) == 0.0
    assert alpha.check(2.0 / 3.0 - 1.0) == -1.0 / 3.0  # within rounding of the bound
    with pytest.raises(ParameterError) as info:
        alpha.check(0.5)
    assert str(info.value) == 'alpha: must be in [-0.333333, 0], got 0.5'
    assert info.value.parameter == 'alpha'
    assert info.value.reason == 'must be in [-0.333333, 0], got 0.5'
    with pytest.raises(ParameterError, match='expected a number'):
        alpha.check(True)
    opened = Parameter('beta', 0.25, 'Newmark beta', low=0.0, high=0.5, low_open=True)
    with pytest.raises(ParameterError, match=r'must be in \(0, 0.5\]'):
        opened.check(0.0)
    iterations = Parameter('iterations', 3, 'trials', low=1, high=10, integer=True)
    assert iterations.check(4.0) == 4 and iterations.check(np.int64(2)) == 2
    with pytest.raises(ParameterError, match=r'must be an integer in \[1, 10\], got 2.5'):
        iterations.check(2.5)
    with pytest.raises(ParameterError, match='expected an integer'):
        iterations.check('3')
    optional = Parameter('spurious', None, 'optional', low=-2.0, high=2.0)
    assert optional.check(None) is None


def test_a_switch_a_choice_and_a_parameter_typed_by_its_default() -> None:
    switch = Parameter('forward_only', True, 'a switch')
    assert switch.boolean and switch.check(np.bool_(False)) is False
    with pytest.raises(ParameterError, match='forward_only: expected true or false, got 1'):
        switch.check(1)
    clock = Parameter('clock', 'simulated', 'the clock', choices=('simulated', 'wall'))
    assert clock.check('wall') == 'wall'
    with pytest.raises(ParameterError, match='must be one of simulated, wall'):
        clock.check('fast')
    order = Parameter('order', 3, 'an int')
    assert order.check(2) == 2
    with pytest.raises(ParameterError, match=r'order: must be int, got 2\.0'):
        order.check(2.0)
    gain = Parameter('kp', 1.0, 'a float')
    assert gain.check(2) == 2.0 and isinstance(gain.check(2), float)
    with pytest.raises(ParameterError, match='kp: must be float'):
        gain.check(float('nan'))
    label = Parameter('label', 'a', 'a string')
    with pytest.raises(ParameterError, match='label: must be str'):
        label.check(1)


def test_a_declaration_is_checked() -> None:
    with pytest.raises(ParameterError, match='name must match'):
        Parameter('Rho', 1.0, 'x')
    with pytest.raises(ParameterError, match='default must be a bool, int, float, str or None'):
        Parameter('rho', [1.0], 'x')  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match='description must be a non-empty string'):
        Parameter('rho', 1.0, '')
    with pytest.raises(ParameterError, match='bounds and choices exclude each other'):
        Parameter('rho', 'a', 'x', low=0.0, choices=('a',))


def test_resolve_parameters() -> None:
    declared = (Parameter('stiffness', None, 'k', low=0.0, low_open=True, required=True),
                Parameter('factor', 1.0, 'f', low=0.0, high=10.0))
    assert resolve_parameters(declared, {'stiffness': 2}) == {'stiffness': 2.0, 'factor': 1.0}
    with pytest.raises(ParameterError, match='stiffness: missing'):
        resolve_parameters(declared, {})
    with pytest.raises(ParameterError) as info:
        resolve_parameters(declared, {'stiffness': 1.0, 'stifness': 1.0})
    assert str(info.value) == 'stifness: unknown parameter (parameters: stiffness, factor)'
    assert resolve_parameters(declared, {'stiffness': 'x'}, check=False)['stiffness'] == 'x'
    assert check_number(5, 'x') == 5.0
