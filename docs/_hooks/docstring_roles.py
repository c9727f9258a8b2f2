"""MkDocs hook: Sphinx roles in docstrings read as plain code on the API pages.

Some docstrings name objects the Sphinx way (``:class:`~.base.Integrator```); mkdocstrings
renders the role's text literally (``:class:Integrator``). This hook drops the role and
shortens the name as Sphinx would: ``~`` keeps the last component, a leading ``.`` (a name
relative to the module) is dropped.
"""

from __future__ import annotations

import re
from typing import Any

ROLE = re.compile(r':(?:py:)?(?:attr|class|const|data|exc|func|meth|mod|obj):<code>([^<]*)</code>')


def _name(match: re.Match[str]) -> str:
    text = match.group(1)
    if text.startswith('~'):
        text = text[1:].rsplit('.', 1)[-1]
    return f'<code>{text.lstrip(".")}</code>'


def on_page_content(html: str, **_: Any) -> str:
    """Replace each rendered Sphinx role by its name in code.

    Args:
        html: The page's HTML.
        **_: The other arguments MkDocs passes (page, config, files).

    Returns:
        The page's HTML without the roles' markers.
    """
    return ROLE.sub(_name, html)
