"""Sections a test's own test file needs only to be a whole test file.

Every reader of a test file validates the whole file against the typed schema
(``pd_common.config.read_test_file``), so a test that writes a file for one reader (the
specimen simulator, a driver) gives the sections it does not exercise too.
"""

from __future__ import annotations

from typing import Any

#: A short inline ground motion (m/s2).
INLINE_GROUND_MOTION: dict[str, Any] = {
    'units': 'm/s2', 'inline': {'dt': 0.01, 'acceleration': [0.0, 0.5, -0.5, 0.0]}}

#: A one-DOF structure (kg, N/m).
ONE_DOF_STRUCTURE: dict[str, Any] = {
    'dof_names': ['u'], 'mass': 2543.4, 'initial_stiffness': 1.0e6}
