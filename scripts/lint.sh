#!/usr/bin/env bash
# The workspace's conventions (configured in pyproject.toml), run by `./pd test` before pytest:
#   1. ruff check  — lint (rule set in [tool.ruff.lint]);
#   2. mypy        — types (strict on the pure cores);
#   3. lint-imports — the import contracts (peers over a pure core, no ROS in the cores, no
#                     cycles, the integrator core's layers).
# Expects the environment of scripts/env.sh. Exits non-zero on the first failing check.
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$REPO"
echo '[lint] ruff' >&2
python -m ruff check --quiet src tests bench scripts
echo '[lint] mypy' >&2
python -m mypy
echo '[lint] import contracts' >&2
# every Python package of src/ (pd_msgs is generated): the contracts see the source tree
sources="$(find src -mindepth 2 -maxdepth 2 -name setup.py -printf '%h\n' | sort | paste -sd:)"
PYTHONPATH="$sources${PYTHONPATH:+:$PYTHONPATH}" lint-imports --no-cache --config pyproject.toml \
    > .lint-imports.log 2>&1 || { cat .lint-imports.log >&2; exit 1; }
grep -E 'KEPT|BROKEN|Contracts:' .lint-imports.log >&2
