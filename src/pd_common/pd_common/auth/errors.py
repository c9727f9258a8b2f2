"""Exceptions of the message authentication."""

from __future__ import annotations

__all__ = ['AuthError', 'KeyFileError']


class AuthError(Exception):
    """Base class of the authentication errors."""


class KeyFileError(AuthError, ValueError):
    """A key file is missing, malformed, or readable by someone other than its owner."""
