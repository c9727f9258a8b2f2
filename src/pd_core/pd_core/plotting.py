"""The one way the integrator's figures get matplotlib.

``pyplot`` on the Agg backend (files, no display), imported on first use (it is the heaviest import
of a run's end).
"""

from __future__ import annotations

from typing import Any


def pyplot() -> Any:
    """``matplotlib.pyplot`` with the Agg backend selected."""
    import matplotlib as mpl  # noqa: PLC0415 - heavy; only needed for the figures

    mpl.use('Agg')
    import matplotlib.pyplot as plt  # noqa: PLC0415

    return plt
