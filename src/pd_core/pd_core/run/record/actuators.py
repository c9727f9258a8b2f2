"""Per-actuator outputs of a test with force-controlled actuators: ``actuators.csv``, a figure.

A substructured test whose experimental elements have force-controlled actuators (mixed
control, e.g. a column's axial load) commands, per actuator, either a stroke or a force; the
structure-level history (``response.csv``) holds the structure DOFs only. This module reads
the sites' own streams from the run's record (journal or bag: the node-graph run, the ROS-free
run and the replay alike) and writes, per committed step (the answer of the step's last
iteration, at every site):

* per actuator ``<a>``: ``mode_<a>`` (0 displacement, 1 force), ``command_<a>`` (the
  commanded stroke [m] for displacement control, the commanded force [N] for force control),
  ``stroke_<a>`` [m] and ``force_<a>`` [N] measured;
* per free basic DOF ``<b>`` of an element ``<e>`` (a ``null`` entry of its ``dofs``):
  ``<e>.<b>`` the measured displacement [m] (from the strokes, the setup's inverse) and
  ``<e>.<b>_force`` its basic force [N] (``Jᵀ f`` there; for a column's ``v`` the axial force,
  tension positive);
* per structure basic DOF: ``<e>.<b>`` and ``<e>.<b>_force`` likewise (the lateral
  hysteresis of a column, P-Δ included).

Actuator columns are named ``<site>.<a>`` when actuator names repeat across sites.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pd_common.experimental.setups import PlanarActuators, RigidLinkTwoActuators
from pd_common.protocol import Command, ControlMode, Feedback, FeedbackStatus

from ...plotting import pyplot
from .outputs import write_columns_csv

if TYPE_CHECKING:
    from ...model.substructure import ExperimentalElement, StructuralModel
    from .bag import RecordedRun
    from .history import ResponseHistory

__all__ = ['ACTUATORS_CSV', 'ACTUATORS_FIGURE', 'ActuatorHistory', 'actuator_history',
           'basic_names', 'write_actuator_outputs']

ACTUATORS_CSV = 'actuators.csv'
ACTUATORS_FIGURE = 'actuators.png'


def basic_names(element: ExperimentalElement) -> list[str]:
    """Names of the element's basic DOFs (``u, v[, theta]``, ``u, theta``, or ``b1, b2...``)."""
    setup = element.setup
    n = setup.n_basic if setup is not None else int(element.dofs.size)
    if isinstance(setup, PlanarActuators):
        return ['u', 'v', 'theta'][:n]
    if isinstance(setup, RigidLinkTwoActuators):
        return ['u', 'theta']
    return [f'b{k + 1}' for k in range(n)]


class ActuatorHistory:
    """Per committed step, every actuator's command and measurement (see the module docstring).

    Attributes:
        columns: the ``actuators.csv`` columns (``time``, ``step`` first).
        forced: the force-controlled actuators' column labels.
        free: ``<e>.<b>`` labels of the free basic DOFs.
        structural: ``<e>.<b>`` labels of the structure basic DOFs.
        control: per actuator label, its ``control`` (mode and force table).
    """

    def __init__(self, columns: dict[str, np.ndarray], forced: list[str], free: list[str],
                 structural: list[str], control: dict[str, Any]) -> None:
        self.columns = columns
        self.forced = forced
        self.free = free
        self.structural = structural
        self.control = control

    @property
    def rows(self) -> int:
        """Number of committed steps recorded."""
        return int(self.columns['step'].size)

    def summary(self) -> dict[str, Any]:
        """The ``actuators`` block of ``summary.json``.

        Per force-controlled actuator the largest |measured − commanded| force; per free DOF
        its range and final value; the units and the mode codes.
        """
        columns = self.columns
        forced = {}
        for label in self.forced:
            error = columns[f'force_{label}'] - columns[f'command_{label}']
            forced[label] = {
                'control': self.control[label],
                'max_abs_force_error': float(np.max(np.abs(error))) if error.size else math.nan,
                'final_force': float(columns[f'force_{label}'][-1]) if error.size else math.nan,
            }
        free = {}
        for label in self.free:
            values, force = columns[label], columns[f'{label}_force']
            free[label] = {
                'min': float(np.min(values)) if values.size else math.nan,
                'max': float(np.max(values)) if values.size else math.nan,
                'final': float(values[-1]) if values.size else math.nan,
                'final_force': float(force[-1]) if force.size else math.nan,
            }
        return {'file': ACTUATORS_CSV, 'modes': {'0': 'displacement', '1': 'force'},
                'units': {'stroke': 'm', 'force': 'N', 'command': 'm (displacement) or N '
                          '(force)'},
                'force_controlled': forced, 'free_dofs': free}


def _site_steps(events: list[tuple[int, Command | Feedback]], test_id: str
                ) -> dict[int, tuple[Command, Feedback]]:
    """Per step, the command and OK answer of its last iteration on one site's stream."""
    commands: dict[tuple[int, int], Command] = {}
    steps: dict[int, tuple[Command, Feedback]] = {}
    for _, item in events:
        if item.test_id != test_id:
            continue
        if isinstance(item, Command):
            commands[(item.step, item.iteration)] = item
            continue
        if item.status is not FeedbackStatus.OK:
            continue
        command = commands.get((item.step, item.iteration))
        if command is None:
            continue
        held = steps.get(item.step)
        if held is None or item.iteration >= held[1].iteration:
            steps[item.step] = (command, item)
    return steps


def actuator_history(run: RecordedRun, model: StructuralModel, test_id: str,
                     history: ResponseHistory) -> ActuatorHistory:
    """The per-actuator history of the committed steps of ``history`` from ``run``'s record."""
    n = history.n_committed
    sites = model.site_names
    names = [name for site in sites for name in model.actuator_names(site)]
    repeated = len(set(names)) != len(names)
    columns: dict[str, np.ndarray] = {'time': history.time[:n].copy(),
                                      'step': history.steps[:n].copy()}
    forced: list[str] = []
    free: list[str] = []
    structural: list[str] = []
    control: dict[str, Any] = {}
    for site in sites:
        steps = _site_steps(run.site_events.get(site, []), test_id)
        elements = model.sites[site]
        total = sum(element.setup.n_actuators for element in elements
                    if element.setup is not None)
        modes = np.zeros((n, total))
        commanded = np.full((n, total), math.nan)
        strokes = np.full((n, total), math.nan)
        forces = np.full((n, total), math.nan)
        for row in range(n):
            found = steps.get(row)
            if found is None:
                continue
            command, answer = found
            target = np.array(command.target_displacement, dtype=float)
            mode = (np.array(command.control_mode, dtype=float) if command.control_mode
                    else np.zeros(total))
            force_target = (np.array(command.target_force, dtype=float) if command.target_force
                            else np.zeros(total))
            modes[row] = mode
            commanded[row] = np.where(mode == ControlMode.FORCE, force_target, target)
            strokes[row] = np.array(answer.measured_displacement, dtype=float)
            forces[row] = np.array(answer.restoring_force, dtype=float)
        start = 0
        for element in elements:
            setup = element.setup
            assert setup is not None
            stop = start + setup.n_actuators
            for k, name in enumerate(element.actuator_names):
                label = f'{site}.{name}' if repeated else name
                j = start + k
                columns[f'mode_{label}'] = modes[:, j]
                columns[f'command_{label}'] = commanded[:, j]
                columns[f'stroke_{label}'] = strokes[:, j]
                columns[f'force_{label}'] = forces[:, j]
                spec = element.control[k] if element.control else None
                control[label] = spec.describe() if spec is not None else {
                    'mode': 'displacement'}
                if spec is not None and spec.force_controlled:
                    forced.append(label)
            basic = np.full((n, setup.n_basic), math.nan)
            basic_force = np.full((n, setup.n_basic), math.nan)
            for row in range(n):
                if np.all(np.isfinite(strokes[row, start:stop])):
                    basic[row] = setup.basic_displacement(strokes[row, start:stop])
                    basic_force[row] = setup.basic_force(forces[row, start:stop], basic[row])
            labels = basic_names(element)
            free_set = set(element.free_index.tolist())
            for b, label in enumerate(labels):
                key = f'{element.name}.{label}'
                columns[key] = basic[:, b]
                columns[f'{key}_force'] = basic_force[:, b]
                (free if b in free_set else structural).append(key)
            start = stop
    return ActuatorHistory(columns, forced, free, structural, control)


def write_actuator_figure(actuators: ActuatorHistory, directory: Path, *, title: str = ''
                          ) -> Path:
    """Force-controlled actuators' force vs time, free DOFs vs time, structure-DOF hysteresis.

    ``actuators.png``: top left the commanded and measured force of each force-controlled
    actuator [kN]; bottom left each free basic DOF's measured displacement [mm]; right each
    structure basic DOF's basic force [kN] against its displacement [mm] (a column's lateral
    hysteresis, P-Δ included).
    """
    plt = pyplot()
    columns = actuators.columns
    time = columns['time']
    figure, axes = plt.subplot_mosaic([['force', 'loop'], ['free', 'loop']], figsize=(12, 5.5),
                                      layout='constrained', width_ratios=(1.6, 1))
    for label in actuators.forced:
        axes['force'].plot(time, columns[f'command_{label}'] / 1e3, color='0.5',
                           linestyle='--', linewidth=1.0, label=f'{label} commanded')
        axes['force'].plot(time, columns[f'force_{label}'] / 1e3, linewidth=1.0,
                           label=f'{label} measured')
    if actuators.forced:  # from 0: a held load reads as a flat line, not as its noise
        values = np.concatenate([columns[f'{kind}_{label}'] for label in actuators.forced
                                 for kind in ('force', 'command')]) / 1e3
        values = values[np.isfinite(values)]
        if values.size:
            low, high = min(0.0, float(values.min())), max(0.0, float(values.max()))
            margin = 0.1 * (high - low) or 1.0
            axes['force'].set_ylim(low - margin, high + margin)
    axes['force'].set_ylabel('Actuator force [kN]')
    axes['force'].set_title(f'Force-controlled actuators — {title}' if title
                            else 'Force-controlled actuators')
    axes['force'].legend(fontsize='small')
    for label in actuators.free:
        axes['free'].plot(time, 1e3 * columns[label], linewidth=1.0, label=label)
    axes['free'].set_ylabel('Free DOF [mm]')
    axes['free'].set_xlabel('Time [s]')
    if actuators.free:
        axes['free'].legend(fontsize='small')
    for label in actuators.structural:
        axes['loop'].plot(1e3 * columns[label], columns[f'{label}_force'] / 1e3, linewidth=0.8,
                          label=label)
    axes['loop'].set_xlabel('Basic displacement [mm]')
    axes['loop'].set_ylabel('Basic force [kN]')
    axes['loop'].set_title('Hysteresis (structure DOFs)')
    if actuators.structural:
        axes['loop'].legend(fontsize='small')
    for item in axes.values():
        item.grid(visible=True, alpha=0.4)
    for key in ('force', 'free'):
        axes[key].set_xlim(0.0, float(time[-1]) if time.size else 1.0)
    path = directory / ACTUATORS_FIGURE
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def write_actuator_outputs(actuators: ActuatorHistory, directory: str | Path, *,
                           figures: bool = True, title: str = '') -> list[Path]:
    """Write ``actuators.csv`` and (optionally) ``actuators.png``."""
    directory = Path(directory)
    written = [write_columns_csv(actuators.columns, directory / ACTUATORS_CSV)]
    if figures:
        written.append(write_actuator_figure(actuators, directory, title=title))
    return written
