"""The pre-test's figures (matplotlib, Agg; imported only when a figure is drawn).

* ``spectra.png``: 5 % pseudo-acceleration spectra of the records (scale 1), the test's
  initial period marked;
* ``demand.png``: per run group (record and variation) the actuator's peak stroke, largest
  increment per step, peak velocity and peak force against the scale factor, each with the
  bridge's limit as a horizontal line.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pd_core.plotting import pyplot

from .execute import RunOutcome
from .limits import BridgeLimits
from .plan import Plan
from .spectra import Spectrum

__all__ = ['MAX_LINES', 'plot_demand', 'plot_spectra']

#: Lines drawn per panel (the first groups; the CSV has every run).
MAX_LINES = 12


def plot_spectra(plan: Plan, spectra: Sequence[Spectrum], period: float, path: Path) -> Path:
    """``S_a(T)`` of every record [g = 9.81 m/s²], with the test's initial period."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.0, 4.5))
    for record, spectrum in zip(plan.records, spectra):
        ax.plot(spectrum.periods, spectrum.pseudo_acceleration / 9.81, label=record.name)
    ax.axvline(period, color='k', linestyle=':', label=f'test T = {period:.3g} s')
    ax.set_xscale('log')
    ax.set_xlabel('period T [s]')
    ax.set_ylabel('pseudo-acceleration Sa [g]')
    damping = spectra[0].damping if spectra else 0.05
    ax.set_title(f'{plan.test_id}: {100 * damping:g} % damped response spectra (scale 1)')
    ax.grid(True, which='both', alpha=0.3)
    ax.legend(fontsize='small')
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def plot_demand(plan: Plan, outcomes: Sequence[RunOutcome], limits: BridgeLimits,
                path: Path) -> Path:
    """The actuator's demand against the scale factor, one line per record/variation."""
    plt = pyplot()
    groups: dict[tuple[int, tuple[float, ...]], list[RunOutcome]] = {}
    for o in outcomes:
        groups.setdefault((o.run.record, o.run.values), []).append(o)
    panels = [('peak stroke [mm]', 'peak_stroke', 1e3, limits.max_displacement),
              ('largest increment per step [mm]', 'max_increment', 1e3, limits.max_increment),
              ('peak velocity [m/s]', 'peak_velocity', 1.0, limits.value('max_velocity')),
              ('peak force [kN]', 'peak_force', 1e-3, limits.max_force)]
    fig, axes = plt.subplots(2, 2, figsize=(10.0, 7.0), sharex=True)
    for ax, (label, attribute, factor, limit) in zip(axes.flat, panels):
        for (record, values), items in list(groups.items())[:MAX_LINES]:
            items = sorted(items, key=lambda o: o.run.scale)
            scales = np.array([o.run.scale for o in items])
            data = np.array([getattr(o, attribute) for o in items]) * factor
            name = plan.records[record].name
            if values:
                name += ' ' + ', '.join(f'{v.name.split(".")[-1]}={x:g}'
                                        for v, x in zip(plan.variations, values))
            ax.plot(scales, data, marker='o', markersize=3, label=name)
        if limit is not None:
            ax.axhline(limit * factor, color='r', linestyle='--', label='bridge limit')
        elif attribute == 'peak_velocity':
            ax.text(0.5, 0.5, 'no step_duration: velocity not known', ha='center',
                    transform=ax.transAxes)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel('scale factor')
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.suptitle(f'{plan.test_id}: actuator {plan.dof_name}', y=0.99, fontsize='medium')
    fig.legend(handles, labels, loc='upper center', bbox_to_anchor=(0.5, 0.955), ncol=3,
               fontsize='small')
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 0.86))
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
