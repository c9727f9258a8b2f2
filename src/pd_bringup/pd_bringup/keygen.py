"""Make a key file: ``./pd keygen [--out FILE] [--force]`` (``ros2 run pd_bringup keygen``).

The key authenticates every command, feedback and control of a rig's tests. Its file is
readable by its owner only (mode 0600); give its path to every node of the rig (parameter
``key_file``, ``run_test --key``, or ``rig.key_file``). The secret is never printed: only the
file's path and the key's id.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pd_common.auth import KeyFileError, generate_key

from .rig import default_rig_key


def main(argv: list[str] | None = None) -> int:
    """Entry point; 0 when the key file was made, 2 on an error."""
    parser = argparse.ArgumentParser(prog='keygen', description=__doc__.splitlines()[0])
    parser.add_argument('--out', type=Path, default=None,
                        help=f'the key file to create (default: {default_rig_key()})')
    parser.add_argument('--force', action='store_true',
                        help='replace an existing key file (every node then needs the new one)')
    args = parser.parse_args(argv)
    path = args.out or default_rig_key()
    try:
        key = generate_key(path, overwrite=args.force)
    except KeyFileError as err:
        print(f'keygen: error: {err}', file=sys.stderr)
        return 2
    print(f'keygen: {path} (key id {key.key_id}, mode 0600)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
