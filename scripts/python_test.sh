#!/usr/bin/env bash
# Tests of the Python side: the g1tess package (pyo3 + maturin, built with `pip install .`
# into a cached virtual environment), Gmsh reading `export-msh` output back, and the Dask
# batch example (examples/dask_batch.py) on a LocalCluster of two workers.
# The environment (.cache/py-venv, git-ignored) gets gmsh, numpy, pytest, dask[distributed]
# and maturin from PyPI once. With CI=true a failure to set it up fails the run; otherwise
# it prints a loud SKIP.
set -euo pipefail
cd "$(dirname "$0")/.."

VENV=.cache/py-venv
# Pinned so that a run is reproducible; bump together.
PACKAGES=(gmsh==4.15.2 numpy==2.4.6 pytest==9.2.0 "dask[distributed]==2026.8.0" maturin==1.16.0)

WHAT="python tests"
# shellcheck source=scripts/venv.sh
. scripts/venv.sh

have_packages() {
  [ -x "$VENV/bin/python" ] && "$VENV/bin/python" - "${PACKAGES[@]}" <<'PY' 2>/dev/null
import importlib.metadata as m, sys
for spec in sys.argv[1:]:
    name, version = spec.split("==")
    if m.version(name.split("[")[0]) != version:
        sys.exit(1)
PY
}

if ! have_packages; then
  PY=$(command -v python3 || true)
  [ -n "$PY" ] || unavailable "python3 not found"
  "$PY" -c 'import sys; sys.exit(sys.version_info < (3, 9))' || unavailable "python3 is older than 3.9"
  make_venv "$PY" "${PACKAGES[@]}"
fi

# scripts/test.sh sets the environment up in the background while cargo builds.
[ "${1:-}" = "--setup-only" ] && exit 0

test_binary "the g1tess binary the tests compare with"

echo "== pip install . (the g1tess package: maturin, release build of python/ in target/)"
# No build isolation: maturin comes from the environment, so nothing is downloaded here.
PATH="$PWD/$VENV/bin:$PATH" "$VENV/bin/python" -m pip install -q --disable-pip-version-check \
  --no-build-isolation --force-reinstall --no-deps . 2>&1

echo "== pytest python/tests"
G1TESS_BIN="$BIN" PYTHONDONTWRITEBYTECODE=1 "$VENV/bin/python" -m pytest -q -p no:cacheprovider \
  python/tests
