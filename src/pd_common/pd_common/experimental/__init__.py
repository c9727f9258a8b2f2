"""Experimental errors (thesis section 3.4.3) and tracking monitors (command vs measured)."""

from __future__ import annotations

from .error_model import ERRORS_KEY, ErroneousStep, ErrorInjector, ErrorModel
from .tracking import TrackingMonitor, TrackingSample, tracking_error, tracking_indicator

__all__ = [
    'ERRORS_KEY',
    'ErroneousStep',
    'ErrorInjector',
    'ErrorModel',
    'TrackingMonitor',
    'TrackingSample',
    'tracking_error',
    'tracking_indicator',
]
