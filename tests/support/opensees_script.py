"""Reference analyses in openseespy: a script run in a child process on a JSON spec.

The child gets the spec as JSON on stdin (``spec`` in the script) and prints its result as
JSON on its last stdout line; it runs with openseespy's bundled libraries on
``LD_LIBRARY_PATH`` (:func:`opensees_environment`, as the OpenSees site does), so a failing
import or a crash cannot take the test process down. Whether openseespy imports at all:
:func:`support.opensees_material.opensees_available`.

:func:`opensees_script` puts the model-specific body of a test's script after
:data:`PRELUDE` (imports, ``spec``) and two helpers the body may call:

* ``gravity_step(loads)`` (:data:`GRAVITY_STEP`): the nodal ``loads`` (``[tag, *components]``)
  applied in one static ``LoadControl`` step, then held with ``loadConst -time 0``;
* ``transient_setup(integrator, rayleigh=None)`` (:data:`TRANSIENT_SETUP`): ``rayleigh``
  (its four factors) if given, then the transient analysis — ``explicit``: ``algorithm
  Linear`` + ``NewmarkExplicit 0.5``; otherwise ``NormDispIncr 1e-14 50`` + ``Newton`` +
  ``Newmark 0.5 0.25``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from collections.abc import Mapping
from typing import Any

import pytest

from pd_actuator_bridge.opensees_site import opensees_environment

PRELUDE = '''\
import json, sys
import openseespy.opensees as ops
spec = json.loads(sys.stdin.read())
'''

GRAVITY_STEP = '''\
def gravity_step(loads):
    """The nodal loads of one static LoadControl step, then held (loadConst -time 0)."""
    ops.timeSeries('Linear', 1)
    ops.pattern('Plain', 1, 1)
    for tag, *load in loads:
        ops.load(tag, *load)
    ops.constraints('Plain')
    ops.numberer('Plain')
    ops.system('FullGeneral')
    ops.test('NormDispIncr', 1e-14, 20)
    ops.algorithm('Newton')
    ops.integrator('LoadControl', 1.0)
    ops.analysis('Static')
    if ops.analyze(1) != 0:
        sys.exit('gravity analysis failed')
    ops.loadConst('-time', 0.0)
'''

TRANSIENT_SETUP = '''\
def transient_setup(integrator, rayleigh=None):
    """Rayleigh damping (if given) and the transient analysis: explicit or Newmark + Newton."""
    if rayleigh is not None:
        ops.rayleigh(*rayleigh)
    ops.constraints('Plain')
    ops.numberer('Plain')
    ops.system('FullGeneral')
    if integrator == 'explicit':
        ops.algorithm('Linear')
        ops.integrator('NewmarkExplicit', 0.5)
    else:
        ops.test('NormDispIncr', 1e-14, 50)
        ops.algorithm('Newton')
        ops.integrator('Newmark', 0.5, 0.25)
    ops.analysis('Transient')
'''


def opensees_script(body: str) -> str:
    """A child script: :data:`PRELUDE`, the two helpers, then ``body`` (dedented)."""
    return '\n'.join([PRELUDE, GRAVITY_STEP, TRANSIENT_SETUP, textwrap.dedent(body)])


def run_opensees(script: str, spec: Mapping[str, Any], *, timeout: float = 300.0) -> Any:
    """Run ``script`` with ``spec`` as JSON on stdin in a child; the JSON of its last line.

    A failing child fails the test with the end of its stderr.
    """
    result = subprocess.run([sys.executable, '-c', script], input=json.dumps(spec),
                            capture_output=True, text=True, timeout=timeout, check=False,
                            env=opensees_environment(dict(os.environ)))
    if result.returncode != 0:
        pytest.fail(f'openseespy child exited {result.returncode}:\n{result.stderr[-2000:]}',
                    pytrace=False)
    return json.loads(result.stdout.strip().splitlines()[-1])
