"""A two-storey shear frame after OpenFresco's TwoStoryShear example, storey 1 tested.

    python two_story_shear.py --element generic --port 44000 --out u.txt   # storey 1 served
    python two_story_shear.py --element numerical --out u.txt              # the twin

Storey 1 (between the ground and floor 1) is the experimental element; storey 2 stays in
OpenSees (``zeroLength`` with ``uniaxialMaterial Elastic``). The twin has storey 1 as
``zeroLength`` with ``ElasticPP``: the law of the simulated specimen of ``serve_two_story.yaml``.
Units: SI.

Only the layout is OpenFresco's: its ``TwoStoryShear_Local.tcl`` (kip, in) has two equal floor
masses 4/386.1 kip s²/in, both storeys tested (``twoNodeLink``, ``Steel02`` 2.8 kip/in with
F_y = 1.5 kip), no damping and twice El Centro; the numbers here are this example's own.
"""

from __future__ import annotations

import math

import common
import openseespy.opensees as ops

MASSES = (2.0e4, 1.5e4)  # kg, floors 1 and 2
STIFFNESS = (4.0e6, 3.0e6)  # N/m, storeys 1 and 2
YIELD_FORCE = 6.0e4  # N, storey 1


def build(element: str, port: int) -> None:
    """Ground node 1, floors 2 and 3 (1-D), storey elements 1 and 2."""
    ops.wipe()
    ops.model('basic', '-ndm', 1, '-ndf', 1)
    for tag in (1, 2, 3):
        ops.node(tag, 0.0)
    ops.fix(1, 1)
    ops.mass(2, MASSES[0])
    ops.mass(3, MASSES[1])
    if element == 'generic':
        # The one line that changes: storey 1 is served over TCP (its drift is node 2's u).
        ops.element('genericClient', 1, '-node', 2, '-dof', 1, '-server', port, '127.0.0.1')
    else:
        ops.uniaxialMaterial('ElasticPP', 1, STIFFNESS[0], YIELD_FORCE / STIFFNESS[0])
        ops.element('zeroLength', 1, 1, 2, '-mat', 1, '-dir', 1)
    ops.uniaxialMaterial('Elastic', 2, STIFFNESS[1])
    ops.element('zeroLength', 2, 2, 3, '-mat', 2, '-dir', 1)
    # 5 % mass-proportional damping at the first mode.
    k1, k2 = STIFFNESS
    m1, m2 = MASSES
    a, b, c = m1 * m2, -((k1 + k2) * m2 + k2 * m1), k1 * k2
    omega1 = math.sqrt((-b - math.sqrt(b * b - 4 * a * c)) / (2 * a))
    ops.rayleigh(2 * 0.05 * omega1, 0.0, 0.0, 0.0)


def main() -> None:
    """Build, run, write the floors' displacements and storey 1's force."""
    args = common.parser(__doc__).parse_args()
    build(args.element, args.port)
    common.ground_motion(dt=0.01, scale=args.scale)
    common.analysis(args.integrator)
    common.run(args, nodes=[2, 3], elements=[1])


if __name__ == '__main__':
    main()
