"""What the OpenSees examples share: the record, the analysis, the output (plain openseespy)."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

import numpy as np
import openseespy.opensees as ops

RECORD = (Path(__file__).resolve().parents[2] / 'src' / 'pd_integrator' / 'data'
          / 'ground_motions' / 'elcentro_1940_ns_chopra.csv')
G = 9.81


def parser(doc: str | None) -> argparse.ArgumentParser:
    """The examples' options."""
    result = argparse.ArgumentParser(description=doc,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    result.add_argument('--element', choices=('generic', 'numerical'), default='generic',
                        help='genericClient (served by ./pd serve) or the numerical twin')
    result.add_argument('--port', type=int, default=44000, help="the server's port")
    result.add_argument('--integrator', choices=('explicit', 'newton'), default='explicit',
                        help='NewmarkExplicit, or Newmark (average acceleration) with Newton')
    result.add_argument('--steps', type=int, default=1000, help='steps of 0.01 s')
    result.add_argument('--scale', type=float, default=1.0, help='scale of the record')
    result.add_argument('--out', required=True, help='text file: time, then per node u, '
                        'per element its basic force')
    return result


def ground_motion(dt: float, direction: int = 1, scale: float = 1.0) -> None:
    """El Centro 1940 NS (in g, 0.02 s), uniform excitation along ``direction``."""
    data = np.loadtxt(RECORD, delimiter=',', comments='#')
    values = (data[:, 1] * G * scale).tolist()
    ops.timeSeries('Path', 1, '-dt', float(data[1, 0] - data[0, 0]), '-values', *values)
    ops.pattern('UniformExcitation', 1, direction, '-accel', 1)
    del dt


def analysis(kind: str) -> None:
    """NewmarkExplicit (one trial per step) or Newmark with Newton (iterations, then commit)."""
    ops.constraints('Plain')
    ops.numberer('Plain')
    ops.system('FullGeneral')
    if kind == 'explicit':
        ops.algorithm('Linear')
        ops.integrator('NewmarkExplicit', 0.5)
    else:
        ops.test('NormDispIncr', 1e-14, 100)
        ops.algorithm('Newton')
        ops.integrator('Newmark', 0.5, 0.25)
    ops.analysis('Transient')


def run(args: argparse.Namespace, nodes: list[int], elements: list[int],
        dof: int = 1, forces: Callable[[], list[float]] | None = None) -> None:
    """``args.steps`` steps of 0.01 s; write time, the nodes' displacements, the forces.

    The forces are each element's last basic force, then ``forces()`` if given.
    """
    rows = []
    for _ in range(args.steps):
        if ops.analyze(1, 0.01) != 0:
            msg = 'analysis failed'
            raise SystemExit(msg)
        row = [ops.getTime()]
        row += [ops.nodeDisp(node, dof) for node in nodes]
        row += [ops.eleResponse(element, 'forces')[-1] for element in elements]
        row += forces() if forces is not None else []
        rows.append(row)
    np.savetxt(args.out, np.array(rows), fmt='%.17g')
    ops.wipe()  # destroys the genericClient: it sends DIE, the test ends
