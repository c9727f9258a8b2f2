"""A one-bay frame after OpenFresco's OneBayFrame example: both columns tested, one element.

    python one_bay_frame.py --element generic --port 44000 --out u.txt   # both columns served
    python one_bay_frame.py --element numerical --out u.txt              # the twin

OpenFresco's ``OneBayFrame_Local.tcl`` (EXAMPLES/OneBayFrame, kip and inch): two columns from
the ground to the beam-level nodes 3 (x = 0) and 4 (x = 100 in), 54 in high, tested as two
``expElement twoNodeLink`` shear links (initial stiffness 2.8 and 5.6 kip/in, the left one
``Steel02`` with F_y = 1.5 kip and b = 0.01, the right one elastic), a horizontal truss
between the column tops (EA/L = 200 / 100 = 2 kip/in) that stays in OpenSees, lumped masses
0.04 and 0.02 kip s²/in, mass-proportional damping ``alphaM = 1.010017396536`` 1/s,
``NewmarkExplicit 0.5``, El Centro NS along x.

Here both columns are **one** ``genericClient`` element of two DOFs (node 3 dof 1, node 4
dof 1: the test's ``structure.dof_names`` ``[col1, col2]``), served by ``./pd serve
src/pd_integrator/config/serve_one_bay_frame.yaml``, whose simulated specimen has two
independent elements (``topology: independent``: one per DOF, each column's force a function
of its own top's displacement, the columns' bases being fixed).

The twin has each column as ``twoNodeLink`` (shear, local y along global x) with the law of
the simulated specimen: column 1 the project's ``bilinear`` (kinematic hardening b = 0.01),
which is OpenSees's ``Steel01`` without isotropic hardening, so the twin uses ``Steel01``.
OpenFresco's ``Steel02`` (Giuffré-Menegotto-Pinto, R0 = 18.5) has a curved transition no
project specimen model reproduces; ``Steel01`` is its bilinear limit (R0 → ∞), so the served
run and its twin can agree to round-off. Column 2: ``elastic`` and ``Elastic``.

Units: SI, converted from OpenFresco's kip and inch with 1 kip = 4448.2216152605 N and
1 in = 0.0254 m (stiffness kip/in x 175126.8 N/m, mass kip s²/in x 175126.8 kg, force
kip x 4448.2 N); ``serve_one_bay_frame.yaml`` holds the same values. The record is this
project's El Centro in g (``common.ground_motion``), applied with dt = 0.01 s (OpenFresco
used its own file at 0.02 s).
"""

from __future__ import annotations

import common
import openseespy.opensees as ops

KIP = 4448.2216152605  # N
INCH = 0.0254  # m
MASSES = (0.04 * KIP / INCH, 0.02 * KIP / INCH)  # kg, nodes 3 and 4
STIFFNESS = (2.8 * KIP / INCH, 5.6 * KIP / INCH)  # N/m, columns 1 and 2
SPRING = 2.0 * KIP / INCH  # N/m, the truss between the column tops (EA/L)
YIELD_FORCE = 1.5 * KIP  # N, column 1
HARDENING = 0.01  # column 1's post-yield stiffness ratio
ALPHA_M = 1.010017396536  # 1/s, D = alphaM M (OpenFresco's value)
WIDTH, HEIGHT = 100.0 * INCH, 54.0 * INCH  # m


def build(element: str, port: int) -> None:
    """Ground nodes 1 and 2, column tops 3 and 4 (2-D, vertical DOFs fixed), the truss."""
    ops.wipe()
    ops.model('basic', '-ndm', 2, '-ndf', 2)
    ops.node(1, 0.0, 0.0)
    ops.node(2, WIDTH, 0.0)
    ops.node(3, 0.0, HEIGHT, '-mass', MASSES[0], MASSES[0])
    ops.node(4, WIDTH, HEIGHT, '-mass', MASSES[1], MASSES[1])
    ops.fix(1, 1, 1)
    ops.fix(2, 1, 1)
    ops.fix(3, 0, 1)
    ops.fix(4, 0, 1)
    if element == 'generic':
        # The one line that changes: both columns are one served element of two DOFs.
        ops.element('genericClient', 1, '-node', 3, 4, '-dof', 1, '-dof', 1,
                    '-server', port, '127.0.0.1')
    else:
        ops.uniaxialMaterial('Steel01', 1, YIELD_FORCE, STIFFNESS[0], HARDENING)
        ops.uniaxialMaterial('Elastic', 2, STIFFNESS[1])
        # Shear links: local x up the column, local y (dir 2) along global x.
        for tag, (i, j), material in ((1, (1, 3), 1), (2, (2, 4), 2)):
            ops.element('twoNodeLink', tag, i, j, '-mat', material, '-dir', 2,
                        '-orient', 1.0, 0.0, 0.0)
    ops.uniaxialMaterial('Elastic', 3, SPRING * WIDTH)  # E with A = 1, L = WIDTH
    ops.element('Truss', 3, 3, 4, 1.0, 3)
    ops.rayleigh(ALPHA_M, 0.0, 0.0, 0.0)


def column_forces(element: str) -> list[float]:
    """Each column's horizontal force on its top node (node 3, node 4)."""
    if element == 'generic':
        # genericClient's forces: its nodes' every DOF (node 3 x, y, node 4 x, y).
        forces = ops.eleResponse(1, 'forces')
        return [float(forces[0]), float(forces[2])]
    # twoNodeLink's global forces: node i (x, y), node j (x, y).
    return [float(ops.eleResponse(tag, 'forces')[2]) for tag in (1, 2)]


def main() -> None:
    """Build, run, write the column tops' displacements and the columns' forces."""
    args = common.parser(__doc__).parse_args()
    build(args.element, args.port)
    common.ground_motion(dt=0.01, scale=args.scale)
    common.analysis(args.integrator)
    common.run(args, nodes=[3, 4], elements=[],
               forces=lambda: column_forces(args.element))


if __name__ == '__main__':
    main()
