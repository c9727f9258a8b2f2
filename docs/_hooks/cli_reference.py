"""MkDocs hook: the command-line reference shows ``./pd help`` as the script prints it.

A page that holds the line ``<!-- pd help -->`` gets, in its place, the output of
``bash pd help`` (run from the repository root) in a code block, so the page cannot drift
from the script.
"""

from __future__ import annotations

import subprocess
from pathlib import Path
from typing import Any

MARKER = '<!-- pd help -->'
REPO = Path(__file__).resolve().parents[2]


def pd_help() -> str:
    """Return what ``./pd help`` prints.

    Returns:
        The help text, one command per line.

    Raises:
        RuntimeError: The script failed or printed nothing.
    """
    done = subprocess.run(['bash', str(REPO / 'pd'), 'help'], capture_output=True, text=True,
                          cwd=REPO, timeout=60, check=False)
    if done.returncode != 0 or not done.stdout.strip():
        msg = f'./pd help failed ({done.returncode}): {done.stderr.strip()}'
        raise RuntimeError(msg)
    return done.stdout.rstrip()


def on_page_markdown(markdown: str, **_: Any) -> str:
    """Replace the marker line with the help text in a code block.

    Args:
        markdown: The page's Markdown.
        **_: The other arguments MkDocs passes (page, config, files).

    Returns:
        The page's Markdown, the marker replaced.
    """
    if MARKER not in markdown:
        return markdown
    return markdown.replace(MARKER, f'```text\n{pd_help()}\n```')
