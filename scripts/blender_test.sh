#!/usr/bin/env bash
# Real-Blender integration test of the add-on in blender/ (see blender/tests/test_roundtrip.py).
# Blender runs headless as the `bpy` module from PyPI (Python 3.11 only), installed once into
# a cached virtual environment under .cache/ (git-ignored; the wheel is about 370 MB).
# With CI=true a failure to set it up fails the run; otherwise it prints a loud SKIP.
set -euo pipefail
cd "$(dirname "$0")/.."

BPY_VERSION=4.5.15
VENV=.cache/blender-venv

WHAT="blender integration test"
# shellcheck source=scripts/venv.sh
. scripts/venv.sh

have_packages() {
  [ -x "$VENV/bin/python" ] &&
    "$VENV/bin/python" -c "import importlib.metadata as m, sys; sys.exit(m.version('bpy') != '$BPY_VERSION')" 2>/dev/null
}

if ! have_packages; then
  PY311=$(command -v python3.11 || true)
  [ -n "$PY311" ] || unavailable "python3.11 not found (bpy $BPY_VERSION needs Python 3.11)"
  make_venv "$PY311" "bpy==$BPY_VERSION"
fi

# scripts/test.sh sets the environment up in the background while cargo builds.
[ "${1:-}" = "--setup-only" ] && exit 0

test_binary "the g1tess binary the add-on runs"

echo "== blender integration test (bpy $BPY_VERSION)"
PYTHONDONTWRITEBYTECODE=1 "$VENV/bin/python" blender/tests/test_roundtrip.py "$BIN"
