"""Real-time hybrid simulation: transfer systems, compensators, continuous actuator motion.

Pure (numpy/scipy). The vRTHS benchmark (Silva, Dyke et al. 2020) is built from these pieces
by ``pd_rths_benchmark`` (``./pd rths_benchmark``); the bridge's ``transfer_system`` driver runs
them behind the step protocol.
"""

from __future__ import annotations

from .base import (
    BENCHMARK_CAPACITY,
    BENCHMARK_NOISE,
    BENCHMARK_QUANTUM,
    BENCHMARK_SPECIMEN,
    IdealPlant,
    PhysicalSpecimen,
    SensorNoise,
    TransferSystem,
    quantise,
)
from .compensation import (
    Compensator,
    CompensatorParameter,
    CompensatorSpec,
    NoCompensation,
    compensator_names,
    compensator_spec,
    make_compensator,
    register_compensator,
)
from .continuous import (
    ActuatorCounters,
    ContinuousActuator,
    ContinuousConfig,
    ContinuousMeasurement,
    continuous_from_config,
)
from .cpu_latency import CpuLatencyRequest, wall_clock_cpu_latency
from .plant import plant_from_config, plant_model_names, register_plant_model
from .realtime import RealtimeLoop, RealtimeStatistics
from .site import ContinuousSiteServer, SampleLog

__all__ = [
    'BENCHMARK_CAPACITY',
    'BENCHMARK_NOISE',
    'BENCHMARK_QUANTUM',
    'BENCHMARK_SPECIMEN',
    'ActuatorCounters',
    'Compensator',
    'CompensatorParameter',
    'CompensatorSpec',
    'ContinuousActuator',
    'ContinuousConfig',
    'ContinuousMeasurement',
    'ContinuousSiteServer',
    'CpuLatencyRequest',
    'IdealPlant',
    'NoCompensation',
    'PhysicalSpecimen',
    'RealtimeLoop',
    'RealtimeStatistics',
    'SampleLog',
    'SensorNoise',
    'TransferSystem',
    'compensator_names',
    'compensator_spec',
    'continuous_from_config',
    'make_compensator',
    'plant_from_config',
    'plant_model_names',
    'quantise',
    'register_compensator',
    'register_plant_model',
    'wall_clock_cpu_latency',
]
