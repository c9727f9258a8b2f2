"""The console's Foxglove feed: its topics, their JSON messages and a layout for them.

With ``--foxglove`` the console also serves the live test to the Foxglove app through
``foxglove-sdk``'s WebSocket server. This module says what goes there (plain data; the node
logs it) and builds the shipped layout (``foxglove.layouts``): the hysteresis loop as an
x-y plot, the histories, the gauges and the status.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import foxglove.layouts as fl

__all__ = ['RESPONSE_FIELDS', 'STATUS_TOPIC', 'foxglove_layout', 'gauges_message',
           'gauges_topic', 'response_message', 'response_topic']

#: The integrator's status (the page's ``test`` block) as JSON.
STATUS_TOPIC = '/pd_console/status'
#: The fields of a response message, one per answered step of a DOF.
RESPONSE_FIELDS = ('t', 'command', 'measured', 'force', 'error', 'indicator')


def _site_name(site: str) -> str:
    return site or 'default'


def response_topic(site: str, dof: str) -> str:
    """The topic of one DOF's response at ``site``."""
    return f'/pd_console/{_site_name(site)}/{dof}'


def gauges_topic(site: str) -> str:
    """The topic of ``site``'s gauges (peak fraction of each limit)."""
    return f'/pd_console/{_site_name(site)}/gauges'


def response_message(row: Iterable[float]) -> dict[str, float]:
    """One answered step of a DOF: SI units (m, N, m2)."""
    return dict(zip(RESPONSE_FIELDS, (float(value) for value in row), strict=True))


def gauges_message(site_json: Mapping[str, Any]) -> dict[str, float]:
    """``site``'s gauges: per limit that is on, the current and the peak fraction."""
    message: dict[str, float] = {}
    for gauge in site_json.get('gauges', []):
        if not gauge['off']:
            message[gauge['name']] = float(gauge['ratio'] or 0.0)
            message[f'{gauge["name"]}_peak'] = float(gauge['peak_ratio'] or 0.0)
    return message


def foxglove_layout(sites: Mapping[str, Iterable[str]]) -> str:
    """A Foxglove layout (JSON) for ``sites`` (site → its DOF names).

    Per DOF the hysteresis loop (x-y), the displacement and force histories; the status and the
    gauges.
    """
    rows: list[fl.SplitItem] = []
    for site, dofs in sites.items():
        for dof in dofs:
            topic = response_topic(site, dof)
            hysteresis = fl.PlotPanel(title=f'{_site_name(site)}/{dof}: hysteresis',
                                      config=fl.PlotConfig(
                                          x_axis_val='custom',
                                          x_axis_label='measured displacement [m]',
                                          y_axis_label='restoring force [N]',
                                          paths=[fl.PlotSeries(
                                              value=f'{topic}.force',
                                              x_value_path=f'{topic}.measured',
                                              label='force vs displacement')]))
            history = fl.PlotPanel(title=f'{_site_name(site)}/{dof}: displacement',
                                   config=fl.PlotConfig(paths=[
                                       fl.PlotSeries(value=f'{topic}.command', label='command'),
                                       fl.PlotSeries(value=f'{topic}.measured',
                                                     label='measured')]))
            force = fl.PlotPanel(title=f'{_site_name(site)}/{dof}: restoring force',
                                 config=fl.PlotConfig(paths=[
                                     fl.PlotSeries(value=f'{topic}.force', label='force')]))
            rows.append(fl.SplitItem(content=fl.SplitContainer(direction='row', items=[
                fl.SplitItem(content=hysteresis), fl.SplitItem(content=history),
                fl.SplitItem(content=force)])))
    status = fl.RawMessagesPanel(title='test status',
                                 config=fl.RawMessagesConfig(topic_path=STATUS_TOPIC))
    gauges = [fl.SplitItem(content=fl.RawMessagesPanel(
        title=f'{_site_name(site)}: limits (fraction)',
        config=fl.RawMessagesConfig(topic_path=gauges_topic(site)))) for site in sites]
    rows.append(fl.SplitItem(proportion=0.6, content=fl.SplitContainer(
        direction='row', items=[fl.SplitItem(content=status), *gauges])))
    layout = fl.Layout(content=fl.SplitContainer(direction='column', items=rows))
    return layout.to_json()
