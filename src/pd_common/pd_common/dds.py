"""The shipped Fast DDS participant profile: how the lab's processes find each other quickly.

``share/pd_common/config/fastdds_discovery.xml`` changes two discovery periods of Fast DDS and
nothing else (transports, QoS and the discovery range ``ROS_AUTOMATIC_DISCOVERY_RANGE`` stay
the rmw's):

* a new participant announces itself every 100 ms for its first 5 s (Fast DDS: 5 times, then
  every 3 s), so the processes of a test, started together, meet at once;
* a running participant announces itself every 250 ms (Fast DDS: every 3 s). A new process
  (``./pd control``, the console, a restarted node) learns a running node's endpoints from its
  announcement: with Fast DDS's period it waited up to 3 s for one (measured here: 0.1–3.0 s
  before ``./pd control`` heard the integrator's status), now under 0.5 s. The cost is
  a few hundred bytes to each local peer four times a second.

Every node applies it before ``rclpy.init`` (:func:`use_discovery_profile`), and ``run_test``
hands it to every process it starts; a profile file the user selected
(``FASTDDS_DEFAULT_PROFILES_FILE``, or a ``DEFAULT_FASTDDS_PROFILES.xml`` in the working
directory, which Fast DDS loads by itself) always wins.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, MutableMapping
from pathlib import Path

from .resources import ResourceError, share_file

__all__ = ['DDS_PROFILE_VARIABLES', 'DISCOVERY_PROFILE', 'WORKING_DIRECTORY_PROFILE',
           'discovery_profile', 'use_discovery_profile']

#: The environment variables by which Fast DDS loads a profile file (the user's choice wins).
DDS_PROFILE_VARIABLES = ('FASTDDS_DEFAULT_PROFILES_FILE', 'FASTRTPS_DEFAULT_PROFILES_FILE')
#: The shipped profile, in ``share/pd_common/config``.
DISCOVERY_PROFILE = 'fastdds_discovery.xml'
#: The profile file Fast DDS also loads from the working directory (the user's too).
WORKING_DIRECTORY_PROFILE = 'DEFAULT_FASTDDS_PROFILES.xml'


def discovery_profile(env: Mapping[str, str], cwd: Path | None = None) -> dict[str, str]:
    """The variables that give a process with environment ``env`` the shipped profile.

    ``{}`` when ``env`` selects a profile file already, the working directory (``cwd``,
    default the process's) holds Fast DDS's ``DEFAULT_FASTDDS_PROFILES.xml`` (which Fast DDS
    loads unless ``SKIP_DEFAULT_XML_FILE=1``), the rmw is not Fast DDS, or the profile is not
    installed.
    """
    if any(env.get(name) for name in DDS_PROFILE_VARIABLES):
        return {}
    if (env.get('SKIP_DEFAULT_XML_FILE') != '1'
            and ((cwd or Path.cwd()) / WORKING_DIRECTORY_PROFILE).is_file()):
        return {}
    if not env.get('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp').startswith('rmw_fastrtps'):
        return {}
    try:
        path = share_file('pd_common', 'config', DISCOVERY_PROFILE)
    except ResourceError:
        return {}
    if not path.is_file():
        return {}
    return {DDS_PROFILE_VARIABLES[0]: str(path)}


def use_discovery_profile(env: MutableMapping[str, str] | None = None) -> None:
    """Give this process (``env``: default ``os.environ``) the shipped profile.

    Call it before ``rclpy.init``: Fast DDS reads the variable when the participant is made.
    """
    target = os.environ if env is None else env
    target.update(discovery_profile(target))
