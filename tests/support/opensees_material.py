"""Driving OpenSees uniaxial materials through a displacement history (openseespy, child).

openseespy runs in a child process with its bundled libraries on ``LD_LIBRARY_PATH`` (as the
OpenSees site does), so a failing import cannot take the test process down. ``setStrain``
sets the trial strain and commits it, one history point at a time.
"""

from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
from collections.abc import Sequence

import numpy as np

from pd_actuator_bridge.opensees_site import opensees_environment

_SCRIPT = r'''
import json, sys
import openseespy.opensees as ops
spec = json.loads(sys.stdin.read())
results = []
for material in spec['materials']:
    ops.wipe()
    ops.uniaxialMaterial(*material)
    ops.testUniaxialMaterial(material[1])
    stress, tangent = [], []
    for x in spec['history']:
        ops.setStrain(x)
        stress.append(ops.getStress())
        tangent.append(ops.getTangent())
    results.append([stress, tangent])
print(json.dumps(results))
'''


@functools.cache
def opensees_available() -> bool:
    """Whether openseespy imports in a child process."""
    result = subprocess.run([sys.executable, '-c', 'import openseespy.opensees'],
                            capture_output=True, timeout=60, check=False,
                            env=opensees_environment(dict(os.environ)))
    return result.returncode == 0


def opensees_responses(materials: Sequence[Sequence[object]], history: Sequence[float]
                       ) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(force, tangent)`` of each ``uniaxialMaterial(*material)`` at every displacement.

    Each entry of ``materials`` is the argument list of ``ops.uniaxialMaterial`` (type, tag,
    parameters...); all of them run in one child process.
    """
    spec = {'materials': [list(material) for material in materials],
            'history': [float(x) for x in history]}
    result = subprocess.run([sys.executable, '-c', _SCRIPT], input=json.dumps(spec),
                            capture_output=True, text=True, timeout=120, check=False,
                            env=opensees_environment(dict(os.environ)))
    if result.returncode != 0:
        msg = f'openseespy failed: {result.stderr.strip()[-500:]}'
        raise RuntimeError(msg)
    lines = [line for line in result.stdout.splitlines() if line.startswith('[')]
    return [(np.array(stress), np.array(tangent)) for stress, tangent in json.loads(lines[-1])]


def opensees_forces(material: Sequence[object], history: Sequence[float]) -> np.ndarray:
    """Forces of one material at each displacement (see :func:`opensees_responses`)."""
    return opensees_responses([material], history)[0][0]
