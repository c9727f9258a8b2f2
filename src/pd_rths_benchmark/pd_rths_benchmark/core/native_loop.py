"""The vRTHS benchmark through this project's integrator and step protocol (``--loop native``).

The partition is the benchmark's, written as a substructured test file
(:func:`native_test_file`): the numerical substructure ``K − K_E`` is a ``linear`` element on
the three floors, the physical specimen an ``experimental`` element on floor 1 at site
``lab1``, whose ``transfer_system`` section is the benchmark's plant, compensator, sensors and
capacity at 4096 Hz (:class:`pd_common.rths.ContinuousSiteServer`). The session integrates
``M ẍ + C_N ẋ + K_N x + r = −M ι ẍ_g`` at Δt_int (e.g. 1/1024 s) with the chosen scheme; each
step's target d[n+1] is sub-stepped at the controller rate by the predictor–corrector
(the targets' polynomial, ``interpolation``) and the step's measurement, taken at t_{n+1}, is
its restoring force r[n+1]: the one-sample force delay and the RK4 of the benchmark's own
loop are gone.

The specimen's inertia: with ``inertia: subtract`` (the default here) the integrator carries
the full mass ``M`` and the force returned is the load cell's minus ``m_e ẍ`` of the
actuator's displacement (an accelerometer on the specimen's mass), so the mass is not in the
explicit restoring force; with ``inertia: measured`` the integrator has ``M − M_E`` and the
load cell's force includes ``m_e ẍ``. The damping ``C_N = C − C_E`` is the numerical model's
coefficient matrix; ``c_e ẋ`` is measured.

J1–J5 are judged at the controller rate (x_d: the sub-stepped desired displacement, x_m: the
measured one, against the reference at the same instants), J6–J9 at the integration steps
(the floors' commanded displacements against the reference).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pd_common.protocol import Command, TestState
from pd_common.rths import ContinuousSiteServer, PhysicalSpecimen
from pd_core.errors import ConfigError
from pd_core.run.loop.dispatch import StepDispatcher
from pd_core.run.loop.session import TestSession
from pd_core.run.runner import serve_queue, site_servers
from pd_core.run.test_file import from_dict

from .problem import BenchmarkCase, numerical_substructure, padding_needed

__all__ = ['DOF_NAMES', 'SITE', 'NativeLoopResult', 'native_test_file', 'run_native_loop']

#: The floors' DOF names and the physical site of the native test file.
DOF_NAMES = ('x1', 'x2', 'x3')
SITE = 'lab1'


@dataclass(frozen=True, eq=False)
class NativeLoopResult:
    """One native run.

    Attributes:
        t_samples: Controller sample times, s (from the first sample after rest).
        x_d: Desired displacement of the actuator at each sample, m.
        x_m: Measured displacement at each sample, m.
        u: Command at each sample, m.
        force: Load-cell force at each sample, N.
        t_steps: Integration step times, s (from 0).
        floors: The floors' commanded displacements at each step, ``(steps + 1, 3)``, m.
        restoring_force: The restoring force of floor 1 the integrator took at each step, N.
        capacity_reached: Whether a sample reached the actuator's capacity.
        peak_force: Largest |actuator force|, N.
        completed: Whether every step was committed (False: the session held or aborted).
        state: The session's final state and reason.
    """

    t_samples: NDArray[np.float64]
    x_d: NDArray[np.float64]
    x_m: NDArray[np.float64]
    u: NDArray[np.float64]
    force: NDArray[np.float64]
    t_steps: NDArray[np.float64]
    floors: NDArray[np.float64]
    restoring_force: NDArray[np.float64]
    capacity_reached: bool
    peak_force: float
    completed: bool
    state: str


def native_test_file(case: BenchmarkCase, record: NDArray[np.float64], record_dt: float, *,
                     padding_samples: int, intensity: float, integration_dt: float,
                     transfer_system: Mapping[str, Any], specimen: PhysicalSpecimen,
                     scheme: str = 'newmark_explicit', test_id: str = 'vrths-native',
                     bridge: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The benchmark's native run as a test file (a mapping; ``yaml.safe_dump`` writes it).

    Args:
        case: The benchmark case.
        record: The ground acceleration, m/s², at ``record_dt`` (before ``intensity``).
        record_dt: Its sample period, s.
        padding_samples: Zeros before and after (the benchmark's 5 s, in record samples),
            added only at an end that does not hold them yet
            (:func:`~.problem.padding_needed`: the benchmark's own records carry them).
        intensity: The factor on the record.
        integration_dt: Δt_int, s.
        transfer_system: The site's ``transfer_system`` section.
        specimen: The physical specimen (removed from the numerical substructure).
        scheme: The integration scheme.
        test_id: The test's id.
        bridge: The site's ``bridge`` parameters (for a run through the node graph).
    """
    m_n, c_n, k_n = numerical_substructure(case, specimen)
    inertia = transfer_system.get('inertia', 'subtract')
    mass = np.diag(case.mass if inertia == 'subtract' else m_n).tolist()
    pad_before, pad_after = padding_needed(record, padding_samples)
    acceleration = [*([0.0] * padding_samples if pad_before else []),
                    *(float(a) for a in record),
                    *([0.0] * padding_samples if pad_after else [])]
    duration = (len(acceleration) - 1) * record_dt
    site: dict[str, Any] = {'transfer_system': {**dict(transfer_system), 'inertia': inertia}}
    if bridge is not None:
        site['bridge'] = dict(bridge)
    return {
        'test': {'id': test_id, 'scheme': scheme, 'dt': float(integration_dt),
                 'duration': float(math.floor(duration / integration_dt + 1e-9)
                                   * integration_dt)},
        'structure': {
            'dof_names': list(DOF_NAMES),
            'mass': [float(m) for m in mass],
            'damping': {'coefficient': c_n.tolist()},
            'elements': [
                {'type': 'linear', 'name': 'numerical', 'dofs': list(DOF_NAMES),
                 'stiffness': k_n.tolist()},
                {'type': 'experimental', 'name': 'specimen', 'site': SITE,
                 'dofs': [DOF_NAMES[0]], 'initial_stiffness': float(specimen.stiffness)},
            ],
        },
        'ground_motion': {'inline': {'dt': float(record_dt), 'acceleration': acceleration},
                          'units': 'm/s2', 'scale': float(intensity)},
        'protocol': {'max_retries': 0},
        'sites': {SITE: site},
    }


def run_native_loop(test_file: Mapping[str, Any], *, source: str = 'rths_benchmark'
                    ) -> NativeLoopResult:
    """Run a native test file in this process (session, step dispatcher, continuous site).

    Raises:
        ConfigError: A bad test file or ``transfer_system`` section (one line).
    """
    definition = from_dict(dict(test_file), source=source)
    servers = site_servers(definition, keep_samples=True)
    server = servers.get(SITE)
    if not isinstance(server, ContinuousSiteServer) or server.samples is None:
        msg = f'{source}: sites.{SITE}.transfer_system: is required for the native loop'
        raise ConfigError(msg)
    session = TestSession(definition)
    queue: deque[tuple[str, Command]] = deque()
    dispatcher = StepDispatcher(session, lambda site, command: queue.append((site, command)))
    dispatcher.start()
    serve_queue(queue, servers, dispatcher)
    history = session.history
    n = history.n_committed
    samples = server.samples
    completed = session.state is TestState.FINISHED
    return NativeLoopResult(
        t_samples=samples.times, x_d=samples.desired, x_m=samples.measured,
        u=samples.command, force=samples.force, t_steps=history.time,
        floors=np.array(history.displacement[:n]),
        restoring_force=np.array(history.restoring_force[:n, 0]),
        capacity_reached=not server.valid, peak_force=server.peak_force,
        completed=completed,
        state=f'{session.state.name.lower()}: {session.message}')
