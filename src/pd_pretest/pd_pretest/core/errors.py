"""The pre-test's error: one line naming the test file and what is not supported or invalid."""

from __future__ import annotations

from pd_core.errors import ConfigError

__all__ = ['PretestError']


class PretestError(ConfigError):
    """Invalid pre-test input or a test the vectorised pre-test does not support."""
