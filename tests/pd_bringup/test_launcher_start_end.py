"""run_test's start and end: the shipped Fast DDS discovery profile, and the specimen side
stopped (and the summary printed) once the integrator has written its summary, while it still
writes its figures."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from pd_bringup.plan import DDS_PROFILE_VARIABLES, Child, LaunchPlan, discovery_profile
from pd_bringup.supervisor import Supervisor


def test_the_discovery_profile_is_shipped_and_never_overrides_the_users() -> None:
    env = discovery_profile({'RMW_IMPLEMENTATION': 'rmw_fastrtps_cpp'})
    profile = Path(env['FASTDDS_DEFAULT_PROFILES_FILE'])
    assert profile.is_file() and '<initialAnnouncements>' in profile.read_text()
    for name in DDS_PROFILE_VARIABLES:  # the user's own profile file wins
        assert discovery_profile({name: '/etc/my_profile.xml'}) == {}
    assert discovery_profile({'RMW_IMPLEMENTATION': 'rmw_cyclonedds_cpp'}) == {}


def _python(code: str) -> list[str]:
    return [sys.executable, '-c', code]


def _plan(tmp_path: Path, integrator: str) -> LaunchPlan:
    children = [Child(name, 'simulator', '', '', _python('import time; time.sleep(60)'))
                for name in ('specimen', 'bridge')]
    return LaunchPlan(test_id='t', n_steps=1, out=tmp_path, site_mode='bridge', physical=False,
                      key_file=None, environment={}, children=children,
                      integrator=_python(integrator))


def test_the_specimen_side_stops_once_the_summary_is_written(tmp_path: Path) -> None:
    # An "integrator" that writes its summary, then takes 1.5 s for its figures.
    integrator = ('import json, pathlib, time; time.sleep(0.3); '
                  f'pathlib.Path({str(tmp_path)!r}, "summary.json").write_text(json.dumps('
                  '{"steps": 1})); time.sleep(1.5); '
                  f'pathlib.Path({str(tmp_path)!r}, "figure.png").write_text("x")')
    (tmp_path / 'summary.json').write_text(json.dumps({'steps': 0}))  # an earlier run's
    time.sleep(0.05)
    seen: list[tuple[bool, list[int | None], bool]] = []

    def on_outputs() -> None:
        assert supervisor.integrator is not None
        seen.append((supervisor.integrator.process.poll() is None,
                     [item.process.poll() for item in supervisor.children],
                     (tmp_path / 'figure.png').exists()))

    supervisor = Supervisor(_plan(tmp_path, integrator), 'restart', {}, None, time.sleep,
                            log=lambda line: None, on_outputs=on_outputs)
    supervisor.start(resume=False)
    try:
        code = supervisor.run()
    finally:
        supervisor.stop()
    assert code == 0
    # Called once, with the integrator still at its figures and the specimen side stopped.
    assert len(seen) == 1
    integrator_alive, children_codes, figure_written = seen[0]
    assert integrator_alive and not figure_written
    assert all(code is not None for code in children_codes)
    assert (tmp_path / 'figure.png').exists()  # run() returned after the integrator ended
