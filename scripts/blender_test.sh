#!/usr/bin/env bash
# Real-Blender integration test of the add-on in blender/ (see blender/tests/test_roundtrip.py).
# Blender runs headless as the `bpy` module from PyPI (Python 3.11 only), installed once into
# a cached virtual environment under .cache/ (git-ignored; the wheel is about 370 MB).
# With CI=true a failure to set it up fails the run; otherwise it prints a loud SKIP.
set -euo pipefail
cd "$(dirname "$0")/.."

BPY_VERSION=4.5.15
VENV=.cache/blender-venv

unavailable() {
  if [ "${CI:-}" = "true" ]; then
    echo "blender: FAILED to set up: $1" >&2
    exit 1
  fi
  echo "!!!!!!!! SKIP blender integration test: $1 !!!!!!!!" >&2
  exit 0
}

have_bpy() {
  [ -x "$VENV/bin/python" ] &&
    "$VENV/bin/python" -c "import importlib.metadata as m, sys; sys.exit(m.version('bpy') != '$BPY_VERSION')" 2>/dev/null
}

if ! have_bpy; then
  PY311=$(command -v python3.11 || true)
  [ -n "$PY311" ] || unavailable "python3.11 not found (bpy $BPY_VERSION needs Python 3.11)"
  echo "== installing bpy==$BPY_VERSION into $VENV (once)"
  rm -rf "$VENV"
  mkdir -p "$(dirname "$VENV")"
  "$PY311" -m venv "$VENV" || unavailable "cannot create a Python 3.11 virtual environment"
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check "bpy==$BPY_VERSION" ||
    unavailable "pip could not install bpy==$BPY_VERSION"
  have_bpy || unavailable "bpy $BPY_VERSION not importable after installation"
fi

# scripts/test.sh sets the environment up in the background while cargo builds.
[ "${1:-}" = "--setup-only" ] && exit 0

# scripts/test.sh passes the binary `cargo test --release` has just built (G1TESS_BIN), so the
# heavy crates are compiled once: a plain `cargo build --release` after `cargo test --release`
# recompiles wgpu and about 60 other crates, because dev-dependencies switch on other features
# of serde, bitflags and a few more.
BIN=${G1TESS_BIN:-}
if [ -z "$BIN" ]; then
  echo "== cargo build --release (the g1tess binary the add-on runs)"
  cargo build --release 2>&1
  BIN=target/release/g1tess
fi
[ -x "$BIN" ] || { echo "blender: FAILED: no g1tess binary at $BIN" >&2; exit 1; }

echo "== blender integration test (bpy $BPY_VERSION)"
PYTHONDONTWRITEBYTECODE=1 "$VENV/bin/python" blender/tests/test_roundtrip.py "$BIN"
