"""Experimental setups: from an experimental element's DOFs to a site's actuator strokes.

As in OpenFresco's layering, an *experimental element* lives in the numerical model and has
*basic* DOFs (e.g. a story drift, or the translation and rotation of a column top); the
*setup* transforms them to the strokes of the actuators of its site and transforms what the
site measures (actuator displacements and forces) back to the element's basic DOFs:

* :meth:`ExperimentalSetup.actuator_targets` — basic trial displacement → actuator commands;
* :meth:`ExperimentalSetup.basic_displacement` — measured actuator displacements → basic;
* :meth:`ExperimentalSetup.basic_force` — measured actuator forces → basic forces
  (``f_b = Jᵀ f_a`` with ``J = ∂d_a/∂d_b``: exact by virtual work for pinned actuators).

Setups (``setup.type`` in the test file):

``one_to_one``
    one actuator per basic DOF, ``d_a = d_b``.
``rigid_link_2``
    two parallel actuators acting on a rigid link, for a translation ``u`` and a rotation
    ``θ`` (the link's basic DOFs, in this order). Actuator *i* is attached to the link at the
    distance ``a_i`` (``offsets``) from the reference point, measured along the link
    (perpendicular to the actuators); ``θ`` is positive when it moves the point at ``+a`` in
    the actuators' positive direction. ``geometry: linear`` (default) gives
    ``d_i = u + a_i θ``. ``geometry: nonlinear`` takes the actuators' rotation into account
    (``actuator_length`` L, from the reaction pin to the attachment point at rest):
    ``d_i = sqrt((L + u + a_i sin θ)² + (a_i (1 − cos θ))²) − L``; its inverse is found by
    Newton iterations.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError

__all__ = [
    'SETUP_TYPES',
    'ExperimentalSetup',
    'OneToOneSetup',
    'RigidLinkTwoActuators',
    'setup_from_config',
]


class ExperimentalSetup(abc.ABC):
    """Maps an element's basic DOFs to actuator DOFs and back."""

    #: Number of basic DOFs of the element.
    n_basic: int
    #: Number of actuators.
    n_actuators: int

    @abc.abstractmethod
    def actuator_targets(self, basic: np.ndarray) -> np.ndarray:
        """Actuator strokes [m] that impose the basic displacement ``basic``."""

    @abc.abstractmethod
    def jacobian(self, basic: np.ndarray) -> NDArray[np.float64]:
        """``∂ d_actuator / ∂ d_basic`` at ``basic`` (``n_actuators × n_basic``)."""

    def basic_displacement(self, actuator: np.ndarray) -> np.ndarray:
        """The basic displacement that produced the measured actuator strokes."""
        return np.linalg.solve(self.jacobian(np.zeros(self.n_basic)), actuator)

    def basic_force(
        self, actuator_force: NDArray[np.float64], basic: np.ndarray
    ) -> NDArray[np.float64]:
        """Basic forces equivalent to the actuator forces at ``basic`` (``Jᵀ f``)."""
        return self.jacobian(basic).T @ actuator_force


class OneToOneSetup(ExperimentalSetup):
    """One actuator per basic DOF: ``d_a = d_b``."""

    def __init__(self, n_basic: int) -> None:
        if n_basic < 1:
            msg = f'one_to_one setup: needs at least one DOF, got {n_basic}'
            raise ConfigError(msg)
        self.n_basic = n_basic
        self.n_actuators = n_basic
        self._identity = np.eye(n_basic)

    def actuator_targets(self, basic: np.ndarray) -> np.ndarray:
        return np.array(basic, dtype=float)

    def jacobian(self, basic: np.ndarray) -> NDArray[np.float64]:
        return self._identity

    def basic_displacement(self, actuator: np.ndarray) -> np.ndarray:
        return np.array(actuator, dtype=float)

    def basic_force(
        self, actuator_force: NDArray[np.float64], basic: np.ndarray
    ) -> NDArray[np.float64]:
        return np.array(actuator_force, dtype=float)


class RigidLinkTwoActuators(ExperimentalSetup):
    """Two parallel actuators on a rigid link: basic DOFs (u, θ) → two strokes.

    Args:
        offsets: ``(a_1, a_2)`` [m], attachment points along the link (distinct).
        geometry: ``'linear'`` (small rotations) or ``'nonlinear'`` (exact actuator geometry).
        actuator_length: L [m], pin-to-attachment length at rest (``nonlinear`` only).
    """

    NEWTON_TOLERANCE = 1e-14
    NEWTON_ITERATIONS = 50

    def __init__(self, offsets: Sequence[float], geometry: str = 'linear',
                 actuator_length: float | None = None) -> None:
        a = [float(value) for value in offsets]
        if len(a) != 2 or not all(math.isfinite(value) for value in a) or a[0] == a[1]:
            msg = ('rigid_link_2 setup: offsets must be two distinct finite numbers, '
                   f'got {offsets!r}')
            raise ConfigError(msg)
        if geometry not in ('linear', 'nonlinear'):
            msg = f"rigid_link_2 setup: geometry must be 'linear' or 'nonlinear', got {geometry!r}"
            raise ConfigError(msg)
        if geometry == 'nonlinear' and (actuator_length is None or not math.isfinite(
                actuator_length) or actuator_length <= 0.0):
            msg = ('rigid_link_2 setup: geometry nonlinear needs a positive actuator_length, '
                   f'got {actuator_length!r}')
            raise ConfigError(msg)
        self.n_basic = 2
        self.n_actuators = 2
        self.offsets = np.array(a)
        self.geometry = geometry
        self.actuator_length = actuator_length
        self._linear = np.array([[1.0, a[0]], [1.0, a[1]]])

    def _length(self) -> float:
        """L [m]: set (and positive) for the nonlinear geometry (checked on construction)."""
        if self.actuator_length is None:
            msg = 'rigid_link_2 setup: geometry nonlinear needs a positive actuator_length'
            raise ConfigError(msg)
        return float(self.actuator_length)

    def actuator_targets(self, basic: np.ndarray) -> np.ndarray:
        u, theta = float(basic[0]), float(basic[1])
        if self.geometry == 'linear':
            return u + self.offsets * theta
        length = self._length()
        along = length + u + self.offsets * math.sin(theta)
        across = self.offsets * (1.0 - math.cos(theta))
        return np.hypot(along, across) - length

    def jacobian(self, basic: np.ndarray) -> NDArray[np.float64]:
        if self.geometry == 'linear':
            return self._linear
        u, theta = float(basic[0]), float(basic[1])
        length = self._length()
        a = self.offsets
        along = length + u + a * math.sin(theta)
        across = a * (1.0 - math.cos(theta))
        stroke = np.hypot(along, across)
        d_u = along / stroke
        d_theta = (along * a * math.cos(theta) + across * a * math.sin(theta)) / stroke
        return np.column_stack((d_u, d_theta))

    def basic_displacement(self, actuator: np.ndarray) -> np.ndarray:
        actuator = np.asarray(actuator, dtype=float)
        basic = np.linalg.solve(self._linear, actuator)
        if self.geometry == 'linear':
            return basic
        for _ in range(self.NEWTON_ITERATIONS):
            residual = self.actuator_targets(basic) - actuator
            if float(np.max(np.abs(residual))) <= self.NEWTON_TOLERANCE * (
                    1.0 + float(np.max(np.abs(actuator)))):
                return basic
            basic = basic - np.linalg.solve(self.jacobian(basic), residual)
        msg = (f'rigid_link_2 setup: no (u, theta) found for the measured strokes '
               f'{actuator.tolist()!r}')
        raise ConfigError(msg)


SETUP_TYPES = ('one_to_one', 'rigid_link_2')


def setup_from_config(raw: Any, n_basic: int, where: str) -> ExperimentalSetup:
    """Build a setup from a test file's ``setup`` mapping (``None``: one-to-one).

    Raises:
        ConfigError: one line naming ``where`` (e.g. ``test.yaml: structure.elements[0].setup``).
    """
    if raw is None:
        raw = {'type': 'one_to_one'}
    if isinstance(raw, str):
        raw = {'type': raw}
    if not isinstance(raw, Mapping):
        msg = f'{where}: must be a mapping with a type, got {raw!r}'
        raise ConfigError(msg)
    kind = raw.get('type', 'one_to_one')
    allowed = {'one_to_one': {'type'},
               'rigid_link_2': {'type', 'offsets', 'geometry', 'actuator_length'}}
    if kind not in allowed:
        msg = f'{where}.type: must be one of {", ".join(SETUP_TYPES)}, got {kind!r}'
        raise ConfigError(msg)
    unknown = sorted(set(raw) - allowed[kind])
    if unknown:
        msg = f'{where}.{unknown[0]}: unknown parameter for a {kind} setup'
        raise ConfigError(msg)
    try:
        if kind == 'one_to_one':
            return OneToOneSetup(n_basic)
        if n_basic != 2:
            msg = f'needs an element with 2 DOFs (translation, rotation), got {n_basic}'
            raise ConfigError(msg)
        offsets = raw.get('offsets')
        if not isinstance(offsets, (list, tuple)) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in offsets):
            msg = f'offsets: must be a list of two numbers [m], got {offsets!r}'
            raise ConfigError(msg)
        length = raw.get('actuator_length')
        if length is not None and (isinstance(length, bool) or not isinstance(
                length, (int, float))):
            msg = f'actuator_length: must be a number [m], got {length!r}'
            raise ConfigError(msg)
        return RigidLinkTwoActuators(offsets, str(raw.get('geometry', 'linear')),
                                     None if length is None else float(length))
    except ConfigError as err:
        text = str(err)
        for prefix in ('rigid_link_2 setup: ', 'one_to_one setup: '):
            text = text.removeprefix(prefix)
        msg = f'{where}: {text}'
        raise ConfigError(msg) from None
