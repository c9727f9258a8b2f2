"""The vRTHS benchmark's transfer system (Silva, Dyke et al. 2020) and the plant factory.

The plant, from the command ``u`` to the actuator displacement ``x`` (SI units)::

    G_s(s) = a1β0 / (s² + β1 s + β2)                   servo-valve
    G_a(s) = 1 / (s + a3)                              actuator
    G_e(s) = 1 / (m_e s² + c_e s + k_e)                specimen
    G_0    = G_a G_e / (1 + a2 s G_a G_e)              control–structure interaction a2·s
    G      = g · G_s G_0 / (1 + G_s G_0)               inner unity feedback (servo-controller)

As a state-space model with physical states ``[q, q̇, f, x, ẋ]``: ``q`` the servo-valve's output
(``q̈ + β1 q̇ + β2 q = a1β0 (g u − x)``), ``f`` the actuator's force (``ḟ + a3 f = q − a2 ẋ``),
and the specimen ``m_e ẍ + c_e ẋ + k_e x = f``. This is the block diagram of the benchmark's
Simulink model (the gain ``g`` acts on the command before the unity feedback, which gives the
same ``G``); the actuator force ``f`` is the signal the benchmark's capacity of ±8,900 N
applies to (its saturation block sits on the actuator's output), and it is the exact specimen
force ``m_e ẍ + c_e ẋ + k_e x`` of the plant's displacement.

:class:`BenchmarkPlant` discretises the model exactly for a command held over each controller
sample (zero-order hold, :func:`scipy.signal.cont2discrete`) and steps it with plain floats.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import RthsError
from ..registry import GROUPS, Registry
from .base import BENCHMARK_SPECIMEN, IdealPlant, PhysicalSpecimen, TransferSystem

__all__ = [
    'PERTURBATION_STD',
    'PLANT_MODELS',
    'BenchmarkPlant',
    'BenchmarkPlantParameters',
    'PlantFactory',
    'benchmark_state_space',
    'benchmark_transfer_function',
    'equivalent_delay',
    'frequency_response',
    'perturbed_plants',
    'plant_from_config',
    'plant_model_names',
    'register_plant_model',
]

#: Standard deviations of the benchmark's uncertain plants, in the order of the draws.
PERTURBATION_STD = {'k_e': 5.0e4, 'beta1': 3.3, 'beta2': 3.3e3, 'a3': 1.3}


@dataclass(frozen=True)
class BenchmarkPlantParameters:
    """The parameters of the benchmark's transfer system.

    Attributes:
        a1_beta0: Servo-valve gain a1·β0, 1/s² per m (nominal 2.1283e13).
        beta1: Servo-valve damping term β1, 1/s (nominal 425).
        beta2: Servo-valve stiffness term β2, 1/s² (nominal 9.9976e4).
        a3: Actuator pole a3, 1/s (nominal 3.3).
        a2: Control–structure interaction gain a2 (nominal 4.2297e6).
        gain: Command gain g (nominal 1.0261).
        specimen: The physical substructure (m_e, k_e, ζ_e).
    """

    a1_beta0: float = 2.1283e13
    beta1: float = 425.0
    beta2: float = 9.9976e4
    a3: float = 3.3
    a2: float = 4.2297e6
    gain: float = 1.0261
    specimen: PhysicalSpecimen = BENCHMARK_SPECIMEN

    def __post_init__(self) -> None:
        """Check the fields (finite; a1β0, β2, g and the specimen mass positive)."""
        for name in ('a1_beta0', 'beta1', 'beta2', 'a3', 'a2', 'gain'):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value)):
                msg = f'plant parameter {name} must be a finite number, got {value!r}'
                raise RthsError(msg)
        for name in ('a1_beta0', 'beta2', 'gain'):
            if getattr(self, name) <= 0.0:
                msg = f'plant parameter {name} must be > 0, got {getattr(self, name)!r}'
                raise RthsError(msg)
        if self.specimen.mass <= 0.0:
            msg = f'plant specimen mass must be > 0, got {self.specimen.mass!r}'
            raise RthsError(msg)

    @classmethod
    def nominal(cls) -> BenchmarkPlantParameters:
        """The benchmark's nominal plant."""
        return cls()

    @classmethod
    def perturbed(cls, rng: np.random.Generator) -> BenchmarkPlantParameters:
        """One uncertain plant of the benchmark, drawn from ``rng``.

        Four standard normal draws, in this order (the order of the benchmark's input file):
        ``k_e ~ N(1.19e6, 5e4²)``, ``β1 ~ N(425, 3.3²)``, ``β2 ~ N(9.9976e4, 3300²)``,
        ``a3 ~ N(3.3, 1.3²)``; each is ``mean + std · rng.standard_normal()``. The specimen's
        damping coefficient follows the drawn stiffness (``c_e = 2 ζ_e √(k_e m_e)``), as in the
        benchmark. A seed therefore gives the same plants for everyone:
        ``rng = np.random.default_rng(seed)`` and one call per plant.
        """
        base = cls()
        k_e = base.specimen.stiffness + PERTURBATION_STD['k_e'] * float(rng.standard_normal())
        beta1 = base.beta1 + PERTURBATION_STD['beta1'] * float(rng.standard_normal())
        beta2 = base.beta2 + PERTURBATION_STD['beta2'] * float(rng.standard_normal())
        a3 = base.a3 + PERTURBATION_STD['a3'] * float(rng.standard_normal())
        return replace(base, beta1=beta1, beta2=beta2, a3=a3,
                       specimen=replace(base.specimen, stiffness=k_e))


def benchmark_state_space(
    params: BenchmarkPlantParameters,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The continuous state-space model ``(A, B, C, D)`` of the plant.

    States ``[q, q̇, f, x, ẋ]`` (module docstring), input ``u``, outputs ``[x, f]`` (displacement
    m, actuator force N).
    """
    m = params.specimen.mass
    c = params.specimen.damping
    k = params.specimen.stiffness
    ab, b1, b2, a3, a2, g = (params.a1_beta0, params.beta1, params.beta2, params.a3,
                             params.a2, params.gain)
    a = np.array([
        [0.0, 1.0, 0.0, 0.0, 0.0],
        [-b2, -b1, 0.0, -ab, 0.0],
        [1.0, 0.0, -a3, 0.0, -a2],
        [0.0, 0.0, 0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0 / m, -k / m, -c / m],
    ])
    b = np.array([[0.0], [ab * g], [0.0], [0.0], [0.0]])
    c_out = np.array([[0.0, 0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 1.0, 0.0, 0.0]])
    d = np.zeros((2, 1))
    return a, b, c_out, d


def benchmark_transfer_function(
    params: BenchmarkPlantParameters,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The plant's continuous transfer function ``G(s) = num(s)/den(s)``.

    The plant's continuous transfer function ``G(s) = num(s)/den(s)`` from the block
    diagram's polynomials (highest power first, as :mod:`scipy.signal`)::

        G = g a1β0 / ((s² + β1 s + β2)((s + a3)(m_e s² + c_e s + k_e) + a2 s) + a1β0)
    """
    specimen = np.array([params.specimen.mass, params.specimen.damping,
                         params.specimen.stiffness])
    interaction = np.polyadd(np.polymul([1.0, params.a3], specimen), [params.a2, 0.0])
    den = np.polyadd(np.polymul([1.0, params.beta1, params.beta2], interaction),
                     [params.a1_beta0])
    num = np.array([params.gain * params.a1_beta0])
    return num, np.asarray(den, dtype=np.float64)


def frequency_response(
    params: BenchmarkPlantParameters, frequencies_hz: NDArray[np.float64] | list[float],
) -> NDArray[np.complex128]:
    """``G(j 2π f)`` of the continuous plant at ``frequencies_hz``."""
    num, den = benchmark_transfer_function(params)
    s = 2j * np.pi * np.asarray(frequencies_hz, dtype=np.float64)
    return np.asarray(np.polyval(num, s) / np.polyval(den, s), dtype=np.complex128)


def equivalent_delay(params: BenchmarkPlantParameters, frequency_hz: float) -> float:
    """The plant's phase delay ``−∠G(j ω) / ω`` at ``frequency_hz``, s.

    About 25 ms at 1 Hz for the nominal plant.

    Raises:
        RthsError: If the frequency is not positive.
    """
    if not (math.isfinite(frequency_hz) and frequency_hz > 0.0):
        msg = f'equivalent_delay frequency_hz must be > 0, got {frequency_hz!r}'
        raise RthsError(msg)
    response = complex(frequency_response(params, [frequency_hz])[0])
    phase = math.atan2(response.imag, response.real)
    return -phase / (2.0 * math.pi * frequency_hz)


def _zoh(params: BenchmarkPlantParameters, dt: float
         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The exact (zero-order hold) discretisation ``(A_d, B_d)`` of the plant's states.

    The model's entries span 20 orders of magnitude (a1β0 = 2.1e13 against 1/m_e): the matrix
    exponential is taken of the diagonally balanced model (:func:`scipy.linalg.matrix_balance`,
    a similarity by powers of 2, exact in floating point) and transformed back; unbalanced, the
    displacement row of ``B_d`` loses about 6e-3 of its value to round-off.
    """
    from scipy import linalg, signal  # noqa: PLC0415 - 0.6 s to import: not on a node's start-up
    a, b, c, d = benchmark_state_space(params)
    _balanced, (scale, _perm) = linalg.matrix_balance(a, permute=False, separate=True)
    a_b = a * (1.0 / scale)[:, None] * scale[None, :]
    b_b = b / scale[:, None]
    ad, bd, _cd, _dd, _dt = signal.cont2discrete((a_b, b_b, c * scale[None, :], d), dt,
                                                 method='zoh')
    a_d = np.asarray(ad, dtype=np.float64) * scale[:, None] / scale[None, :]
    b_d = np.asarray(bd, dtype=np.float64) * scale[:, None]
    return a_d, b_d


class BenchmarkPlant(TransferSystem):
    """The benchmark's transfer system discretised exactly (zero-order hold on the command).

    Sample ordering as :class:`~.base.TransferSystem`: ``output()`` is the displacement at
    sample ``k``; ``advance(u)`` holds ``u`` over one sample. :meth:`actuator_force` is the
    actuator's force at sample ``k`` (the signal of the ±8,900 N capacity).
    """

    def __init__(self, dt: float, params: BenchmarkPlantParameters | None = None) -> None:
        """Discretise the plant of ``params`` (nominal by default) at sample period ``dt``."""
        super().__init__(dt)
        self.params = params if params is not None else BenchmarkPlantParameters.nominal()
        self.a_discrete, self.b_discrete = _zoh(self.params, self.dt)
        # Rows of [A | B] as float tuples: advance() is plain float arithmetic.
        self._rows = tuple(
            (*(float(v) for v in self.a_discrete[i]), float(self.b_discrete[i, 0]))
            for i in range(5))
        self._state = (0.0, 0.0, 0.0, 0.0, 0.0)

    def reset(self) -> None:
        """Return to rest."""
        self._state = (0.0, 0.0, 0.0, 0.0, 0.0)

    def output(self) -> float:
        """The actuator displacement at the current sample, m."""
        return self._state[3]

    def actuator_force(self) -> float:
        """The actuator force at the current sample, N."""
        return self._state[2]

    @property
    def specimen(self) -> PhysicalSpecimen:
        """The physical specimen the plant was drawn with (a perturbed plant's k_e).

        The one whose force the load cell reads.
        """
        return self.params.specimen

    @property
    def state(self) -> tuple[float, float, float, float, float]:
        """The state ``(q, q̇, f, x, ẋ)`` at the current sample."""
        return self._state

    def advance(self, command: float) -> None:
        """Hold ``command`` (m) over one sample."""
        s0, s1, s2, s3, s4 = self._state
        u = float(command)
        r0, r1, r2, r3, r4 = self._rows
        self._state = (
            r0[0] * s0 + r0[1] * s1 + r0[2] * s2 + r0[3] * s3 + r0[4] * s4 + r0[5] * u,
            r1[0] * s0 + r1[1] * s1 + r1[2] * s2 + r1[3] * s3 + r1[4] * s4 + r1[5] * u,
            r2[0] * s0 + r2[1] * s1 + r2[2] * s2 + r2[3] * s3 + r2[4] * s4 + r2[5] * u,
            r3[0] * s0 + r3[1] * s1 + r3[2] * s2 + r3[3] * s3 + r3[4] * s4 + r3[5] * u,
            r4[0] * s0 + r4[1] * s1 + r4[2] * s2 + r4[3] * s3 + r4[4] * s4 + r4[5] * u,
        )


def perturbed_plants(seed: int, count: int) -> list[BenchmarkPlantParameters]:
    """The first ``count`` uncertain plants of ``seed``.

    One generator ``np.random.default_rng(seed)``, one :meth:`BenchmarkPlantParameters.perturbed`
    call per plant, in order (plant ``i`` of a seed is the same in every run and for everyone).
    """
    rng = np.random.default_rng(seed)
    return [BenchmarkPlantParameters.perturbed(rng) for _ in range(count)]


PlantFactory = Callable[[Mapping[str, Any], float, str], TransferSystem]
"""``factory(section, dt, where)``: the transfer system of a ``plant:`` section at the
controller period ``dt`` (one-line :class:`RthsError` naming ``where`` and the key)."""



def _admit(name: str, factory: Any) -> PlantFactory:
    """A callable plant factory.

    Raises:
        RthsError: Anything else.
    """
    if not callable(factory):
        msg = f'plant model {name}: the factory must be callable, got {factory!r}'
        raise RthsError(msg)
    admitted: PlantFactory = factory
    return admitted


#: The plant models by name (``plant: {model: name}``): the built-ins, the bridge's
#: ``emulator`` and the installed ``pd.plants`` plug-ins (an entry point names a factory).
PLANT_MODELS: Registry[PlantFactory] = Registry('plant model', GROUPS['plant model'],
                                                admit=_admit, error=RthsError)


def register_plant_model(name: str, factory: PlantFactory) -> None:
    """Register the plant model ``name`` (``plant: {model: name, ...}``).

    Raises:
        RthsError: On a bad or taken name.
    """
    PLANT_MODELS.register(name, factory)


def plant_model_names() -> tuple[str, ...]:
    """The registered plant models, sorted."""
    return PLANT_MODELS.names()


def plant_from_config(section: Mapping[str, Any] | None, dt: float,
                      where: str = 'plant') -> TransferSystem:
    """The transfer system of a ``plant:`` section at controller period ``dt``.

    ``model`` (default ``benchmark``) names a registered model: ``benchmark`` and ``ideal``
    here; the bridge registers ``emulator`` (its servo-hydraulic emulator). An empty or
    missing section is the nominal benchmark plant.

    Raises:
        RthsError: One line naming ``where`` and the key on an unknown key or a bad value.
    """
    if section is None:
        section = {}
    if not isinstance(section, Mapping):
        msg = f'{where}: must be a mapping, got {type(section).__name__}'
        raise RthsError(msg)
    model = section.get('model', 'benchmark')
    factory = PLANT_MODELS.get(model) if isinstance(model, str) else None
    if factory is None:
        msg = (f'{where}.model: must be one of {", ".join(plant_model_names())}, got '
               f'{model!r}' + (' (registered by the bridge: run it there)'
                               if model == 'emulator' else ''))
        raise RthsError(msg)
    return factory(section, dt, where)


def _keys(section: Mapping[str, Any], where: str, keys: tuple[str, ...]) -> None:
    for key in section:
        if key not in keys:
            msg = f'{where}: unknown key {key!r} (expected {", ".join(keys)})'
            raise RthsError(msg)


def _benchmark_plant(section: Mapping[str, Any], dt: float, where: str) -> TransferSystem:
    """The benchmark plant of ``{model: benchmark, perturbed: false, seed: 0, index: 0}``.

    ``perturbed: true`` is plant ``index`` of :func:`perturbed_plants` of ``seed``.
    """
    _keys(section, where, ('model', 'perturbed', 'seed', 'index'))
    perturbed = section.get('perturbed', False)
    if not isinstance(perturbed, bool):
        msg = f'{where}.perturbed: must be true or false, got {perturbed!r}'
        raise RthsError(msg)
    numbers = {}
    for key in ('seed', 'index'):
        value = section.get(key, 0)
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            msg = f'{where}.{key}: must be an integer >= 0, got {value!r}'
            raise RthsError(msg)
        numbers[key] = value
    params = (perturbed_plants(numbers['seed'], numbers['index'] + 1)[numbers['index']]
              if perturbed else BenchmarkPlantParameters.nominal())
    return BenchmarkPlant(dt, params)


def _ideal_plant(section: Mapping[str, Any], dt: float, where: str) -> TransferSystem:
    """``{model: ideal}``: x = u one sample later."""
    if section.get('perturbed', False) is not False:
        msg = f'{where}.perturbed: applies to model benchmark only, not ideal'
        raise RthsError(msg)
    _keys(section, where, ('model', 'perturbed'))
    return IdealPlant(dt)


register_plant_model('benchmark', _benchmark_plant)
register_plant_model('ideal', _ideal_plant)
