"""Exact solutions to verify the schemes against (a public verification API).

Nigam–Jennings piecewise-exact SDOF response to a sampled ground motion, modal
superposition for linear MDOF structures, closed-form free and harmonic vibration, an
event-driven exact response of an elastic-perfectly-plastic SDOF, and that SDOF's implicit
Newmark response solved by Newton's method (what the implicit schemes' iterations converge to).
The test suite checks every scheme's convergence against them; a lab can check its own
configuration the same way.

* :mod:`.nigam_jennings` — linear SDOF under a piecewise-linear excitation;
* :mod:`.closed_form` — free and harmonic vibration of a linear SDOF;
* :mod:`.modal` — modal superposition for a classically damped linear MDOF;
* :mod:`.epp` — event-driven exact response of an elastic-perfectly-plastic SDOF;
* :mod:`.newmark_epp` — implicit Newmark response of that SDOF, Newton to a tolerance;
* :mod:`.checks` — the input checks they share.
"""

from __future__ import annotations

from .closed_form import free_vibration, harmonic_response
from .epp import EPPResponse, epp_exact
from .modal import modal_superposition
from .newmark_epp import NewmarkEPPResponse, newmark_epp
from .nigam_jennings import nigam_jennings, nigam_jennings_coefficients

__all__ = [
    'EPPResponse',
    'NewmarkEPPResponse',
    'epp_exact',
    'free_vibration',
    'harmonic_response',
    'modal_superposition',
    'newmark_epp',
    'nigam_jennings',
    'nigam_jennings_coefficients',
]
