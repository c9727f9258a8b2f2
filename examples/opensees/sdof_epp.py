"""The thesis's column as an OpenSees SDOF: genericClient (served by ./pd serve) or its twin.

    python sdof_epp.py --element generic --port 44000 --integrator explicit --out u.txt
    python sdof_epp.py --element numerical --integrator newton --out u.txt

The twin is the same model with a zeroLength element and uniaxialMaterial ElasticPP (the
simulated specimen's law) in place of the genericClient element. The record is El Centro 1940
NS (the project's copy), 5 % Rayleigh damping on the mass.
"""

from __future__ import annotations

import math

import common
import openseespy.opensees as ops

MASS = 2543.4  # kg
STIFFNESS = 312559.0  # N/m
YIELD_FORCE = 10000.0  # N


def build(element: str, port: int) -> None:
    """The model: a fixed node 1, the column top node 2 with the mass."""
    ops.wipe()
    ops.model('basic', '-ndm', 1, '-ndf', 1)
    ops.node(1, 0.0)
    ops.node(2, 0.0)
    ops.fix(1, 1)
    ops.mass(2, MASS)
    if element == 'generic':
        # The one line that changes: the tested column is served over TCP.
        ops.element('genericClient', 1, '-node', 2, '-dof', 1, '-server', port, '127.0.0.1')
    else:
        ops.uniaxialMaterial('ElasticPP', 1, STIFFNESS, YIELD_FORCE / STIFFNESS)
        ops.element('zeroLength', 1, 1, 2, '-mat', 1, '-dir', 1)
    omega = math.sqrt(STIFFNESS / MASS)
    ops.rayleigh(2 * 0.05 * omega, 0.0, 0.0, 0.0)


def main() -> None:
    """Build, run, write the top's displacement and force per step."""
    parser = common.parser(__doc__)
    args = parser.parse_args()
    build(args.element, args.port)
    common.ground_motion(dt=0.01, scale=args.scale)
    common.analysis(args.integrator)
    common.run(args, nodes=[2], elements=[1])


if __name__ == '__main__':
    main()
