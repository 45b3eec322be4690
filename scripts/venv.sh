# Shared by scripts/blender_test.sh and scripts/python_test.sh (sourced, not run): the cached
# virtual environment under .cache/ and the g1tess binary a test runs.
# The sourcing script sets WHAT (its name in messages), VENV, and defines `have_packages`
# (true when VENV already holds what it needs).

# With CI=true a failure to set up fails the run; otherwise a loud SKIP.
unavailable() {
  if [ "${CI:-}" = "true" ]; then
    echo "$WHAT: FAILED to set up: $1" >&2
    exit 1
  fi
  echo "!!!!!!!! SKIP $WHAT: $1 !!!!!!!!" >&2
  exit 0
}

# make_venv PYTHON PACKAGE...: creates VENV with PYTHON and installs the packages from PyPI
# (callers run it where `have_packages` says they are missing).
make_venv() {
  local py=$1
  shift
  echo "== installing $* into $VENV (once)"
  rm -rf "$VENV"
  mkdir -p "$(dirname "$VENV")"
  "$py" -m venv "$VENV" || unavailable "cannot create a virtual environment with $py"
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check "$@" ||
    unavailable "pip could not install $*"
  have_packages || unavailable "$* not importable after installation"
}

# test_binary PURPOSE: sets BIN to the g1tess binary to test. scripts/test.sh passes the one
# `cargo test --release` has just built (G1TESS_BIN), so the heavy crates are compiled once: a
# plain `cargo build --release` after `cargo test --release` recompiles wgpu and about 60 other
# crates, because dev-dependencies switch on other features of serde, bitflags and a few more.
test_binary() {
  BIN=${G1TESS_BIN:-}
  if [ -z "$BIN" ]; then
    echo "== cargo build --release ($1)"
    cargo build --release 2>&1
    BIN=target/release/g1tess
  fi
  [ -x "$BIN" ] || { echo "$WHAT: FAILED: no g1tess binary at $BIN" >&2; exit 1; }
}
