"""The integration scheme ``central_difference``.

The central difference method is Newmark's with ``β = 0``, ``γ = 1/2``: the same recursion as
``newmark_explicit`` (thesis eqs. 3.20-3.22), under its textbook name. The scheme's facts
(stability limit, order, parameters, softening note) are class attributes, inherited here.
"""

from __future__ import annotations

from typing import ClassVar

from pd_core.schemes import NewmarkExplicit


class CentralDifference(NewmarkExplicit):
    """Central difference: Newmark explicit under its textbook name (``Ω ≤ 2``, 2nd order)."""

    name: ClassVar[str] = 'central_difference'
