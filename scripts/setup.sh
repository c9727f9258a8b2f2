#!/usr/bin/env bash
# Idempotent set-up of the pseudo-dynamic testing workspace on Debian 12.
#
#   1. system packages (python3.11 with venv and headers, cmake, g++, chromium and
#      chromium-driver for the console's browser test) via apt when missing;
#   2. a virtual environment in .venv with the pinned requirements (ROS 2 Kilted wheels, numpy,
#      scipy, rosbags, matplotlib, colcon, pytest);
#   3. the colcon workspace in ros2_ws/ (build/ install/ log/), built from src/.
#
# Every stage is skipped when its inputs have not changed since it last succeeded (hashes in
# .setup-stamps/). Safe to run any number of times; the README commands call it first.
set -euo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$REPO/.venv"
WS="$REPO/ros2_ws"
STAMPS="$REPO/.setup-stamps"
mkdir -p "$STAMPS"

log() { printf '[setup] %s\n' "$*" >&2; }

# --- 1. system packages --------------------------------------------------------------------
find_python() {
    for candidate in python3.11 python3; do
        if command -v "$candidate" >/dev/null 2>&1 &&
            "$candidate" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; then
            command -v "$candidate"
            return 0
        fi
    done
    return 1
}

python_ready() {
    local py="$1"
    "$py" -c 'import ensurepip, venv, sysconfig, os, sys
sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' \
        2>/dev/null
}

need_apt=()
# An existing venv's own interpreter answers first (a version manager's shim for python3.11
# costs a tenth of a second per call, and every ./pd command runs this check).
if [ -x "$VENV/bin/python" ] && "$VENV/bin/python" -c \
    'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; then
    PYTHON="$VENV/bin/python"
else
    PYTHON="$(find_python || true)"
fi
if [ -z "$PYTHON" ] || ! python_ready "$PYTHON"; then
    need_apt+=(python3 python3-venv python3-dev)
fi
command -v cmake >/dev/null 2>&1 || need_apt+=(cmake)
command -v g++ >/dev/null 2>&1 || need_apt+=(g++)
command -v make >/dev/null 2>&1 || need_apt+=(make)
# Headless Chromium and its driver: the console's browser test (tests/graph/test_console_browser.py).
[ -x /usr/bin/chromium ] || need_apt+=(chromium)
[ -x /usr/bin/chromedriver ] || need_apt+=(chromium-driver)
# openseespy's bundled libgfortran needs the system's libquadmath (the OpenSees site tests).
# The cache listing is read whole before it is searched: piping it into `grep -q` would end the
# listing early by SIGPIPE, which `pipefail` turns into a random "missing" (and an apt run).
ld_cache="$(ldconfig -p 2>/dev/null || /sbin/ldconfig -p 2>/dev/null || true)"
case "$ld_cache" in
    *libquadmath.so.0*) ;;
    *) need_apt+=(libquadmath0) ;;
esac
unset ld_cache
if [ "${#need_apt[@]}" -gt 0 ]; then
    log "installing system packages: ${need_apt[*]}"
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need_apt[@]}" >/dev/null
    PYTHON="$(find_python || true)"
fi
if [ -z "$PYTHON" ]; then
    log "error: CPython 3.11 is required (the ROS 2 Kilted wheels are cp311); none was found"
    exit 1
fi

# --- 2. virtual environment ----------------------------------------------------------------
if [ ! -x "$VENV/bin/python" ]; then
    log "creating $VENV with $PYTHON"
    "$PYTHON" -m venv "$VENV"
fi
touch "$VENV/COLCON_IGNORE"   # colcon must not crawl into the venv

req_hash="$(sha256sum "$REPO/requirements.txt" | cut -d' ' -f1)"
if [ "$(cat "$STAMPS/requirements" 2>/dev/null)" != "$req_hash" ]; then
    log "installing pinned Python packages (first time: a few minutes)"
    # (pip's notes about unused local index folders are noise: filtered out)
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check \
        -r "$REPO/requirements.txt" 2> >(grep -v "^WARNING: Location 'file:" >&2)
    echo "$req_hash" > "$STAMPS/requirements"
fi

# --- 3. colcon workspace -------------------------------------------------------------------
# (this script is an input too: a changed build recipe rebuilds)
src_hash="$(cd "$REPO" && { find src -type f -not -name '*.pyc' -not -path '*/__pycache__/*' \
    -print0 | sort -z; printf 'scripts/setup.sh\0'; } | xargs -0 sha256sum | sha256sum \
    | cut -d' ' -f1)"
if [ "$(cat "$STAMPS/workspace" 2>/dev/null)" != "$src_hash:$req_hash" ] ||
    [ ! -f "$WS/install/setup.sh" ]; then
    log "building the colcon workspace in ros2_ws/"
    (
        export VIRTUAL_ENV="$VENV" PATH="$VENV/bin:$PATH" AMENT_PREFIX_PATH="$VENV"
        export HOME="${HOME:-$REPO}"
        mkdir -p "$WS/log"
        cd "$WS"
        colcon --log-base "$WS/log" build --base-paths "$REPO/src" --symlink-install \
            --event-handlers console_direct- \
            --cmake-args -DPython3_EXECUTABLE="$VENV/bin/python" -DBUILD_TESTING=OFF \
            > "$WS/log/last_build.txt" 2>&1 || {
                tail -n 40 "$WS/log/last_build.txt" >&2
                log "error: colcon build failed (full log: ros2_ws/log/last_build.txt)"
                exit 1
            }
        # Byte-compile the packages once here: every node process imports them at start-up,
        # and where PYTHONDONTWRITEBYTECODE is set nothing else ever writes their .pyc files
        # (each process would compile them again, ~0.3 s of CPU apiece).
        "$VENV/bin/python" -m compileall -q -j 0 "$REPO/src" > "$WS/log/compileall.txt" 2>&1 || {
            tail -n 20 "$WS/log/compileall.txt" >&2
            log "error: byte-compiling src/ failed (full log: ros2_ws/log/compileall.txt)"
            exit 1
        }
    )
    echo "$src_hash:$req_hash" > "$STAMPS/workspace"
fi
log "ready: $VENV, $WS/install"
