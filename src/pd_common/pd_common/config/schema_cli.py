"""``./pd schema``: the JSON Schema of a test file or of the bridge's parameter file.

Or the reference page of every key, on stdout; ``--write DIR`` regenerates the shipped
schemas.

    ./pd schema [--bridge] [--markdown]
    ./pd schema --write src/pd_common/schema             # after a change of the models
    ./pd schema --markdown > docs/reference/test-file.md  # the reference page
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from .schema import (
    BRIDGE_SCHEMA_FILE,
    DRIVER_CONFIG_SCHEMA_FILE,
    TEST_FILE_SCHEMA_FILE,
    json_schema,
    json_schema_text,
)
from .schema_markdown import markdown_reference

__all__ = ['main']


def _write(folder: Path) -> list[Path]:
    """Write the three schemas into ``folder``; the files written.

    Raises:
        OSError: the folder cannot be made or a file cannot be written.
    """
    texts = {folder / name: json_schema_text(bridge=bridge, driver=driver)
             for bridge, driver, name in ((False, False, TEST_FILE_SCHEMA_FILE),
                                          (True, False, BRIDGE_SCHEMA_FILE),
                                          (False, True, DRIVER_CONFIG_SCHEMA_FILE))}
    folder.mkdir(parents=True, exist_ok=True)
    for path, text in texts.items():
        path.write_text(text, encoding='utf-8')
    return list(texts)


def main(argv: Sequence[str] | None = None) -> int:
    """``./pd schema``: print the JSON Schema of a test file.

    Or of the bridge's parameter file, or their reference page in Markdown; ``--write DIR``
    regenerates the shipped files.

    Args:
        argv: the command line (default: ``sys.argv[1:]``).

    Returns:
        The exit code.
    """
    parser = argparse.ArgumentParser(
        prog='pd schema', description='The JSON Schema of a test file (for YAML editors) or of '
        "the bridge's parameter file, or the reference page of every key.")
    parser.add_argument('--bridge', action='store_true',
                        help="the bridge's ROS parameter file instead of a test file")
    parser.add_argument('--driver', action='store_true',
                        help="a driver's settings file (the bridge's driver_config) instead")
    parser.add_argument('--markdown', action='store_true',
                        help='the reference page (Markdown) of every key instead')
    parser.add_argument('--write', metavar='DIR', type=Path,
                        help='write the JSON Schemas into DIR (src/pd_common/schema)')
    args = parser.parse_args(argv)
    if args.write is not None:
        try:
            written = _write(args.write)
        except OSError as err:  # a file in the way, a read-only folder
            where = err.filename or args.write
            print(f'schema: error: {where}: cannot write ({err.strerror or err})',
                  file=sys.stderr)
            return 2
        for path in written:
            sys.stdout.write(f"{path}\n")
        return 0
    if args.markdown:
        sys.stdout.write(markdown_reference(json_schema(bridge=args.bridge, driver=args.driver),
                                            bridge=args.bridge, driver=args.driver))
    else:
        sys.stdout.write(json_schema_text(bridge=args.bridge, driver=args.driver))
    return 0


if __name__ == '__main__':
    sys.exit(main())
