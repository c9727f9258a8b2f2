"""Topic names of the step protocol (relative to a node's namespace, and absolute).

A test without substructures uses the default site ``''``: ``/pd/step_command`` etc.; a
substructured test has one set per site under ``/pd/<site>/``.
"""

from __future__ import annotations

__all__ = ['DEFAULT_SITE', 'GLOBAL_EMERGENCY_STOP', 'NAMESPACE', 'site_topic', 'site_topic_name']

#: The namespace of the test's nodes.
NAMESPACE = '/pd'
#: The site of a test without substructures.
DEFAULT_SITE = ''
#: Absolute topic every bridge and the integrator take emergency stops from (lab-wide).
GLOBAL_EMERGENCY_STOP = '/pd/emergency_stop'


def site_topic(site: str, name: str) -> str:
    """Relative topic ``name`` of ``site`` (``step_command`` or ``<site>/step_command``)."""
    return f'{site}/{name}' if site else name


def site_topic_name(site: str, name: str) -> str:
    """Absolute topic ``name`` of ``site`` (``/pd/<site>/<name>``; ``/pd/<name>`` for '')."""
    return f'{NAMESPACE}/{site_topic(site, name)}'
