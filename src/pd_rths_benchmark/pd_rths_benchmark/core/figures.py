"""The vRTHS benchmark's figures (matplotlib, Agg; imported only when a figure is drawn).

* ``tracking.png``: desired x_d and measured x_m of the actuator against time, a zoom on the
  strongest second, and the tracking error x_m − x_d;
* ``floors.png``: each floor's displacement in the hybrid run against the reference (the full
  structure without partition), and the difference.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pd_core.plotting import pyplot

from .benchmark import BenchmarkRun

__all__ = ['plot_floors', 'plot_tracking']

MM = 1e3


def _title(run: BenchmarkRun) -> str:
    return (f'vRTHS benchmark case {run.case}, {run.controller}, loop {run.loop}: '
            f'J2 = {run.j["J2"]:.2f} %, J4 = {run.j["J4"]:.2f} %')


def plot_tracking(run: BenchmarkRun, path: Path) -> Path:
    """x_d vs x_m, a zoom around the peak of x_d, and the error, mm."""
    plt = pyplot()
    t, x_d, x_m = run.t, run.x_d * MM, run.x_m * MM
    peak = int(np.argmax(np.abs(x_d)))
    window = (t >= t[peak] - 0.5) & (t <= t[peak] + 0.5)
    fig, axes = plt.subplots(3, 1, figsize=(9, 8))
    axes[0].plot(t, x_d, label='desired $x_d$', lw=0.8)
    axes[0].plot(t, x_m, label='measured $x_m$', lw=0.8, ls='--')
    axes[0].set_ylabel('displacement [mm]')
    axes[0].legend(loc='upper right')
    axes[1].plot(t[window], x_d[window], label='$x_d$')
    axes[1].plot(t[window], x_m[window], label='$x_m$', ls='--')
    axes[1].set_ylabel('zoom [mm]')
    axes[1].legend(loc='upper right')
    axes[2].plot(t, x_m - x_d, lw=0.6, color='tab:red')
    axes[2].set_ylabel('$x_m - x_d$ [mm]')
    axes[2].set_xlabel('time [s]')
    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.suptitle(_title(run), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_floors(run: BenchmarkRun, path: Path) -> Path:
    """Each floor of the hybrid run against the reference, and the difference, mm."""
    plt = pyplot()
    fig, axes = plt.subplots(3, 2, figsize=(11, 8), sharex=True,
                             gridspec_kw={'width_ratios': [3, 2]})
    for floor in range(3):
        hybrid = run.floors[:, floor] * MM
        reference = run.reference[:, floor] * MM
        left, right = axes[floor]
        left.plot(run.t_floors, reference, label='reference', lw=0.9)
        left.plot(run.t_floors, hybrid, label='hybrid', lw=0.8, ls='--')
        left.set_ylabel(f'floor {floor + 1} [mm]')
        right.plot(run.t_floors, hybrid - reference, lw=0.6, color='tab:red')
        right.set_ylabel('hybrid − reference [mm]')
        for ax in (left, right):
            ax.grid(True, alpha=0.3)
    axes[0][0].legend(loc='upper right')
    axes[2][0].set_xlabel('time [s]')
    axes[2][1].set_xlabel('time [s]')
    fig.suptitle(_title(run), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
