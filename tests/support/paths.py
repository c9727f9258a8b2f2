"""The paths the tests share: the repository, its shipped test files, records and install."""

from __future__ import annotations

from pathlib import Path

#: The repository's root.
REPO = Path(__file__).resolve().parents[2]
#: The shipped test files (``src/pd_integrator/config``).
CONFIG = REPO / 'src' / 'pd_integrator' / 'config'
#: The thesis's column: the default test of ``./pd run``.
DEFAULT_TEST = CONFIG / 'default_test.yaml'
#: The three-storey frame with two experimental sites.
TWO_SITES = CONFIG / 'three_story_two_sites.yaml'
#: The shipped ground-motion records.
GROUND_MOTIONS = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions'
#: El Centro 1940 NS (public domain), in g.
ELCENTRO = GROUND_MOTIONS / 'elcentro_1940_ns_chopra.csv'
#: The Python packages of ``src/`` (each an ament_python package with its ``setup.py``; the
#: generated ``pd_msgs`` is not one of them), sorted.
PACKAGES = tuple(sorted(path.parent.name for path in (REPO / 'src').glob('*/setup.py')))
#: The colcon install space (``./pd setup``).
INSTALL = REPO / 'ros2_ws' / 'install'
