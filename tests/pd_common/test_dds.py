"""The shipped Fast DDS profile (pd_common.dds): installed, read by Fast DDS without an error,
applied by every node before rclpy.init, and never in place of the user's own profile."""

from __future__ import annotations

import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from pd_common.dds import (
    DDS_PROFILE_VARIABLES,
    WORKING_DIRECTORY_PROFILE,
    discovery_profile,
    use_discovery_profile,
)

NS = {'dds': 'http://www.eprosima.com'}


def shipped() -> Path:
    env = discovery_profile({'RMW_IMPLEMENTATION': 'rmw_fastrtps_cpp'})
    return Path(env['FASTDDS_DEFAULT_PROFILES_FILE'])


def seconds(element: ET.Element | None) -> float:
    assert element is not None
    return (float(element.findtext('dds:sec', '0', NS))
            + float(element.findtext('dds:nanosec', '0', NS)) * 1e-9)


def test_the_profile_is_installed_with_the_documented_periods() -> None:
    profile = shipped()
    assert profile.is_file() and profile.parent.name == 'config'
    discovery = ET.parse(profile).getroot().find(
        'dds:profiles/dds:participant/dds:rtps/dds:builtin/dds:discovery_config', NS)
    assert discovery is not None
    assert seconds(discovery.find('dds:leaseAnnouncement', NS)) == pytest.approx(0.25)
    initial = discovery.find('dds:initialAnnouncements', NS)
    assert initial is not None and initial.findtext('dds:count', None, NS) == '50'
    assert seconds(initial.find('dds:period', NS)) == pytest.approx(0.1)
    # announcements far inside the lease (Fast DDS's 20 s default: nothing sets another)
    assert discovery.find('dds:leaseDuration', NS) is None


def test_a_profile_in_the_working_directory_wins(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    env = {'RMW_IMPLEMENTATION': 'rmw_fastrtps_cpp'}
    assert discovery_profile(env, tmp_path)  # (none there yet)
    (tmp_path / WORKING_DIRECTORY_PROFILE).write_text('<dds/>')
    assert discovery_profile(env, tmp_path) == {}
    monkeypatch.chdir(tmp_path)
    use_discovery_profile(env)
    assert env == {'RMW_IMPLEMENTATION': 'rmw_fastrtps_cpp'}
    # (one Fast DDS is told to skip is no profile of the user's)
    assert discovery_profile({**env, 'SKIP_DEFAULT_XML_FILE': '1'}, tmp_path)


def test_the_users_profile_or_another_rmw_wins() -> None:
    for name in DDS_PROFILE_VARIABLES:
        assert discovery_profile({name: '/etc/my_profile.xml'}) == {}
        env = {name: '/etc/my_profile.xml'}
        use_discovery_profile(env)
        assert env == {name: '/etc/my_profile.xml'}
    assert discovery_profile({'RMW_IMPLEMENTATION': 'rmw_cyclonedds_cpp'}) == {}
    env = {'RMW_IMPLEMENTATION': 'rmw_fastrtps_cpp'}
    use_discovery_profile(env)
    assert env['FASTDDS_DEFAULT_PROFILES_FILE'] == str(shipped())


PROBE = (
    'import os\n'
    'from pd_common.ros import init_with_stop_flag\n'
    'import rclpy\n'
    'init_with_stop_flag([])\n'
    'node = rclpy.create_node("profile_probe")\n'
    'print(os.environ.get("FASTDDS_DEFAULT_PROFILES_FILE", ""))\n'
    'node.destroy_node()\n'
    'rclpy.try_shutdown()\n')


def probe(**extra: str) -> subprocess.CompletedProcess[str]:
    """A node made the nodes' way (``init_with_stop_flag``), no profile selected but ``extra``."""
    env = {name: value for name, value in os.environ.items() if name not in DDS_PROFILE_VARIABLES}
    env.update(ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', ROS_DOMAIN_ID='97', **extra)
    done = subprocess.run([sys.executable, '-c', PROBE], env=env, capture_output=True,
                          text=True, timeout=60, check=False)
    assert done.returncode == 0, done.stderr
    return done


def test_fast_dds_reads_the_profile_without_an_error_and_every_node_applies_it(
        tmp_path: Path) -> None:
    """The variable is set before the node's participant exists, and Fast DDS parses the file
    without a word; a misspelt element would be an error line on stderr (its default then
    silently applies), as a copy of the profile with one shows."""
    done = probe()
    assert done.stdout.strip() == str(shipped())
    assert 'XMLPARSER' not in done.stderr and 'Error' not in done.stderr, done.stderr
    bad = tmp_path / 'bad.xml'
    bad.write_text(shipped().read_text().replace('leaseAnnouncement', 'leaseAnouncement'))
    done = probe(FASTDDS_DEFAULT_PROFILES_FILE=str(bad))
    assert done.stdout.strip() == str(bad)
    assert 'Error' in done.stderr
