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
sources="src/pd_common:src/pd_integrator:src/pd_actuator_bridge:src/pd_specimen_sim:src/pd_bringup"
PYTHONPATH="$sources${PYTHONPATH:+:$PYTHONPATH}" lint-imports --no-cache --config pyproject.toml \
    > .lint-imports.log 2>&1 || { cat .lint-imports.log >&2; exit 1; }
grep -E 'KEPT|BROKEN|Contracts:' .lint-imports.log >&2
