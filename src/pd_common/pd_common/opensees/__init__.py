"""Serving OpenSees's ``genericClient`` element: wire format, trial/commit exchange, socket.

Pure (no ``rclpy``): the integrator's ``opensees_element`` scheme drives a test from it; the
``element_server`` executable (``./pd serve``) starts that test.
"""

from __future__ import annotations

from ..errors import ElementProtocolError
from .exchange import COMMIT, END, FORCE, ElementExchange, Event
from .link import (
    LOOPBACK,
    ElementLink,
    ElementLinkLostError,
    allow_list,
    bind_listener,
    check_bind,
)
from .wire import ACTION_NAMES, SizeMessage, Trial, decode_size_message, encode_size_message

__all__ = ['ACTION_NAMES', 'COMMIT', 'END', 'FORCE', 'LOOPBACK', 'ElementExchange',
           'ElementLink', 'ElementLinkLostError', 'ElementProtocolError', 'Event', 'SizeMessage',
           'Trial', 'allow_list', 'bind_listener', 'check_bind', 'decode_size_message',
           'encode_size_message']
