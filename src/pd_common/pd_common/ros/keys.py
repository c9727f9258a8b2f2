"""The key of a node: parameters ``key_file`` and ``authentication`` (declared by every node).

``key_file`` is the path of the rig's or the test's key file (``./pd keygen``; ``run_test``
makes one per simulated test); when it is empty the environment variable ``PD_KEY_FILE`` is
used. With ``authentication`` true (the default) a node without a usable key refuses to start;
``authentication:=false`` runs unauthenticated (an isolated machine whose owner asked for it).
"""

from __future__ import annotations

import os

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node

from ..auth.errors import AuthError
from ..auth.keys import KEY_FILE_ENV, Key, load_key

__all__ = ['declare_key']


def declare_key(node: Node) -> Key | None:
    """Declare ``key_file`` and ``authentication`` and load the key (``None``: off).

    Raises:
        AuthError: authentication is on and there is no key file, or it cannot be used (one
            line naming the file and what is wrong).
    """
    node.declare_parameter('key_file', '', ParameterDescriptor(
        description=f'key file of the rig or test (default: ${KEY_FILE_ENV})'))
    node.declare_parameter('authentication', True, ParameterDescriptor(
        description='authenticate commands, feedback and controls (false: isolated machine)'))
    path = str(node.get_parameter('key_file').value) or os.environ.get(KEY_FILE_ENV, '')
    if not bool(node.get_parameter('authentication').value):
        return None
    if not path:
        msg = (f'parameter key_file: a key file is required (make one with ./pd keygen, or set '
               f'{KEY_FILE_ENV}); authentication:=false runs without one')
        raise AuthError(msg)
    return load_key(path)
